"""The ``rl`` suite: RL baselines against random sampling and CMA-ES at equal episodes.

It is stored in a run folder like every other suite.

Three parts (``docs/rl.md``):

* ``fixed``: at the default goal (0, 1.5, 0.1), PPO, SAC, CMA-ES and random sampling, each for
  ``fixed_episodes`` episodes per seed; PPO's and SAC's final deterministic design is simulated
  once more.
* ``task``: PPO, SAC and the contextual regression train on goals drawn from the paper's range;
  on held-out goals, each policy's zero-shot tool (one episode per goal) is compared with the
  straight tool and with CMA-ES and random sampling run afresh on each goal (read at every
  budget from one run of the largest).
* ``mass``: the same with the box mass in the task: PPO, SAC and the contextual regression
  train on goals *and* box masses drawn from ``mass_range``, and are tested on held-out (goal, mass)
  tasks against CMA-ES and random sampling run afresh at each.

The run folder is written through :class:`benchmarks.storage.RunSession`: every episode is one
row of the evaluation log (``docs/results-format.md``, "The rl suite"), one part file per run
(``iteration`` 0, ``candidate`` = episode), written atomically and recorded with its checksum
in ``manifest.json`` as soon as it is written. A unit of work (one training, one fixed-goal run,
one held-out task's CMA-ES or random run) is redone whole if it was interrupted, and an
interrupted suite resumes where it stopped: the same command with the same settings skips the
finished units and ends with the same stored results (apart from the timing columns). The
report is made from the stored files by :func:`benchmarks.reports.make_suite_report`.
"""

from __future__ import annotations

import dataclasses
import math
import os
import shlex
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, wait
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np
import pandas as pd

from benchmarks.execution import WORKERS_MAX, check_main_guard, make_executor
from benchmarks.rl.agents import (
    EpisodeRecord,
    Trained,
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
    MethodConfig,
    PPOConfig,
    SACConfig,
    learned_configs,
    training_episodes,
)
from benchmarks.rl.policies import save_policy
from benchmarks.storage import (
    ResultStore,
    ResumeError,
    RunSession,
    Unit,
    json_ready,
    validate_evaluations,
)
from tooldesign_env.schema import (
    BEST_SO_FAR,
    DEFAULT_BOX_MASS,
    DEFAULT_GOAL,
    GOAL_HIGH,
    GOAL_LOW,
    TIMING_COLUMNS,
    coefficient_columns,
)
from tooldesign_env.specs import BOX_MASS_MAX, MASS_RANGE_MIN

#: Most seeds of the fixed-goal part: a suite's n_seeds limit (benchmarks.suites.config,
#: which the rl layer does not import).
SEEDS_MAX = 10_000

__all__ = [
    "FIXED_GOAL",
    "FIXED_METHODS",
    "MASS_METHODS",
    "MASS_RANGE",
    "NOISE_FLOOR",
    "PARTS",
    "POLICIES_DIR",
    "RL_SUITE_KIND",
    "RL_SUITE_NAME",
    "RUNTIME_FIELDS",
    "SIZES",
    "TASK_METHODS",
    "VARIANTS",
    "RLSuiteConfig",
    "RLSuiteResult",
    "SuiteSize",
    "held_out_budgets",
    "held_out_goals",
    "held_out_masses",
    "rl_suite_config",
    "rl_summary_text",
    "run_rl_suite",
]

RL_SUITE_NAME = "rl"
"""The ``suite`` column of every row, and the suite's name in ``tooldesign bench``."""

RL_SUITE_KIND = "rl-suite"
"""``manifest.json`` ``extra.kind`` of an rl suite run folder."""

RUNTIME_FIELDS: frozenset[str] = frozenset({"workers"})
"""Config fields that do not change the results: a resumed suite may set them differently."""

#: Config fields added after the suite was first stored, with the value older runs had: the tool's
#: section was square until the round one became the default (docs/model.md), the hand a chain
#: of links of its own until it was merged into the last arm link (docs/performance.md).
ADDED_FIELDS: dict[str, Any] = {"section_shape": "square", "merge_fixed_links": False}

FIXED_GOAL: tuple[float, float, float] = DEFAULT_GOAL
"""The goal of the fixed-goal part, (x, y, z) in m."""

NOISE_FLOOR = 0.015
"""Relative change of F below which two results are not told apart: a 0.1 mm nudge of the box
moves F by a median 1.4-1.6 % (docs/model.md, "Stability: the noise floor")."""

ROOT_SEED = 20261123
"""Root of the seeds: run seeds and held-out tasks come from ``SeedSequence([ROOT_SEED, k])``."""

MASS_RANGE: tuple[float, float] = (0.1, 0.9)
"""Box masses of the ``mass`` part, kg: the nominal 0.1 kg to the heaviest robustness mass."""

PARTS: tuple[str, ...] = ("fixed", "task", "mass")
FIXED_METHODS: tuple[str, ...] = ("random", "cmaes", "ppo", "sac")
TASK_METHODS: tuple[str, ...] = ("ppo", "sac", "contextual")
MASS_METHODS: tuple[str, ...] = ("ppo", "sac", "contextual")

POLICIES_DIR = "policies"
"""Folder of the saved task-conditioned policies (first training seed) in the run folder."""

VARIANTS: dict[str, str] = {
    "fixed": "fixed goal: one row per episode of each method and seed",
    "fixed-policy": "fixed goal: PPO's and SAC's final deterministic design, one row per seed; "
    "optimizer 'straight' is the straight tool",
    "train": "task part: the training episodes of each method and training seed",
    "zero-shot": "task part: each policy's design per held-out goal (candidate = goal index); "
    "optimizer 'straight' is the straight tool",
    "held-out": "task part: CMA-ES and random sampling afresh on each held-out goal, one run "
    "per goal",
    "mass-train": "mass part: the training episodes (random goals and box masses)",
    "mass-zero-shot": "mass part: each policy's design per held-out (goal, mass) task",
    "mass-held-out": "mass part: CMA-ES and random sampling afresh on each held-out task",
}
"""The ``variant`` column: which part of the suite a row belongs to."""

_PREFIX = {"task": "", "mass": "mass-"}

Progress = Callable[[str], None]


@dataclass(frozen=True, kw_only=True)
class SuiteSize:
    """How big a run of the suite is.

    Attributes:
        name: the size's name.
        seeds: seeds of the fixed-goal part.
        task_seeds: trainings per method in the task and mass parts.
        fixed_episodes: episodes per method and seed at the fixed goal.
        train_episodes: training episodes of PPO, SAC and the contextual method (its CMA-ES
            runs: ``contextual_goals`` tasks of ``train_episodes / contextual_goals`` each).
        contextual_goals: training tasks of the contextual method.
        held_out_goals: tasks the trained policies are tested on, zero-shot.
        budgets: episodes per held-out task at which CMA-ES and random sampling are read
            (1, and the budget of equal total episodes with a trained policy, are added).
        popsize: CMA-ES population size (everywhere in the suite).
        overrides: per-method config fields replaced for this size (the smoke size's tiny
            rollouts), as ``(method, field, value)``.
    """

    name: str
    seeds: int
    task_seeds: int
    fixed_episodes: int
    train_episodes: int
    contextual_goals: int
    held_out_goals: int
    budgets: tuple[int, ...]
    popsize: int = 8
    overrides: tuple[tuple[str, str, Any], ...] = ()


SIZES: dict[str, SuiteSize] = {
    # Runs in CI: about 140 episodes, well under a minute.
    "smoke": SuiteSize(
        name="smoke",
        seeds=1,
        task_seeds=1,
        fixed_episodes=8,
        train_episodes=8,
        contextual_goals=2,
        held_out_goals=2,
        budgets=(4,),
        popsize=4,
        overrides=(
            ("ppo", "n_steps", 8),
            ("ppo", "batch_size", 8),
            ("sac", "learning_starts", 4),
            ("sac", "batch_size", 4),
        ),
    ),
    # What docs/rl.md reports: what fits an hour on a shared machine.
    "short": SuiteSize(
        name="short",
        seeds=3,
        task_seeds=1,
        fixed_episodes=256,
        train_episodes=256,
        contextual_goals=8,
        held_out_goals=8,
        budgets=(50, 100),
    ),
    # The size: 10 seeds of 1,024 episodes at the fixed goal, 20 held-out goals,
    # CMA-ES afresh per goal at budgets 50, 100 and 200.
    "full": SuiteSize(
        name="full",
        seeds=10,
        task_seeds=3,
        fixed_episodes=1024,
        train_episodes=1024,
        contextual_goals=16,
        held_out_goals=20,
        budgets=(50, 100, 200),
    ),
}
"""The sizes of the suite: ``smoke`` (CI), ``short``, ``full`` (docs/rl.md's results)."""


def held_out_budgets(size: SuiteSize) -> tuple[int, ...]:
    """The size's budgets, plus 1 and the budget whose total equals a trained policy's.

    A policy trained on ``train_episodes`` and tried once on each of n tasks spends
    ``train_episodes + n`` episodes: CMA-ES and random sampling get the same total at
    ``ceil(train_episodes / n) + 1`` episodes per task.
    """
    n = size.held_out_goals
    equal = -(-size.train_episodes // n) + 1
    return tuple(sorted({1, equal, *size.budgets}))


def held_out_goals(n: int, root: int = ROOT_SEED) -> np.ndarray:
    """(n, 3) held-out goals in m, uniform in the paper's range, from their own seed stream."""
    rng = np.random.default_rng(np.random.SeedSequence([root, 99]))
    return rng.uniform(np.asarray(GOAL_LOW, float), np.asarray(GOAL_HIGH, float), (n, 3))


def held_out_masses(n: int, mass_range: Sequence[float], root: int = ROOT_SEED) -> np.ndarray:
    """(n,) held-out box masses in kg, uniform in ``mass_range``, from their own seed stream."""
    rng = np.random.default_rng(np.random.SeedSequence([root, 98]))
    return rng.uniform(float(mass_range[0]), float(mass_range[1]), n)


def _seeds(root: int, n: int, part: int) -> list[int]:
    children = np.random.SeedSequence([root, part]).spawn(n)
    return [int(c.generate_state(1)[0]) for c in children]


@dataclass(frozen=True, kw_only=True)
class RLSuiteConfig:
    """Everything that decides the results of a run of the rl suite (see :func:`rl_suite_config`).

    Attributes:
        size: the size.
        methods: fixed-goal methods, a subset of :data:`FIXED_METHODS`.
        parts: a subset of :data:`PARTS`.
        mass_range: (low, high) box masses of the ``mass`` part, kg.
        configs: the configuration of each method (``ppo``, ``sac``, ``contextual``).
        workers: processes that run units of work at once (1: this process); does not change
            the results.
        root_seed: root of every seed and held-out task.
    """

    size: SuiteSize
    methods: tuple[str, ...]
    parts: tuple[str, ...]
    mass_range: tuple[float, float]
    configs: dict[str, MethodConfig]
    workers: int = 1
    root_seed: int = ROOT_SEED

    @property
    def budgets(self) -> tuple[int, ...]:
        """Episodes per held-out task at which CMA-ES and random sampling are read."""
        return held_out_budgets(self.size)

    @property
    def goals(self) -> np.ndarray:
        """(n, 3) held-out goals in m (both task parts)."""
        return held_out_goals(self.size.held_out_goals, self.root_seed)

    @property
    def masses(self) -> np.ndarray:
        """(n,) held-out box masses in kg of the ``mass`` part."""
        return held_out_masses(self.size.held_out_goals, self.mass_range, self.root_seed)

    def planned_episodes(self) -> int:
        """Episodes the whole suite simulates (PPO rounds its training up to whole rollouts)."""
        size, n = self.size, self.size.held_out_goals
        total = 0
        if "fixed" in self.parts:
            total += 1  # the straight tool
            for method in self.methods:
                extra = 1 if method in ("ppo", "sac") else 0
                total += size.seeds * (size.fixed_episodes + extra)
        for part in ("task", "mass"):
            if part in self.parts:
                methods = TASK_METHODS if part == "task" else MASS_METHODS
                trainings = sum(self._train_episodes(m) for m in methods)
                total += n + size.task_seeds * (trainings + len(methods) * n)
                total += 2 * n * max(self.budgets)
        return total

    def _train_episodes(self, method: str) -> int:
        return training_episodes(self.configs[method], self.size.train_episodes)

    def to_json(self) -> dict[str, Any]:
        """The JSON form stored as the manifest's ``config`` (compared when resuming)."""
        return cast(
            "dict[str, Any]",
            json_ready(
                {
                    "name": RL_SUITE_NAME,
                    "size": dataclasses.asdict(self.size),
                    "methods": list(self.methods),
                    "parts": list(self.parts),
                    "mass_range": list(self.mass_range),
                    "configs": {m: dataclasses.asdict(c) for m, c in sorted(self.configs.items())},
                    "root_seed": self.root_seed,
                    "workers": self.workers,
                    "fixed_goal": list(FIXED_GOAL),
                    "budgets": list(self.budgets),
                    "held_out_goals": self.goals.tolist(),
                    "held_out_masses": self.masses.tolist(),
                    "noise_floor": NOISE_FLOOR,
                    # Every env of the suite uses the default tool and scene; recorded so that
                    # a folder made with another default is not resumed with this one.
                    "section_shape": _default_section_shape(),
                    "merge_fixed_links": _default_merge_fixed_links(),
                }
            ),
        )


def _default_section_shape() -> str:
    from tooldesign_env.geometry import ToolSpec

    return ToolSpec().section_shape


def _default_merge_fixed_links() -> bool:
    from tooldesign_env.specs import SceneSpec

    return SceneSpec().merge_fixed_links


def _check_size(size: Any) -> SuiteSize:
    if isinstance(size, SuiteSize):
        return size
    if not isinstance(size, str):
        raise TypeError(f"size must be one of {', '.join(SIZES)} or a SuiteSize, got {size!r}")
    if size not in SIZES:
        raise ValueError(f"unknown size {size!r} of the rl suite; sizes: {', '.join(SIZES)}")
    return SIZES[size]


def _check_subset(name: str, values: Any, allowed: Sequence[str]) -> tuple[str, ...]:
    if isinstance(values, str) or not isinstance(values, Iterable):
        raise ValueError(
            f"{name} must be a list of names from {', '.join(allowed)}, got {values!r}"
        )
    chosen = tuple(values)
    unknown = [v for v in chosen if v not in allowed]
    if not chosen or unknown or len(set(chosen)) != len(chosen):
        raise ValueError(
            f"{name} must be a non-empty list of distinct names from {', '.join(allowed)}, "
            f"got {' '.join(map(str, chosen)) or 'none'}"
        )
    # The order of the suite's own list: the same choice is the same config, however given.
    return tuple(a for a in allowed if a in chosen)


def _check_count(name: str, value: Any, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an int >= 1 and <= {high}, got {value!r}")
    if value < 1:
        raise ValueError(f"{name} must be an int >= 1, got {value!r}")
    if value > high:
        raise ValueError(f"{name} must be an int >= 1 and <= {high}, got {value!r}")
    return int(value)


def _check_mass_range(value: Any) -> tuple[float, float]:
    if (
        isinstance(value, (str, bytes))
        or not isinstance(value, Sequence)
        or len(value) != 2
        or any(isinstance(v, bool) or not isinstance(v, (int, float, np.number)) for v in value)
    ):
        raise TypeError(f"mass_range must be two numbers (low, high) in kg, got {value!r}")
    low, high = float(value[0]), float(value[1])
    # The env's own floor: a lower range passed here and failed in the first env, after the run
    # folder was written, which could then be neither resumed nor reused.
    if not (
        math.isfinite(low) and math.isfinite(high) and MASS_RANGE_MIN <= low <= high <= BOX_MASS_MAX
    ):
        raise ValueError(
            f"mass_range must satisfy {MASS_RANGE_MIN:g} <= low <= high <= {BOX_MASS_MAX:g} "
            f"(kg), got {low:g} {high:g}"
        )
    return low, high


def rl_suite_config(
    size: str | SuiteSize = "smoke",
    *,
    seeds: int | None = None,
    methods: Sequence[str] = FIXED_METHODS,
    parts: Sequence[str] = PARTS,
    mass_range: Sequence[float] = MASS_RANGE,
    workers: int = 1,
) -> RLSuiteConfig:
    """The configuration of a run of the rl suite, checked.

    Args:
        size: ``"smoke"`` (CI), ``"short"`` (docs/rl.md), ``"full"`` (docs/rl.md's results), or a
            :class:`SuiteSize`.
        seeds: seeds of the fixed-goal part instead of the size's, 1 to 10,000 (as a suite's
            ``n_seeds``).
        methods: fixed-goal methods, a subset of random, cmaes, ppo, sac.
        parts: a subset of fixed, task, mass.
        mass_range: (low, high) box masses of the ``mass`` part in kg, 1e-6 <= low <= high
            <= 1000 (``tooldesign_env.specs.MASS_RANGE_MIN`` and ``BOX_MASS_MAX``).
        workers: processes that run units of work at once (1: in this process), 1 to 1024.

    Returns:
        The configuration; the committed configs of each method, with the size's overrides.

    Raises:
        TypeError / ValueError: an unknown size, method or part, or a bad number; the message
            names the value and what is allowed.
    """
    suite = _check_size(size)
    if seeds is not None:
        suite = dataclasses.replace(suite, seeds=_check_count("seeds", seeds, SEEDS_MAX))
    configs = learned_configs(
        train_episodes=suite.train_episodes,
        contextual_goals=suite.contextual_goals,
        popsize=suite.popsize,
        overrides=suite.overrides,
    )
    return RLSuiteConfig(
        size=suite,
        methods=_check_subset("methods", methods, FIXED_METHODS),
        parts=_check_subset("parts", parts, PARTS),
        mass_range=_check_mass_range(mass_range),
        configs=configs,
        workers=_check_count("workers", workers, WORKERS_MAX),
    )


# --- units of work -------------------------------------------------------------------------


@dataclass(frozen=True)
class _Work:
    """One unit of work: what is redone whole after an interruption.

    ``kind`` is ``"fixed"`` (one method and seed at the fixed goal), ``"straight"`` (the
    straight tool on the held-out tasks), ``"train"`` (one training and its zero-shot designs)
    or ``"held-out"`` (CMA-ES or random sampling afresh on one held-out task, ``index``).
    """

    kind: str
    part: str
    method: str
    seed: int
    index: int = 0

    def keys(self) -> list[tuple[str, str, int]]:
        """(variant, optimizer, seed) of the parts it writes, the last one marking it done."""
        prefix = _PREFIX.get(self.part, "")
        if self.kind == "fixed":
            policy = [("fixed-policy", self.method, self.seed)]
            return [
                ("fixed", self.method, self.seed),
                *(policy if self.method in ("ppo", "sac") else []),
            ]
        if self.kind == "straight":
            variant = "fixed-policy" if self.part == "fixed" else f"{prefix}zero-shot"
            return [(variant, "straight", 0)]
        if self.kind == "train":
            return [
                (f"{prefix}train", self.method, self.seed),
                (f"{prefix}zero-shot", self.method, self.seed),
            ]
        return [(f"{prefix}held-out", self.method, self.seed)]

    def label(self) -> str:
        if self.kind == "held-out":
            return f"{self.part} held-out task {self.index + 1}: {self.method} seed {self.seed}"
        if self.kind == "straight":
            return f"{self.part} straight tool"
        return f"{self.part} {self.method} seed {self.seed}"


def _plan(config: RLSuiteConfig) -> list[_Work]:
    size, root = config.size, config.root_seed
    work: list[_Work] = []
    if "fixed" in config.parts:
        work.append(_Work("straight", "fixed", "straight", 0))
        for method in config.methods:
            work += [_Work("fixed", "fixed", method, s) for s in _seeds(root, size.seeds, 0)]
    for part in ("task", "mass"):
        if part not in config.parts:
            continue
        methods = TASK_METHODS if part == "task" else MASS_METHODS
        work.append(_Work("straight", part, "straight", 0))
        for k, seed in enumerate(_seeds(root, size.task_seeds, 1)):
            work += [_Work("train", part, m, seed, k) for m in methods]
        cmaes, random = (_seeds(root, size.held_out_goals, p) for p in (2, 3))
        for i in range(size.held_out_goals):
            work.append(_Work("held-out", part, "cmaes", cmaes[i], i))
            work.append(_Work("held-out", part, "random", random[i], i))
    return work


class _Fixed:
    """A policy that always answers the same action (the straight tool, for one)."""

    def __init__(self, action: np.ndarray) -> None:
        self.action = action

    def predict(self, observation: Any, deterministic: bool = True) -> tuple[np.ndarray, None]:
        return self.action, None


def _frame(
    records: Sequence[EpisodeRecord],
    *,
    variant: str,
    method: str,
    seed: int,
    seconds: float,
    goal_index: Sequence[int] | None = None,
) -> pd.DataFrame:
    """The evaluation rows of one run: one per episode, in order (``candidate`` = episode)."""
    simulated = sum(r.seconds for r in records)
    # The agent's time (training, asking) per episode: what is not simulation.
    agent = max(seconds - simulated, 0.0) / len(records)
    rows = []
    for k, r in enumerate(records):
        row: dict[str, Any] = {
            "suite": RL_SUITE_NAME,
            "variant": variant,
            "optimizer": method,
            "seed": seed,
            "iteration": 0,
            "candidate": k,
            "eval_id": k,
        }
        row.update(zip(coefficient_columns(len(r.coefficients)), r.coefficients, strict=True))
        row.update(
            free_energy=r.free_energy,
            goal_error=r.goal_error,
            confidence=r.confidence,
            final_distance=r.final_distance,
            final_height=r.final_height,
            final_tilt=r.final_tilt,
            status="ok" if r.valid else "invalid",
            eval_time=r.seconds,
            opt_time=agent,
            goal_x=r.goal[0],
            goal_y=r.goal[1],
            goal_z=r.goal[2],
            goal_precision=r.goal_precision,
            box_mass=r.box_mass,
            normalized_reward=r.reward,
        )
        row.update({f"a{i + 1}": a for i, a in enumerate(r.action)})
        if goal_index is not None:
            row["goal_index"] = int(goal_index[k])
        rows.append(row)
    return pd.DataFrame(rows)


Task = tuple[tuple[float, float, float], "float | None"]


def _tasks(config: RLSuiteConfig, part: str) -> list[Task]:
    """The held-out tasks of a part: (goal in m, box mass in kg or None for the env's)."""
    goals = [(float(x), float(y), float(z)) for x, y, z in config.goals]
    if part == "mass":
        return [(g, float(m)) for g, m in zip(goals, config.masses, strict=True)]
    return [(g, None) for g in goals]


def _zero_shot(policy: Any, tasks: Sequence[Task]) -> list[EpisodeRecord]:
    env = make_env()
    try:
        default = float(env.base.simulator.scene.box_mass)
        return [
            evaluate_design(policy, goal, env=env, box_mass=default if mass is None else mass)
            for goal, mass in tasks
        ]
    finally:
        env.close()


def _train_agent(config: MethodConfig, **kwargs: Any) -> Trained:
    """PPO or SAC, by its config."""
    if isinstance(config, PPOConfig):
        return train_ppo(config, **kwargs)
    if isinstance(config, SACConfig):
        return train_sac(config, **kwargs)
    raise TypeError(f"not an agent's config: {config!r}")


def _run_work(work: _Work, config: RLSuiteConfig, out: Path) -> list[pd.DataFrame]:
    """Do one unit of work; returns the frames of :meth:`_Work.keys`, in that order.

    Module-level and of picklable arguments: a worker process of a pool runs it. A training's
    policy (first training seed) is saved here, before any of its parts is written.
    """
    started = time.perf_counter()
    size = config.size
    keys = work.keys()
    straight = _Fixed(np.zeros(3, np.float32))  # a = 0 is the straight tool (default bounds)

    def frame(records: Sequence[EpisodeRecord], key: int, **kwargs: Any) -> pd.DataFrame:
        variant, method, seed = keys[key]
        elapsed = time.perf_counter() - started
        return _frame(records, variant=variant, method=method, seed=seed, seconds=elapsed, **kwargs)

    if work.kind == "straight" and work.part == "fixed":
        return [frame([evaluate_design(straight, FIXED_GOAL)], 0)]
    if work.kind == "fixed":
        n = size.fixed_episodes
        if work.method == "random":
            return [frame(run_random(total_episodes=n, seed=work.seed, goal=FIXED_GOAL), 0)]
        if work.method == "cmaes":
            records = run_cmaes(
                total_episodes=n, seed=work.seed, goal=FIXED_GOAL, popsize=size.popsize
            )
            return [frame(records, 0)]
        trained = _train_agent(
            config.configs[work.method], total_episodes=n, seed=work.seed, goal=FIXED_GOAL
        )
        fixed = frame(trained.records[:n], 0)
        started = time.perf_counter()
        return [fixed, frame([evaluate_design(trained.model, FIXED_GOAL)], 1)]
    tasks = _tasks(config, work.part)
    indices = list(range(len(tasks)))
    if work.kind == "straight":
        return [frame(_zero_shot(straight, tasks), 0, goal_index=indices)]
    if work.kind == "held-out":
        goal, mass = tasks[work.index]
        budget = max(config.budgets)
        if work.method == "cmaes":
            records = run_cmaes(
                total_episodes=budget,
                seed=work.seed,
                goal=goal,
                box_mass=mass,
                popsize=size.popsize,
            )
        else:
            records = run_random(total_episodes=budget, seed=work.seed, goal=goal, box_mass=mass)
        return [frame(records, 0, goal_index=[work.index] * len(records))]
    env_kwargs = {"mass_range": config.mass_range} if work.part == "mass" else {}
    method_config = config.configs[work.method]
    if work.method == "contextual":
        assert isinstance(method_config, ContextualConfig)
        trained = train_contextual(method_config, seed=work.seed, env_kwargs=env_kwargs)
    else:
        trained = _train_agent(
            method_config,
            total_episodes=size.train_episodes,
            seed=work.seed,
            randomize_goal=True,
            env_kwargs=env_kwargs,
        )
    training = frame(trained.records, 0)
    started = time.perf_counter()
    zero_shot = frame(_zero_shot(trained.model, tasks), 1, goal_index=indices)
    if work.index == 0:
        extra: dict[str, Any] = {"seed": work.seed, "suite_size": size.name}
        # The training tasks: the paper's goals, and the masses of the part (the default
        # box mass alone in the goal-only part); a design outside them warns.
        masses = config.mass_range if work.part == "mass" else (DEFAULT_BOX_MASS,) * 2
        save_policy(
            trained.model,
            work.method,
            out / POLICIES_DIR / f"{_PREFIX[work.part]}{work.method}.json",
            config=method_config,
            train_episodes=len(trained.records),
            goal_range=(GOAL_LOW, GOAL_HIGH),
            mass_range=masses,
            extra=extra,
        )
    return [training, zero_shot]


# --- the run -------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class RLSuiteResult:
    """What :func:`run_rl_suite` did.

    Attributes:
        out_dir: The run folder.
        config: The suite's configuration.
        evaluations: Every episode (``ResultStore.read`` format).
        units: Units of work in the suite.
        units_run: Units of work done by this call (the others were on disk).
        wall_time: s, summed over the sessions of the run folder.
        session_time: s, of this call.
        simulation_time: s: the sum of ``eval_time``.
        agent_time: s: the sum of ``opt_time`` (training and asking, outside the simulation).
    """

    out_dir: Path
    config: RLSuiteConfig
    evaluations: pd.DataFrame
    units: int
    units_run: int
    wall_time: float
    session_time: float
    simulation_time: float
    agent_time: float


def _stored_keys(
    store: ResultStore,
    planned: set[tuple[str, str, int]],
    suite: str = RL_SUITE_NAME,
    what: str = "rl suite",
) -> set[tuple[str, str, int]]:
    """(variant, optimizer, seed) of the stored parts, refusing parts the ``what`` does not plan.

    Shared with the break-even study (``suite`` and ``what`` name it), which stores its units of
    work the same way.
    """
    keys = set()
    for unit in store.completed_units():
        key = (unit.variant, unit.optimizer, unit.seed)
        if unit.suite != suite or unit.iteration != 0 or key not in planned:
            raise ResumeError(
                f"cannot resume: {store.parts_dir} holds a part this {what} does not plan "
                f"({unit}); use another folder"
            )
        keys.add(key)
    return keys


def _without_timing(frame: pd.DataFrame) -> pd.DataFrame:
    drop = [c for c in (*TIMING_COLUMNS, BEST_SO_FAR) if c in frame.columns]
    return frame.drop(columns=drop).reset_index(drop=True)


def _write_parts(
    session: RunSession,
    label: str,
    keys: Sequence[tuple[str, str, int]],
    frames: Sequence[pd.DataFrame],
    stored: set[tuple[str, str, int]],
    suite: str = RL_SUITE_NAME,
) -> None:
    """Write the parts of a finished unit that are not on disk; check the ones that are.

    Args:
        session: The open run folder.
        label: The unit, as the error names it.
        keys: (variant, optimizer, seed) of each part of the unit.
        frames: The unit's evaluation rows, one frame per key.
        stored: Keys on disk; the written ones are added.
        suite: The ``suite`` of the parts (the rl suite's or the break-even study's).
    """
    # Verified by the session when it opened the folder: not hashed again for every unit.
    log = session.store.read(verify=False) if any(k in stored for k in keys) else None
    for key, frame in zip(keys, frames, strict=True):
        if key not in stored or log is None:
            session.write_batch(frame)
            stored.add(key)
            continue
        mine = log[
            (log["variant"] == key[0]) & (log["optimizer"] == key[1]) & (log["seed"] == key[2])
        ]
        fresh = _without_timing(validate_evaluations(frame, source=str(key)))
        old = _without_timing(mine)[list(fresh.columns)]
        if not old.equals(fresh):
            unit = Unit(suite=suite, variant=key[0], optimizer=key[1], seed=key[2], iteration=0)
            raise ResumeError(
                f"cannot resume: redoing {label} gave other results than its part "
                f"{unit} on disk; the runs are not reproducible here, use a new folder"
            )


#: Fields named first when a resume is refused: those the options set, then what they decide.
_OPTION_FIELDS = ("size.name", "size.seeds", "methods", "parts", "mass_range")


def _continue_hint(out: Path, recorded: Mapping[str, Any]) -> list[str]:
    """How to go on from a folder made with other settings: the command that continues it.

    The end of :class:`~benchmarks.storage.RunSession`'s refusal (the differing fields come
    first, recorded -> requested, see :class:`~benchmarks.storage.SettingsChanged`).
    """
    flags = _continuing_flags(recorded)
    if flags is None:
        return [
            "this version cannot continue it (its settings are not those of any size and "
            "options here): run the requested suite in another folder"
        ]
    command = shlex.join(["tooldesign", "bench", "rl", *flags, "--out", str(out)])
    return [f"continue it with: {command}", "or run the requested suite in another folder"]


def _continuing_flags(recorded: Mapping[str, Any]) -> list[str] | None:
    """The ``tooldesign bench rl`` options whose suite is ``recorded``; None if there are none."""
    try:
        size = SIZES[recorded["size"]["name"]]
        seeds: int | None = recorded["size"]["seeds"]
        if seeds == size.seeds:
            seeds = None
        methods = tuple(recorded["methods"])
        parts = tuple(recorded["parts"])
        mass_range = tuple(recorded["mass_range"])
        rebuilt = rl_suite_config(
            size.name, seeds=seeds, methods=methods, parts=parts, mass_range=mass_range
        ).to_json()
    except (KeyError, TypeError, ValueError):
        return None
    if any(
        rebuilt.get(k) != recorded.get(k)
        for k in (rebuilt.keys() | recorded.keys()) - RUNTIME_FIELDS
    ):
        return None
    flags = ["--size", size.name]
    if seeds is not None:
        flags += ["--seeds", str(seeds)]
    if methods != FIXED_METHODS:
        flags += ["--methods", *methods]
    if parts != PARTS:
        flags += ["--parts", *parts]
    if mass_range != MASS_RANGE:
        flags += ["--mass-range", *(repr(float(v)) for v in mass_range)]
    return flags


def run_rl_suite(
    config: RLSuiteConfig | str | SuiteSize,
    out_dir: str | os.PathLike[str],
    *,
    resume: bool = True,
    progress: Progress | None = None,
) -> RLSuiteResult:
    """Run the rl suite into one run folder, resuming what is there.

    The report is not written here: :func:`benchmarks.reports.make_suite_report` makes it from
    the stored results (``tooldesign bench rl`` calls both).

    Args:
        config: from :func:`rl_suite_config`, or a size (its default configuration).
        out_dir: The run folder; created if absent.
        resume: Continue the suite in a non-empty ``out_dir`` (made with the same configuration
            apart from ``workers``); with ``False`` a non-empty folder is an error.
        progress: called with a line of text after each unit of work.

    Returns:
        The log and the times.

    Raises:
        TypeError / ValueError: a bad configuration or ``out_dir``; a folder that holds another
            run, or whose parts do not match (:class:`~benchmarks.storage.ResumeError`).
    """
    if not isinstance(config, RLSuiteConfig):
        config = rl_suite_config(config)
    work = _plan(config)
    planned = {key for w in work for key in w.keys()}
    if config.workers != 1:
        # Before the run folder is made: a script refused here reruns cleanly once fixed.
        check_main_guard("process", function="run_rl_suite", serial="workers=1")
    with RunSession(
        out_dir,
        kind=RL_SUITE_KIND,
        config=config.to_json(),
        resume=bool(resume),
        runtime_fields=RUNTIME_FIELDS,
        added_fields=ADDED_FIELDS,
        extra={
            "size": config.size.name,
            "units": len(work),
            "planned_episodes": config.planned_episodes(),
        },
        # A refusal for other settings names these first and offers the continuing command.
        first_fields=_OPTION_FIELDS,
        resume_hint=_continue_hint,
    ) as session:
        store = session.store
        stored = _stored_keys(store, planned)
        session.start()
        pending = [w for w in work if not all(k in stored for k in w.keys())]
        say = progress or (lambda line: None)
        say(
            f"rl suite, size {config.size.name}: {len(work) - len(pending)} of {len(work)} "
            f"units on disk, {len(pending)} to run (about {config.planned_episodes()} "
            "episodes in all)"
        )

        def finished(item: _Work, frames: list[pd.DataFrame]) -> None:
            _write_parts(session, item.label(), item.keys(), frames, stored)
            best = min(float(f["free_energy"].min()) for f in frames)
            episodes = sum(len(f) for f in frames)
            # The unit's own time (simulation and agent), wherever it ran: not its queue wait.
            seconds = sum(float(f["eval_time"].sum() + f["opt_time"].sum()) for f in frames)
            say(f"{item.label()}: {episodes} episodes, best F {best:.0f} ({seconds:.0f} s)")

        if config.workers == 1 or len(pending) <= 1:
            for item in pending:
                finished(item, _run_work(item, config, session.out))
        else:
            _run_pool(pending, config, session, finished)
        evaluations = store.read(verify=False)  # written or verified by this session
        store.consolidate()
        session.update_extra(load_average_at_end=_load_average())
        manifest = session.finish(evaluations)
    return RLSuiteResult(
        out_dir=session.out,
        config=config,
        evaluations=evaluations,
        units=len(work),
        units_run=len(pending),
        wall_time=float(manifest["wall_time"]),
        # read at the same moment as the total (the final manifest), not later
        session_time=float(manifest["extra"]["sessions"][-1]["wall_time"]),
        simulation_time=float(manifest["simulation_time"] or 0.0),
        agent_time=float(manifest["optimizer_time"] or 0.0),
    )


def _run_pool(
    pending: list[_Work],
    config: RLSuiteConfig,
    session: RunSession,
    finished: Callable[[_Work, list[pd.DataFrame]], None],
) -> None:
    """Run the units on a process pool; this process writes every part as its unit ends."""
    with make_executor("process", config.workers) as executor:
        futures = {executor.submit(_run_work, item, config, session.out): item for item in pending}
        remaining = set(futures)
        while remaining:
            done, remaining = wait(remaining, return_when=FIRST_COMPLETED)
            # In plan order within a batch of finished units: the log does not depend on it, the
            # progress lines read better.
            for future in sorted(done, key=lambda f: pending.index(futures[f])):
                finished(futures[future], future.result())


def _load_average() -> str:
    try:
        return ", ".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:  # pragma: no cover - not on every platform
        return "n/a"


def rl_summary_text(result: RLSuiteResult) -> str:
    """What a finished rl suite prints: counts, total time and its split."""
    log = result.evaluations
    counts = log["status"].value_counts()
    per_second = len(log) / max(result.simulation_time, 1e-9)
    return "\n".join(
        [
            f"suite rl ({result.config.size.name}): {result.units} units of work "
            f"({result.units_run} run now), {len(log)} episodes "
            f"({int(counts.get('ok', 0))} valid designs, "
            f"{int(counts.get('invalid', 0))} unusable)",
            f"total time: {result.wall_time:.1f} s wall (this session "
            f"{result.session_time:.1f} s), {result.config.workers} worker(s)",
            f"simulation: {result.simulation_time:.1f} s ({per_second:.2f} episodes/s of "
            f"simulation); agents: {result.agent_time:.1f} s (training, asking)",
            f"load average (1, 5, 15 min) at the end: {_load_average()}",
            f"run folder: {result.out_dir}",
        ]
    )
