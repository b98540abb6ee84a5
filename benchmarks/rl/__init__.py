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
from benchmarks.rl.policies import DesignResult, design_for_goal, load_policy, save_policy
from benchmarks.rl.suite import SIZES, SuiteSize, run_rl_suite

__all__ = [
    "SIZES",
    "ContextualConfig",
    "DesignResult",
    "SuiteSize",
    "design_for_goal",
    "load_policy",
    "run_rl_suite",
    "save_policy",
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
