"""Saved policies: write a trained baseline to disk, and design a tool for a new goal with it.

A saved policy is a small JSON card (``<name>.json``) naming the method, the training budget, the
configuration and, for PPO and SAC, the Stable-Baselines3 ``.zip`` beside it; the contextual
regression is stored in the card itself (no torch needed to use it). The card also records the
task it was trained on: the tool's section and the arm (``section_shape``,
``merge_fixed_links``), which the env it designs with is built with, and the ranges of its
training goals and box masses (``goal_range``, ``mass_range``), outside which designing warns.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import warnings
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
    "CARD_ADDED_FIELDS",
    "POLICY_FORMAT",
    "DesignResult",
    "design_for_goal",
    "load_policy",
    "policy_digest",
    "policy_env_kwargs",
    "read_policy_card",
    "save_policy",
]

#: Version of the card format.
POLICY_FORMAT = 1
_METHODS = ("ppo", "sac", "contextual")

#: Card fields added after the first cards were written, with the value those cards were trained
#: with: the committed rl suite (docs/results/rl, commit a327f7f) ran with the square section
#: and the 13-link arm, the defaults then. A card without a field is read with this value.
CARD_ADDED_FIELDS: dict[str, Any] = {"section_shape": "square", "merge_fixed_links": False}

#: The fields of a contextual card's ``policy`` (:meth:`ContextualPolicy.to_dict`).
_CONTEXTUAL_FIELDS = ("goals", "actions", "bandwidth", "mode")


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
    section_shape: str | None = None,
    merge_fixed_links: bool | None = None,
    goal_range: tuple[Sequence[float], Sequence[float]] | None = None,
    mass_range: Sequence[float] | None = None,
    extra: dict[str, Any] | None = None,
) -> Path:
    """Save a trained baseline as ``path`` (a ``.json`` card, plus ``.zip`` for PPO/SAC).

    Args:
        model: a Stable-Baselines3 PPO/SAC model or a :class:`ContextualPolicy`.
        method: ``"ppo"``, ``"sac"`` or ``"contextual"``.
        path: the card's path; must end in ``.json``.
        config: the configuration it was trained with.
        train_episodes: episodes its training spent.
        section_shape: the tool's section it was trained with (default: ``ToolSpec``'s).
        merge_fixed_links: the ``SceneSpec`` field it was trained with (default: today's).
        goal_range: (low, high), the (x, y, z) corners (m) of its training goals; designing
            outside warns. None records no range (and nothing warns).
        mass_range: (low, high), its training box masses (kg); likewise.
        extra: more JSON-ready fields for the card (seed, suite size, ...).

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
    from tooldesign_env.geometry import ToolSpec
    from tooldesign_env.specs import SceneSpec

    settings: dict[str, Any] = {
        "section_shape": ToolSpec().section_shape if section_shape is None else section_shape,
        "merge_fixed_links": SceneSpec().merge_fixed_links
        if merge_fixed_links is None
        else merge_fixed_links,
    }
    if goal_range is not None:
        settings["goal_range"] = [[float(v) for v in corner] for corner in goal_range]
    if mass_range is not None:
        settings["mass_range"] = [float(v) for v in mass_range]
    _check_settings(settings, card_path)
    card: dict[str, Any] = {
        "format": POLICY_FORMAT,
        "method": method,
        "env_id": "ToolDesignRL-v0",
        "train_episodes": int(train_episodes),
        "config": dataclasses.asdict(config),
        **(extra or {}),
        **settings,
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
    card = _parse_card(card_path, data)
    digest = hashlib.sha256(data)
    if "file" in card:
        zip_path = card_path.parent / card["file"]
        if not zip_path.is_file():
            raise FileNotFoundError(f"{card_path} names {zip_path}, which does not exist")
        digest.update(zip_path.read_bytes())
    return digest.hexdigest()


def read_policy_card(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The checked card of a saved policy, without loading its model (no torch).

    A card written before a field of :data:`CARD_ADDED_FIELDS` reads with that field's value.

    Raises:
        FileNotFoundError: no such card.
        ValueError / TypeError: not a policy card, or a field of the wrong value or type; the
            message names the card and the field.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {path!r}")
    card_path = Path(path)
    return _parse_card(card_path, card_path.read_bytes())


def _parse_card(card_path: Path, data: bytes) -> dict[str, Any]:
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise ValueError(f"{card_path} is not a policy card (not UTF-8 text: {error})") from None
    try:
        card = json.loads(text)
    except json.JSONDecodeError as error:
        raise ValueError(f"{card_path} is not a policy card (invalid JSON: {error})") from None
    if not isinstance(card, dict) or card.get("format") != POLICY_FORMAT:
        raise ValueError(f"{card_path} is not a policy card of format {POLICY_FORMAT}")
    method = card.get("method")
    if method not in _METHODS:
        raise ValueError(f"{card_path}: 'method' must be one of {_METHODS}, got {method!r}")
    if method == "contextual":
        if "policy" not in card:
            raise ValueError(
                f"{card_path}: a contextual card holds its regression in the field 'policy', "
                "which is missing"
            )
        policy = card["policy"]
        if not isinstance(policy, dict):
            raise TypeError(
                f"{card_path}: 'policy' must be an object with the fields "
                f"{', '.join(_CONTEXTUAL_FIELDS)}, got {policy!r}"
            )
        missing = [name for name in _CONTEXTUAL_FIELDS if name not in policy]
        if missing:
            raise ValueError(f"{card_path}: 'policy' lacks the fields {', '.join(missing)}")
    else:
        if "file" not in card:
            raise ValueError(
                f"{card_path}: a {method} card names its Stable-Baselines3 model in the field "
                "'file', which is missing"
            )
        if not isinstance(card["file"], str):
            raise TypeError(
                f"{card_path}: 'file' must be the name of the .zip beside the card, "
                f"got {card['file']!r}"
            )
        if not card["file"]:
            raise ValueError(f"{card_path}: 'file' must name the .zip beside the card, got ''")
    card = {**CARD_ADDED_FIELDS, **card}
    _check_settings(card, card_path)
    return card


def _check_settings(card: dict[str, Any], card_path: Path) -> None:
    """Check the task fields of a card (section, arm, ranges); the errors name the field."""
    from tooldesign_env.geometry import SECTION_SHAPES

    section = card["section_shape"]
    if not isinstance(section, str):
        raise TypeError(
            f"{card_path}: 'section_shape' must be one of {SECTION_SHAPES}, got {section!r}"
        )
    if section not in SECTION_SHAPES:
        raise ValueError(
            f"{card_path}: 'section_shape' must be one of {SECTION_SHAPES}, got {section!r}"
        )
    if not isinstance(card["merge_fixed_links"], bool):
        raise TypeError(
            f"{card_path}: 'merge_fixed_links' must be true or false, "
            f"got {card['merge_fixed_links']!r}"
        )
    if "goal_range" in card:
        what = "two (x, y, z) corners in m"
        _check_pairs(card["goal_range"], card_path, "goal_range", what)
        if len(card["goal_range"][0]) != 3:
            raise TypeError(f"{card_path}: 'goal_range' must be {what}, got {card['goal_range']!r}")
    if "mass_range" in card:
        value = card["mass_range"]
        pair = [[v] for v in value] if isinstance(value, list) else value
        _check_pairs(pair, card_path, "mass_range", "[low, high] in kg", shown=value)
        if value[0] <= 0:
            raise ValueError(f"{card_path}: 'mass_range' must be > 0 kg, got {value!r}")


def _check_pairs(
    value: Any, card_path: Path, name: str, what: str, *, shown: Any = None
) -> None:
    """``value`` must be [low, high], two equally long lists of finite numbers, low <= high.

    ``shown``: what the card holds, for the message, if ``value`` was reshaped from it.
    """
    shown = value if shown is None else shown
    if (
        not isinstance(value, list)
        or len(value) != 2
        or any(not isinstance(corner, list) for corner in value)
        or len(value[0]) != len(value[1])
        or any(isinstance(v, bool) or not isinstance(v, (int, float)) for c in value for v in c)
    ):
        raise TypeError(f"{card_path}: '{name}' must be {what}, got {shown!r}")
    low, high = value
    if not all(math.isfinite(v) for v in (*low, *high)) or any(
        lo > hi for lo, hi in zip(low, high, strict=True)
    ):
        raise ValueError(
            f"{card_path}: '{name}' must be {what}, finite with low <= high, got {shown!r}"
        )


def policy_env_kwargs(card: dict[str, Any]) -> dict[str, Any]:
    """The ``ToolDesignRL-v0`` arguments that rebuild a card's training task (tool, scene).

    Args:
        card: a card from :func:`read_policy_card` or :func:`load_policy`.

    Returns:
        ``{"tool": ToolSpec(section_shape=...), "scene": SceneSpec(merge_fixed_links=...)}``.
    """
    from tooldesign_env.geometry import ToolSpec
    from tooldesign_env.specs import SceneSpec

    settings = {**CARD_ADDED_FIELDS, **card}
    return {
        "tool": ToolSpec(section_shape=settings["section_shape"]),
        "scene": SceneSpec(merge_fixed_links=settings["merge_fixed_links"]),
    }


def load_policy(path: str | os.PathLike[str]) -> tuple[Any, dict[str, Any]]:
    """Load a saved policy card; returns the policy (with ``predict``) and the card.

    The card is :func:`read_policy_card`'s: checked, with :data:`CARD_ADDED_FIELDS` filled in.

    Raises:
        FileNotFoundError: no such card (or its ``.zip`` is missing).
        ValueError / TypeError: not a policy card of a known format and method, or a field of
            the wrong value or type; the message names the card and the field.
    """
    card = read_policy_card(path)
    card_path = Path(path)
    method = card["method"]
    if method == "contextual":
        try:
            return ContextualPolicy.from_dict(card["policy"]), card
        except (TypeError, ValueError) as error:
            raise type(error)(f"{card_path}: 'policy': {error}") from None
    zip_path = card_path.parent / card["file"]
    if not zip_path.is_file():
        raise FileNotFoundError(f"{card_path} names {zip_path}, which does not exist")
    from benchmarks.rl.agents import _torch_single_thread, import_sb3

    algorithm = getattr(import_sb3(), method.upper())
    _torch_single_thread()
    return algorithm.load(zip_path, device="cpu"), card


def _warn_outside_training(card: dict[str, Any], card_path: Any, goal: Any, mass: float) -> None:
    """Warn when the task lies outside the ranges the card records (none: no warning)."""
    if "goal_range" in card:
        low, high = (np.asarray(corner, dtype=float) for corner in card["goal_range"])
        g = np.asarray(goal, dtype=float)
        if np.any(g < low) or np.any(g > high):
            warnings.warn(
                f"the goal {g.tolist()} is outside the goals {card_path} was trained on "
                f"({low.tolist()} to {high.tolist()} m): the policy extrapolates",
                UserWarning,
                stacklevel=3,
            )
    if "mass_range" in card:
        lo, hi = (float(v) for v in card["mass_range"])
        if not lo <= mass <= hi:
            warnings.warn(
                f"the box mass {mass:g} kg is outside the masses {card_path} was trained on "
                f"({lo:g} to {hi:g} kg): the policy extrapolates",
                UserWarning,
                stacklevel=3,
            )


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

    The tool is simulated with the section and arm the policy was trained with (the card's
    ``section_shape`` and ``merge_fixed_links``; the committed cards: square, 13 links). A goal
    closer than :data:`~tooldesign_env.rl.MIN_GOAL_DISTANCE` to the box's start is designed and
    scored by F alone: its ``normalized_reward`` is NaN (the reward has no scale there). A goal
    or mass outside the card's ``goal_range`` / ``mass_range`` warns (``UserWarning``); a card
    without them (those written before the fields) never warns.

    Returns:
        The design, and its F when simulated.

    Raises:
        TypeError / ValueError: a bad goal or box mass (from the env), a bad card.
        FileNotFoundError: no such card.
    """
    if not isinstance(simulate, bool):
        raise TypeError(f"simulate must be True or False, got {simulate!r}")
    policy, card = load_policy(policy_path)
    # reward="free-energy" takes every goal: one within MIN_GOAL_DISTANCE of the box's start,
    # where the normalized reward has no scale, is designed and scored by F alone. The record's
    # normalized reward is info's either way (NaN that near).
    env = make_env(**policy_env_kwargs(card), reward="free-energy")
    logged = EpisodeLog(env)
    try:
        obs, info = logged.reset(options={"goal": goal, "box_mass": box_mass})
        _warn_outside_training(card, policy_path, info["goal"], float(info["box_mass"]))
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
