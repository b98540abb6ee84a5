"""Configurations of the RL baselines: frozen dataclasses, read from TOML files.

The tuned configurations are committed in ``benchmarks/rl/configs/`` (``ppo.toml``,
``sac.toml``, ``contextual.toml``); ``docs/rl.md`` lists what was tried and measured.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Iterable
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = [
    "CONFIG_DIR",
    "ContextualConfig",
    "MethodConfig",
    "PPOConfig",
    "SACConfig",
    "default_config",
    "learned_configs",
    "load_config",
    "training_episodes",
]

#: The committed, tuned configurations.
CONFIG_DIR = Path(__file__).resolve().parent / "configs"


def _positive_int(name: str, value: Any) -> None:
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"{name} must be an int, got {value!r}")
    if value < 1:
        raise ValueError(f"{name} must be >= 1, got {value!r}")


def _number(name: str, value: Any, low: float, high: float) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"{name} must be a number, got {value!r}")
    if not (math.isfinite(value) and low <= value <= high):
        raise ValueError(f"{name} must be in [{low:g}, {high:g}], got {value!r}")


def _net_arch(value: Any) -> None:
    if not isinstance(value, tuple) or not value:
        raise TypeError(f"net_arch must be a non-empty tuple of layer widths, got {value!r}")
    for width in value:
        _positive_int("net_arch[i]", width)


@dataclass(frozen=True, kw_only=True)
class PPOConfig:
    """PPO (Stable-Baselines3) on ``ToolDesignRL-v0``. One step is one episode.

    Attributes:
        n_steps: episodes collected per update.
        batch_size: minibatch size, <= n_steps.
        n_epochs: passes over each rollout.
        learning_rate: Adam step size.
        log_std_init: initial log standard deviation of the Gaussian policy (action units).
        ent_coef: entropy bonus.
        clip_range: PPO's ratio clip.
        net_arch: hidden layer widths of the policy and value networks.
        reward_scale: factor on the normalized reward the agent sees (F is logged unscaled).
    """

    n_steps: int = 32
    batch_size: int = 32
    n_epochs: int = 10
    learning_rate: float = 3e-4
    log_std_init: float = 0.0
    ent_coef: float = 0.0
    clip_range: float = 0.2
    net_arch: tuple[int, ...] = (64, 64)
    reward_scale: float = 1.0

    def __post_init__(self) -> None:
        for name in ("n_steps", "batch_size", "n_epochs"):
            _positive_int(name, getattr(self, name))
        if self.batch_size > self.n_steps:
            raise ValueError(f"batch_size must be <= n_steps, got {self.batch_size}")
        _number("learning_rate", self.learning_rate, 1e-7, 1.0)
        _number("log_std_init", self.log_std_init, -5.0, 2.0)
        _number("ent_coef", self.ent_coef, 0.0, 1.0)
        _number("clip_range", self.clip_range, 1e-3, 1.0)
        _number("reward_scale", self.reward_scale, 1e-3, 1e4)
        _net_arch(self.net_arch)


@dataclass(frozen=True, kw_only=True)
class SACConfig:
    """SAC (Stable-Baselines3) on ``ToolDesignRL-v0``. One step is one episode.

    Attributes:
        learning_starts: random episodes before learning starts.
        batch_size: minibatch size.
        learning_rate: Adam step size.
        gradient_steps: gradient steps per episode.
        ent_coef: entropy coefficient, a number or ``"auto"`` / ``"auto_<init>"``.
        net_arch: hidden layer widths of the actor and the critics.
        reward_scale: factor on the normalized reward the agent sees (F is logged unscaled).
    """

    learning_starts: int = 32
    batch_size: int = 64
    learning_rate: float = 3e-4
    gradient_steps: int = 1
    ent_coef: float | str = "auto"
    net_arch: tuple[int, ...] = (64, 64)
    reward_scale: float = 1.0

    def __post_init__(self) -> None:
        for name in ("learning_starts", "batch_size", "gradient_steps"):
            _positive_int(name, getattr(self, name))
        _number("learning_rate", self.learning_rate, 1e-7, 1.0)
        if isinstance(self.ent_coef, str):
            if not self.ent_coef.startswith("auto"):
                raise ValueError(
                    f"ent_coef must be a number or 'auto[_init]', got {self.ent_coef!r}"
                )
        else:
            _number("ent_coef", self.ent_coef, 0.0, 10.0)
        _number("reward_scale", self.reward_scale, 1e-3, 1e4)
        _net_arch(self.net_arch)


@dataclass(frozen=True, kw_only=True)
class ContextualConfig:
    """Goal -> coefficients regression over CMA-ES optima (a method for a contextual bandit).

    Training runs CMA-ES afresh on ``n_goals`` goals drawn from the paper's range, each with
    ``episodes_per_goal`` episodes, and keeps each goal's best design. A new goal gets the
    designs of the training goals weighted by a Gaussian kernel of the goal distance
    (``mode="kernel"``) or the nearest training goal's design (``mode="nearest"``). Trained with
    randomized box masses, the task is the goal and the mass, and a kg of mass difference counts
    as ``mass_scale`` m of goal distance.

    Attributes:
        n_goals: training goals.
        episodes_per_goal: CMA-ES evaluations per training goal.
        popsize: CMA-ES population size.
        sigma0: CMA-ES initial step, a fraction of the [-1, 1] action box.
        bandwidth: kernel width in m (``mode="kernel"``).
        mode: ``"kernel"`` or ``"nearest"``.
        mass_scale: m of goal distance per kg of box-mass difference (tasks with masses).
    """

    n_goals: int = 8
    episodes_per_goal: int = 32
    popsize: int = 8
    sigma0: float = 0.3
    bandwidth: float = 0.25
    mode: str = "kernel"
    mass_scale: float = 1.0

    def __post_init__(self) -> None:
        for name in ("n_goals", "episodes_per_goal", "popsize"):
            _positive_int(name, getattr(self, name))
        if self.popsize < 2:
            raise ValueError(f"popsize must be >= 2 (CMA-ES), got {self.popsize}")
        _number("sigma0", self.sigma0, 1e-6, 1.0)
        _number("bandwidth", self.bandwidth, 1e-6, 10.0)
        _number("mass_scale", self.mass_scale, 1e-6, 1e6)
        if self.mode not in ("kernel", "nearest"):
            raise ValueError(f"mode must be 'kernel' or 'nearest', got {self.mode!r}")

    @property
    def total_episodes(self) -> int:
        """Episodes spent in training: n_goals * episodes_per_goal."""
        return self.n_goals * self.episodes_per_goal


MethodConfig = PPOConfig | SACConfig | ContextualConfig

_CLASSES: dict[str, type[PPOConfig] | type[SACConfig] | type[ContextualConfig]] = {
    "ppo": PPOConfig,
    "sac": SACConfig,
    "contextual": ContextualConfig,
}


def load_config(path: str | os.PathLike[str]) -> MethodConfig:
    """Read a configuration from a TOML file with ``method = "ppo" | "sac" | "contextual"``.

    Other keys are the fields of the method's dataclass; lists become tuples.

    Raises:
        FileNotFoundError: no such file.
        ValueError: no or an unknown ``method``, an unknown key, or a bad value.
        TypeError: a value of the wrong type.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {path!r}")
    with open(path, "rb") as handle:
        data = tomllib.load(handle)
    method = data.pop("method", None)
    if method not in _CLASSES:
        raise ValueError(f"{path}: method must be one of {sorted(_CLASSES)}, got {method!r}")
    cls = _CLASSES[method]
    known = {f.name for f in fields(cls)}
    unknown = set(data) - known
    if unknown:
        raise ValueError(
            f"{path}: unknown keys {sorted(unknown)} for {method}; allowed {sorted(known)}"
        )
    values: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items()}
    return cls(**values)


def default_config(method: str) -> MethodConfig:
    """The committed, tuned configuration of ``method`` (``configs/<method>.toml``).

    Raises:
        ValueError: an unknown method.
    """
    if method not in _CLASSES:
        raise ValueError(f"method must be one of {sorted(_CLASSES)}, got {method!r}")
    return load_config(CONFIG_DIR / f"{method}.toml")


def learned_configs(
    *,
    train_episodes: int,
    contextual_goals: int,
    popsize: int,
    overrides: Iterable[tuple[str, str, Any]] = (),
) -> dict[str, MethodConfig]:
    """The committed configurations of PPO, SAC and the contextual method, sized for a run.

    The contextual method spreads ``train_episodes`` over ``contextual_goals`` CMA-ES runs (at
    least one episode each) of population ``popsize``; then each ``(method, field, value)`` of
    ``overrides`` replaces that field (a small size's tiny rollouts). The rl suite and the
    break-even study size their learned methods this way.

    Raises:
        TypeError / ValueError: an override naming an unknown method or field, or a bad value.
    """
    configs: dict[str, MethodConfig] = {m: default_config(m) for m in ("ppo", "sac")}
    contextual = default_config("contextual")
    assert isinstance(contextual, ContextualConfig)
    configs["contextual"] = replace(
        contextual,
        n_goals=contextual_goals,
        episodes_per_goal=max(1, train_episodes // contextual_goals),
        popsize=popsize,
    )
    changes: dict[str, dict[str, Any]] = {}
    for method, name, value in overrides:
        changes.setdefault(method, {})[name] = value
    for method, fields_ in changes.items():
        configs[method] = replace(configs[method], **fields_)
    return configs


def training_episodes(config: MethodConfig, episodes: int) -> int:
    """Episodes one training with ``config`` simulates when asked for ``episodes``.

    The contextual method runs its own count (``total_episodes``); PPO rounds up to whole
    rollouts of ``n_steps``; SAC runs ``episodes``.
    """
    if isinstance(config, ContextualConfig):
        return config.total_episodes
    steps = getattr(config, "n_steps", 1)
    return -(-episodes // steps) * steps
