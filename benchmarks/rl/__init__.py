"""RL-agent baselines on ``ToolDesignRL-v0`` and the ``rl`` suite (see ``docs/rl.md``).

Plain functions, no argument parsing: :func:`train_ppo`, :func:`train_sac`,
:func:`train_contextual`, :func:`run_random`, :func:`run_cmaes`, :func:`evaluate_design`,
:func:`run_rl_suite`, :func:`save_policy` and :func:`design_for_goal`.
``python -m benchmarks.rl`` is a thin command line over them.
"""

from __future__ import annotations

from benchmarks.rl.agents import (
    ContextualPolicy,
    EpisodeLog,
    EpisodeRecord,
    evaluate_design,
    make_env,
    run_cmaes,
    run_random,
    train_contextual,
    train_ppo,
    train_sac,
)
from benchmarks.rl.configs import (
    ContextualConfig,
    PPOConfig,
    SACConfig,
    default_config,
    load_config,
)

__all__ = [
    "ContextualConfig",
    "ContextualPolicy",
    "EpisodeLog",
    "EpisodeRecord",
    "PPOConfig",
    "SACConfig",
    "default_config",
    "evaluate_design",
    "load_config",
    "make_env",
    "run_cmaes",
    "run_random",
    "train_contextual",
    "train_ppo",
    "train_sac",
]
