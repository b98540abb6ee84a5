"""RL-agent baselines on ``ToolDesignRL-v0`` and the ``rl`` suite (see ``docs/rl.md``).

Plain functions, no argument parsing: :func:`train_ppo`, :func:`train_sac`,
:func:`train_contextual`, :func:`run_random`, :func:`run_cmaes`, :func:`evaluate_design`,
:func:`rl_suite_config` and :func:`run_rl_suite` (the suite, into a run folder like every
suite's), :func:`save_policy` and :func:`design_for_goal`; the break-even study
(:func:`breakeven_config`, :func:`run_breakeven`, :func:`load_breakeven`) and a policy over many
tasks through the executors (:func:`evaluate_policy_on_tasks`, :func:`load_designer`).
``tooldesign bench rl`` and ``tooldesign rl`` are the command line over them; the suite's report is
:func:`benchmarks.reports.make_suite_report`. Stable-Baselines3 and torch are imported only when
PPO or SAC is trained or loaded.
"""

from __future__ import annotations

from benchmarks.rl.agents import (
    RL_EXTRA,
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
from benchmarks.rl.breakeven import (
    BreakevenConfig,
    breakeven_config,
    load_breakeven,
    run_breakeven,
)
from benchmarks.rl.configs import (
    ContextualConfig,
    PPOConfig,
    SACConfig,
    default_config,
    load_config,
)
from benchmarks.rl.evaluation import RLTask, evaluate_policy_on_tasks, load_designer
from benchmarks.rl.policies import DesignResult, design_for_goal, load_policy, save_policy
from benchmarks.rl.suite import (
    PARTS,
    RL_SUITE_KIND,
    RL_SUITE_NAME,
    SIZES,
    RLSuiteConfig,
    RLSuiteResult,
    SuiteSize,
    rl_suite_config,
    rl_summary_text,
    run_rl_suite,
)

__all__ = [
    "PARTS",
    "RL_EXTRA",
    "RL_SUITE_KIND",
    "RL_SUITE_NAME",
    "SIZES",
    "BreakevenConfig",
    "ContextualConfig",
    "ContextualPolicy",
    "DesignResult",
    "EpisodeLog",
    "EpisodeRecord",
    "PPOConfig",
    "RLSuiteConfig",
    "RLTask",
    "RLSuiteResult",
    "SACConfig",
    "SuiteSize",
    "breakeven_config",
    "default_config",
    "design_for_goal",
    "evaluate_design",
    "evaluate_policy_on_tasks",
    "load_breakeven",
    "load_config",
    "load_designer",
    "load_policy",
    "make_env",
    "rl_suite_config",
    "rl_summary_text",
    "run_cmaes",
    "run_breakeven",
    "run_random",
    "run_rl_suite",
    "save_policy",
    "train_contextual",
    "train_ppo",
    "train_sac",
]
