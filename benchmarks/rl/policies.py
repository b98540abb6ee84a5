"""Saved policies: write a trained baseline to disk, and design a tool for a new goal with it.

A saved policy is a small JSON card (``<name>.json``) naming the method, the training budget, the
configuration and, for PPO and SAC, the Stable-Baselines3 ``.zip`` beside it; the contextual
regression is stored in the card itself (no torch needed to use it).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.rl.agents import ContextualPolicy, EpisodeLog, make_env
from benchmarks.rl.configs import MethodConfig
from benchmarks.storage import atomic_write_bytes, atomic_write_text, json_text
from tooldesign_env.schema import DEFAULT_BOX_MASS

__all__ = [
    "POLICY_FORMAT",
    "DesignResult",
    "design_for_goal",
    "load_policy",
    "policy_digest",
    "save_policy",
]

#: Version of the card format.
POLICY_FORMAT = 1
_METHODS = ("ppo", "sac", "contextual")


@dataclass(frozen=True)
class DesignResult:
    """A tool designed by a saved policy for one goal.

    Attributes:
        goal: (x, y, z) in m.
        box_mass: kg.
        action: (3,) the policy's action in [-1, 1].
        coefficients: (3,) the tool's coefficients (c1, c2, c3).
        free_energy: F of the tool at the goal (NaN if not simulated).
        normalized_reward: 1 - F / F_idle (NaN if not simulated).
        final_distance: the box's final distance to the goal, m (NaN if not simulated).
        valid: whether the design could be used (None if not simulated).
    """

    goal: tuple[float, float, float]
    box_mass: float
    action: tuple[float, ...]
    coefficients: tuple[float, ...]
    free_energy: float
    normalized_reward: float
    final_distance: float
    valid: bool | None


def save_policy(
    model: Any,
    method: str,
    path: str | os.PathLike[str],
    *,
    config: MethodConfig,
    train_episodes: int,
    extra: dict[str, Any] | None = None,
) -> Path:
    """Save a trained baseline as ``path`` (a ``.json`` card, plus ``.zip`` for PPO/SAC).

    Args:
        model: a Stable-Baselines3 PPO/SAC model or a :class:`ContextualPolicy`.
        method: ``"ppo"``, ``"sac"`` or ``"contextual"``.
        path: the card's path; must end in ``.json``.
        config: the configuration it was trained with.
        train_episodes: episodes its training spent.
        extra: more JSON-ready fields for the card (seed, goal range, ...).

    Returns:
        The card's path.

    Raises:
        ValueError: an unknown method, or a path not ending in ``.json``.
        TypeError: a model that does not fit the method.
    """
    if method not in _METHODS:
        raise ValueError(f"method must be one of {_METHODS}, got {method!r}")
    card_path = Path(path)
    if card_path.suffix != ".json":
        raise ValueError(f"path must end in .json (the policy card), got {str(path)!r}")
    card: dict[str, Any] = {
        "format": POLICY_FORMAT,
        "method": method,
        "env_id": "ToolDesignRL-v0",
        "train_episodes": int(train_episodes),
        "config": dataclasses.asdict(config),
        **(extra or {}),
    }
    if method == "contextual":
        if not isinstance(model, ContextualPolicy):
            raise TypeError(f"a contextual policy must be a ContextualPolicy, got {model!r}")
        card["policy"] = model.to_dict()
    else:
        if not hasattr(model, "save"):
            raise TypeError(f"a {method} policy must be a Stable-Baselines3 model, got {model!r}")
        zip_path = card_path.with_suffix(".zip")
        # Save to memory first so that the file appears whole (the atomic write).
        import io

        buffer = io.BytesIO()
        model.save(buffer, exclude=["replay_buffer"])
        atomic_write_bytes(zip_path, buffer.getvalue())
        card["file"] = zip_path.name
    return atomic_write_text(card_path, json_text(card))


def policy_digest(path: str | os.PathLike[str]) -> str:
    """SHA-256 of a saved policy: its card and, for PPO and SAC, the ``.zip`` it names.

    A design run made with a policy records it, so that resuming with a changed policy is
    refused instead of mixing two policies' designs.

    Raises:
        FileNotFoundError: no such card (or its ``.zip`` is missing).
        ValueError: not a policy card of a known format.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {path!r}")
    card_path = Path(path)
    data = card_path.read_bytes()
    try:
        card = json.loads(data)
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise ValueError(f"{card_path} is not a policy card (invalid JSON: {error})") from None
    if not isinstance(card, dict) or card.get("format") != POLICY_FORMAT:
        raise ValueError(f"{card_path} is not a policy card of format {POLICY_FORMAT}")
    digest = hashlib.sha256(data)
    if isinstance(card.get("file"), str):
        zip_path = card_path.parent / card["file"]
        if not zip_path.is_file():
            raise FileNotFoundError(f"{card_path} names {zip_path}, which does not exist")
        digest.update(zip_path.read_bytes())
    return digest.hexdigest()


def load_policy(path: str | os.PathLike[str]) -> tuple[Any, dict[str, Any]]:
    """Load a saved policy card; returns the policy (with ``predict``) and the card.

    Raises:
        FileNotFoundError: no such card (or its ``.zip`` is missing).
        ValueError: not a policy card of a known format and method.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {path!r}")
    card_path = Path(path)
    try:
        card = json.loads(card_path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as error:
        raise ValueError(f"{card_path} is not a policy card (invalid JSON: {error})") from None
    if not isinstance(card, dict) or card.get("format") != POLICY_FORMAT:
        raise ValueError(f"{card_path} is not a policy card of format {POLICY_FORMAT}")
    method = card.get("method")
    if method == "contextual":
        return ContextualPolicy.from_dict(card["policy"]), card
    if method in ("ppo", "sac"):
        zip_path = card_path.parent / card["file"]
        if not zip_path.is_file():
            raise FileNotFoundError(f"{card_path} names {zip_path}, which does not exist")
        from benchmarks.rl.agents import _torch_single_thread, import_sb3

        algorithm = getattr(import_sb3(), method.upper())
        _torch_single_thread()
        return algorithm.load(zip_path, device="cpu"), card
    raise ValueError(f"{card_path}: method must be one of {_METHODS}, got {method!r}")


def design_for_goal(
    policy_path: str | os.PathLike[str],
    goal: Sequence[float],
    *,
    box_mass: float = DEFAULT_BOX_MASS,
    simulate: bool = True,
) -> DesignResult:
    """Design a tool for ``goal`` with a saved policy (zero-shot), and score it.

    Args:
        policy_path: a policy card written by :func:`save_policy`.
        goal: (x, y, z) in m, inside the workspace (x, y in [-2.5, 2.5], z in [0, 1]); the
            policies were trained on x in [-0.5, 0.5], y in [0.5, 1.5], z = 0.1.
        box_mass: the box mass in kg.
        simulate: simulate the tool to report F (one episode, about 0.2 s); False returns the
            design only.

    Returns:
        The design, and its F when simulated.

    Raises:
        TypeError / ValueError: a bad goal or box mass (from the env), a bad card.
        FileNotFoundError: no such card.
    """
    if not isinstance(simulate, bool):
        raise TypeError(f"simulate must be True or False, got {simulate!r}")
    policy, _ = load_policy(policy_path)
    env = make_env()
    logged = EpisodeLog(env)
    try:
        obs, info = logged.reset(options={"goal": goal, "box_mass": box_mass})
        action, _ = policy.predict(obs, deterministic=True)
        action = np.clip(np.asarray(action, dtype=np.float32).ravel(), -1.0, 1.0)
        coefficients = env.to_coefficients(action)
        nan = float("nan")
        result = DesignResult(
            goal=tuple(float(v) for v in info["goal"]),  # type: ignore[arg-type]
            box_mass=float(info["box_mass"]),
            action=tuple(float(a) for a in action),
            coefficients=tuple(float(c) for c in coefficients),
            free_energy=nan,
            normalized_reward=nan,
            final_distance=nan,
            valid=None,
        )
        if simulate:
            logged.step(action)
            record = logged.records[-1]
            result = dataclasses.replace(
                result,
                free_energy=record.free_energy,
                normalized_reward=record.reward,
                final_distance=record.final_distance,
                valid=record.valid,
            )
    finally:
        logged.close()
    return result
