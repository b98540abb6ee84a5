"""The break-even study: learned designers against per-goal search at equal per-goal budgets.

Does a designer that learned from many goals beat CMA-ES run afresh at each new goal, at the
same number of evaluations per goal, and after how many goals do its training episodes pay for
themselves? (issue 36; ``docs/rl.md``, "The break-even study".)

**Tasks.** The benchmark protocol's 8 held-out instances (instance set
:data:`INSTANCE_SET_VERSION`: goal, box mass, box friction, read from the committed
``benchmarks/protocol/data/instances-v1.json`` by
:func:`benchmarks.design.instances.load_instances`), then :data:`FRESH_TASKS`, 12 more drawn
once from the same distribution with :data:`FRESH_TASK_SEED` and committed here: 20 tasks at
the ``full`` size.
The learned designers observe the goal and the mass (``ToolDesignRL-v0``'s observation); the
friction is part of the scene each task is scored in, which they do not see.

**Methods** at per-goal budgets 1, 4, 8, 16, 32 and 64 evaluations (``full``):

- ``random``: uniform random designs at the task; ``cmaes``: CMA-ES afresh at the task
  (population 8, step 0.3, mean the box's centre): the cold starts.
- ``contextual``, ``ppo``, ``sac``: the policy's zero-shot design, one evaluation (the rest of
  the budget unused); trained on random goals of the paper's range and box masses in
  :data:`MASS_RANGE` at the default friction, with today's tool and arm.
- ``warm-contextual``, ``warm-ppo``, ``warm-sac``: the zero-shot design, then CMA-ES from it
  (:func:`benchmarks.rl.warmstart.run_warm_cmaes`: mean the design, step from the policy's
  spread), with the same CMA-ES seed as the cold CMA-ES of that task and replicate.

Each learned method trains once per replicate (training seed); replicate k of every method uses
the same seeds of the cold runs, so every comparison is paired by task and replicate. Runs of
the largest budget are read at every smaller one (their behaviour does not depend on it).

**The noise floor of each task**, measured as the benchmark protocol measures a cell's
(``compute_cell`` of :mod:`benchmarks.protocol.references`): a unit per task, after its cold
runs, evaluates the task's reference design in ``floor_scenes`` nudged scenes
(:class:`benchmarks.suites.retest.RetestConfig`: 16 at ``full``, the protocol's
:data:`~benchmarks.suites.retest.FLOOR_SCENES`; 4 at ``smoke``; the first is the task's
own scene). The design is the best of the task's cold CMA-ES runs (every replicate, the largest
budget), passing over one invalid in a nudged scene for the next best, as the protocol does:
where the compared runs end, the same for every warm-started method, and fixed before any
warm-started run (the study's F_ref would let the tested methods pick their own floor).
:func:`noise_floors` reads the measured range per task; the report's floor is the larger of
it and the least floor ``floor_min_fraction() x |F_ref|``.

**Failures.** A simulation error inside a cold or warm run does not end the study: the
evaluation is stored with status ``failed`` and the F of an unusable design at the task
(:func:`unusable_free_energy`, what CMA-ES is told), its message in ``failures/``
(:data:`FAILURES_DIR`), and the run goes on in a new env. A zero-shot design whose evaluation
failed is stored the same way, so it counts against its method.

**Stored** as every suite: one run folder (:class:`benchmarks.storage.RunSession`), one part
file per run, written atomically and checksummed in ``manifest.json``; the saved policies
(``policies/<method>-<replicate>.json``, recorded with their SHA-256); at the end every
evaluation in one Parquet file, ``evaluations.parquet``, read by :func:`load_breakeven` (columns:
:data:`BREAKEVEN_COLUMNS`; the noise floor's rows have variant ``floor``). **Resume**: the same
command again skips the finished units (a training with its zero-shot designs, one cold run,
one task's noise floor, one warm run); an interrupted unit is redone whole and must equal what
it left on disk. The report (:mod:`benchmarks.reports.breakeven`) is
made from the stored files alone.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, wait
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import gymnasium as gym
import numpy as np
import pandas as pd

from benchmarks.design.instances import load_instances, select_instances
from benchmarks.rl.agents import (
    EpisodeRecord,
    Trained,
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
from benchmarks.rl.evaluation import RLTask, evaluate_policy_on_tasks
from benchmarks.storage import (
    ResultStore,
    RunSession,
    json_ready,
    read_manifest,
    validate_evaluations,
)
from benchmarks.suites.retest import FLOOR_CANDIDATES as MAX_REFERENCE_CANDIDATES
from benchmarks.suites.retest import FLOOR_SCENES
from tooldesign_env.rl import REWARD_FLOOR, ToolDesignRLEnv
from tooldesign_env.schema import (
    DEFAULT_GOAL_PRECISION,
    GOAL_HIGH,
    GOAL_LOW,
)

__all__ = [
    "BREAKEVEN_COLUMNS",
    "BREAKEVEN_KIND",
    "BREAKEVEN_NAME",
    "BREAKEVEN_SIZES",
    "COLD_METHODS",
    "FRESH_TASKS",
    "FAILURES_DIR",
    "FLOOR_METHOD",
    "FRESH_TASK_SEED",
    "INSTANCE_SET_VERSION",
    "LEARNED_METHODS",
    "MASS_RANGE",
    "SECONDS_PER_EVALUATION",
    "BreakevenConfig",
    "BreakevenResult",
    "BreakevenSize",
    "breakeven_config",
    "breakeven_tasks",
    "estimate_text",
    "load_breakeven",
    "noise_floors",
    "NOISE_FLOOR_COLUMNS",
    "unusable_free_energy",
    "method_names",
    "run_breakeven",
]

BREAKEVEN_NAME = "breakeven"
"""The ``suite`` column of every row."""

BREAKEVEN_KIND = "rl-breakeven"
"""``manifest.json`` ``extra.kind`` of a break-even run folder."""

ROOT_SEED = 20261136
"""Root of the study's seeds (training seeds, cold and warm CMA-ES, random sampling)."""

FRESH_TASK_SEED = 20261136
"""The seed :data:`FRESH_TASKS` were drawn with (``benchmarks.protocol.instances.draw_instances``
with ``n=12``, the protocol's distribution; the draw's public/held-out split is ignored)."""

#: The version of the protocol's instance set whose held-out instances are the study's first
#: tasks (recorded in the run folder's config with the tasks themselves).
INSTANCE_SET_VERSION = 1

#: Tasks beyond the protocol's 8 held-out instances: ``draw_instances(FRESH_TASK_SEED, 12)``
#: (goal x, y, z in m; box mass in kg; box friction), drawn once and committed (a test checks
#: them against the draw), so that a new NumPy cannot change the study.
FRESH_TASKS: tuple[tuple[tuple[float, float, float], float, float], ...] = (
    ((-0.3827, 1.2442, 0.1), 0.5449, 0.4516),
    ((-0.0472, 0.8915, 0.1), 0.5015, 0.4859),
    ((-0.0875, 1.4389, 0.1), 0.1795, 0.3108),
    ((0.132, 1.1826, 0.1), 0.4698, 0.3945),
    ((-0.08, 0.5294, 0.1), 0.139, 0.4135),
    ((-0.4672, 1.292, 0.1), 0.1083, 0.4018),
    ((-0.4886, 0.9361, 0.1), 0.4307, 0.4887),
    ((0.4853, 0.8488, 0.1), 0.2615, 0.3292),
    ((0.2734, 1.066, 0.1), 0.872, 0.3541),
    ((0.1606, 1.4283, 0.1), 0.1138, 0.3121),
    ((0.0324, 0.9976, 0.1), 0.1806, 0.4589),
    ((-0.4465, 1.1884, 0.1), 0.1013, 0.4001),
)

#: Box masses the learned designers train on, kg: the instances' range (they are drawn
#: log-uniform in it; training draws uniform, which covers it).
MASS_RANGE: tuple[float, float] = (0.1, 0.9)

LEARNED_METHODS: tuple[str, ...] = ("contextual", "ppo", "sac")

#: The ``method`` of the noise floor's rows (variant ``floor``): not a method that is compared.
FLOOR_METHOD = "noise-floor"
COLD_METHODS: tuple[str, ...] = ("random", "cmaes")

#: Seconds per evaluation per idle core the time estimate assumes: the protocol's 0.072 s
#: (docs/protocol.md) with some room. An evaluation of the study costs what the protocol's does:
#: ``perf/speed/breakeven_evaluation.py`` times both side by side in one process (the same
#: designs and tasks; ratio study / protocol 0.97-1.03 on the project's machine, and making a
#: unit's env costs under one evaluation per 64), so a higher figure measured on a loaded
#: machine (0.2-0.37 s at load 6 on 2 cores) is the load's, not the study's. The integrator
#: measures it on an idle machine.
SECONDS_PER_EVALUATION = 0.075

#: Folder of the run folder with the messages of failed evaluations, one JSON per part that
#: has any (``<variant>-<method>-<seed>.json``), recorded with its SHA-256 in the manifest.
FAILURES_DIR = "failures"

#: Most replicates (training seeds) and tasks a size may ask for.
_REPLICATES_MAX = 1000

Progress = Callable[[str], None]


def method_names(learned: Sequence[str] = LEARNED_METHODS) -> tuple[str, ...]:
    """Every method of a study with these learned designers, in the report's order."""
    return (*COLD_METHODS, *learned, *(f"warm-{m}" for m in learned))


def breakeven_tasks() -> tuple[RLTask, ...]:
    """The study's 20 tasks in order: the protocol's held-out instances, then the fresh ones."""
    held_out = select_instances(load_instances(INSTANCE_SET_VERSION), sets=("held-out",))
    tasks = [
        RLTask(id=i.id, goal=i.goal, box_mass=i.box_mass, box_friction=i.box_friction, set=i.set)
        for i in held_out
    ]
    tasks += [
        RLTask(id=f"f{k + 1:02d}", goal=goal, box_mass=mass, box_friction=friction, set="fresh")
        for k, (goal, mass, friction) in enumerate(FRESH_TASKS)
    ]
    return tuple(tasks)


@dataclass(frozen=True, kw_only=True)
class BreakevenSize:
    """How big a run of the study is.

    Attributes:
        name: The size's name.
        tasks: The first this many of :func:`breakeven_tasks`.
        replicates: Training seeds of each learned method, and seeds of each cold method per
            task.
        budgets: Per-task budgets (evaluations) the report reads; runs go to the largest.
        train_episodes: Training episodes of PPO and SAC, and of the contextual method (its
            CMA-ES runs: ``contextual_goals`` tasks of ``train_episodes / contextual_goals``).
        contextual_goals: Training tasks of the contextual method.
        popsize: CMA-ES population size (cold, warm and the contextual method's).
        floor_scenes: Scenes of each task's noise floor (the first is the task's own scene):
            the protocol's :data:`~benchmarks.suites.retest.FLOOR_SCENES`, 16.
        overrides: Per-method config fields replaced for this size, ``(method, field, value)``.
    """

    name: str
    tasks: int
    replicates: int
    budgets: tuple[int, ...]
    train_episodes: int
    contextual_goals: int
    popsize: int = 8
    floor_scenes: int = FLOOR_SCENES
    overrides: tuple[tuple[str, str, Any], ...] = ()


BREAKEVEN_SIZES: dict[str, BreakevenSize] = {
    # CI: 2 tasks, one replicate, budgets up to 4, noise floors of 4 scenes; about 80
    # evaluations.
    "smoke": BreakevenSize(
        name="smoke",
        tasks=2,
        replicates=1,
        budgets=(1, 2, 4),
        train_episodes=8,
        contextual_goals=2,
        popsize=4,
        floor_scenes=4,
        overrides=(
            ("ppo", "n_steps", 8),
            ("ppo", "batch_size", 8),
            ("sac", "learning_starts", 4),
            ("sac", "batch_size", 4),
        ),
    ),
    # The issue's: 20 tasks (8 held-out + 12 fresh), 5 training seeds, budgets 1 to 64.
    "full": BreakevenSize(
        name="full",
        tasks=20,
        replicates=5,
        budgets=(1, 4, 8, 16, 32, 64),
        train_episodes=1024,
        contextual_goals=16,
    ),
}
"""The sizes: ``smoke`` (CI, seconds) and ``full`` (the issue's study: docs/results/breakeven)."""


def _seeds(root: int, part: int, index: int, n: int) -> list[int]:
    children = np.random.SeedSequence([root, part, index]).spawn(n)
    return [int(c.generate_state(1)[0]) for c in children]


@dataclass(frozen=True, kw_only=True)
class BreakevenConfig:
    """Everything that decides the study's results (see :func:`breakeven_config`).

    Attributes:
        size: The size.
        learned: The learned designers, a subset of :data:`LEARNED_METHODS`.
        configs: The configuration of each learned method.
        mass_range: (low, high) training box masses, kg.
        workers: Processes that run units at once; not a result setting.
        executor: ``"process"`` (a pool of ``workers``; with 1, this process) or ``"dask"``
            (``workers`` in a local cluster, or the cluster of ``scheduler``); not a result
            setting.
        scheduler: A Dask scheduler's address (with ``executor="dask"``), or None.
        root_seed: Root of every seed.
    """

    size: BreakevenSize
    learned: tuple[str, ...]
    configs: dict[str, MethodConfig]
    mass_range: tuple[float, float] = MASS_RANGE
    workers: int = 1
    executor: str = "process"
    scheduler: str | None = None
    root_seed: int = ROOT_SEED

    @property
    def tasks(self) -> tuple[RLTask, ...]:
        """The tasks of the study."""
        return breakeven_tasks()[: self.size.tasks]

    @property
    def max_budget(self) -> int:
        """Evaluations of every cold and warm run."""
        return max(self.size.budgets)

    @property
    def methods(self) -> tuple[str, ...]:
        """Every method, in the report's order."""
        return method_names(self.learned)

    def train_seeds(self) -> list[int]:
        """The training seed of each replicate (shared by the learned methods)."""
        return _seeds(self.root_seed, 1, 0, self.size.replicates)

    def run_seeds(self, method: str, task: int) -> list[int]:
        """Seeds of the cold runs of ``method`` at task ``task``, one per replicate.

        The warm-started runs use the cold CMA-ES's seeds (paired comparisons).
        """
        part = 3 if method == "random" else 2
        return _seeds(self.root_seed, part, task, self.size.replicates)

    def floor_seed(self, task: int) -> int:
        """Seed of task ``task``'s nudged scenes (its noise floor unit)."""
        return _seeds(self.root_seed, 4, task, 1)[0]

    def train_episodes(self, method: str) -> int:
        """Episodes one training of ``method`` simulates (PPO rounds up to whole rollouts)."""
        return training_episodes(self.configs[method], self.size.train_episodes)

    def planned_evaluations(self) -> dict[str, int]:
        """Evaluations per part of the study and in all (``total``)."""
        n, r, b = self.size.tasks, self.size.replicates, self.max_budget
        counts = {
            "train": r * sum(self.train_episodes(m) for m in self.learned),
            "zero-shot": r * n * len(self.learned),
            "cold": len(COLD_METHODS) * r * n * b,
            "floor": n * self.size.floor_scenes,
            "warm": len(self.learned) * r * n * b,
        }
        counts["total"] = sum(counts.values())
        return counts

    def to_json(self) -> dict[str, Any]:
        """The JSON form stored as the manifest's ``config`` (compared when resuming)."""
        from benchmarks.rl.suite import _default_merge_fixed_links, _default_section_shape

        return cast(
            "dict[str, Any]",
            json_ready(
                {
                    "name": BREAKEVEN_NAME,
                    "size": dataclasses.asdict(self.size),
                    "learned": list(self.learned),
                    "methods": list(self.methods),
                    "configs": {m: dataclasses.asdict(c) for m, c in sorted(self.configs.items())},
                    "mass_range": list(self.mass_range),
                    "root_seed": self.root_seed,
                    "fresh_task_seed": FRESH_TASK_SEED,
                    "tasks": [dataclasses.asdict(t) for t in self.tasks],
                    "goal_precision": DEFAULT_GOAL_PRECISION,
                    "workers": self.workers,
                    "executor": self.executor,
                    "scheduler": self.scheduler,
                    "section_shape": _default_section_shape(),
                    "merge_fixed_links": _default_merge_fixed_links(),
                }
            ),
        )


#: Config fields that do not change the results: a resumed study may set them differently.
RUNTIME_FIELDS: frozenset[str] = frozenset({"workers", "executor", "scheduler"})


def _check_size(size: Any) -> BreakevenSize:
    if isinstance(size, BreakevenSize):
        return size
    if not isinstance(size, str) or size not in BREAKEVEN_SIZES:
        raise ValueError(
            f"size must be one of {', '.join(BREAKEVEN_SIZES)} (or a BreakevenSize), got {size!r}"
        )
    return BREAKEVEN_SIZES[size]


def breakeven_config(
    size: str | BreakevenSize = "smoke",
    *,
    learned: Sequence[str] = LEARNED_METHODS,
    workers: int = 1,
    executor: str = "process",
    scheduler: str | None = None,
) -> BreakevenConfig:
    """The configuration of a run of the break-even study, checked.

    Args:
        size: ``"smoke"`` (CI), ``"full"`` (the issue's study) or a :class:`BreakevenSize`.
        learned: The learned designers, a non-empty subset of contextual, ppo, sac (each is
            also warm-started).
        workers: Processes that run units of work at once, 1 to 1024 (1: this process).
        executor: ``"process"`` (a local pool of ``workers``) or ``"dask"`` (a LocalCluster of
            ``workers``, or the scheduler at ``scheduler``; the run folder must be on a file
            system the workers share).
        scheduler: A Dask scheduler address (only with ``executor="dask"``).

    Raises:
        TypeError / ValueError: an unknown size, method or executor, or a bad number; the
            message names the value and what is allowed.
    """
    from benchmarks.execution import WORKERS_MAX
    from benchmarks.rl.suite import _check_count, _check_subset

    chosen = _check_size(size)
    for name in ("tasks", "replicates"):
        limit = len(breakeven_tasks()) if name == "tasks" else _REPLICATES_MAX
        _check_count(f"size.{name}", getattr(chosen, name), limit)
    scenes = chosen.floor_scenes
    if isinstance(scenes, bool) or not isinstance(scenes, int) or not 2 <= scenes <= 100:
        raise ValueError(f"size.floor_scenes must be an int from 2 to 100, got {scenes!r}")
    budgets = chosen.budgets
    if (
        not budgets
        or any(isinstance(b, bool) or not isinstance(b, int) or b < 1 for b in budgets)
        or list(budgets) != sorted(set(budgets))
    ):
        raise ValueError(f"size.budgets must be increasing ints >= 1, got {budgets!r}")
    configs = learned_configs(
        train_episodes=chosen.train_episodes,
        contextual_goals=chosen.contextual_goals,
        popsize=chosen.popsize,
        overrides=chosen.overrides,
    )
    methods = _check_subset("learned", learned, LEARNED_METHODS)
    if executor not in ("process", "dask"):
        raise ValueError(f"executor must be 'process' or 'dask', got {executor!r}")
    if scheduler is not None and (executor != "dask" or not isinstance(scheduler, str)):
        raise ValueError(
            f"scheduler is a Dask scheduler's address and needs executor='dask', got "
            f"scheduler={scheduler!r} with executor={executor!r}"
        )
    return BreakevenConfig(
        size=chosen,
        learned=methods,
        configs={m: configs[m] for m in methods},
        workers=_check_count("workers", workers, WORKERS_MAX),
        executor=executor,
        scheduler=scheduler,
    )


def estimate_text(
    config: BreakevenConfig, *, seconds_per_evaluation: float = SECONDS_PER_EVALUATION
) -> str:
    """The planned evaluations and the time they take at ``seconds_per_evaluation`` per core.

    The estimate counts simulation only, on idle cores: PPO's and SAC's updates come on top,
    and a core shared with other work is slower in proportion (measure the rate with
    ``python -m perf.speed.breakeven_evaluation``).

    Raises:
        ValueError: ``seconds_per_evaluation`` is not a finite number > 0.
    """
    if (
        isinstance(seconds_per_evaluation, bool)
        or not isinstance(seconds_per_evaluation, (int, float))
        or not (math.isfinite(seconds_per_evaluation) and seconds_per_evaluation > 0)
    ):
        raise ValueError(
            f"seconds_per_evaluation must be a finite number > 0, got {seconds_per_evaluation!r}"
        )
    counts = config.planned_evaluations()
    core_seconds = counts["total"] * seconds_per_evaluation
    parts = ", ".join(f"{k} {v:,}" for k, v in counts.items() if k != "total")
    return (
        f"break-even study, size {config.size.name}: {counts['total']:,} evaluations ({parts}); "
        f"at {seconds_per_evaluation:g} s per evaluation per idle core: {core_seconds / 3600:.2f} "
        f"core-hours, {core_seconds / 3600 / config.workers:.2f} h on {config.workers} "
        f"worker(s) (simulation only; PPO's and SAC's updates come on top)"
    )


# --- units of work -------------------------------------------------------------------------


@dataclass(frozen=True)
class _Work:
    """One unit of work, redone whole after an interruption.

    ``kind`` is ``"train"`` (a learned method's training, its card, its zero-shot designs),
    ``"cold"`` (random sampling or CMA-ES at one task), ``"floor"`` (the noise floor of one
    task: the best design of its cold CMA-ES runs in nudged scenes; after those runs) or
    ``"warm"`` (CMA-ES from a card's design at one task).
    """

    kind: str
    method: str
    seed: int
    replicate: int
    task: int = -1

    def keys(self) -> list[tuple[str, str, int]]:
        """(variant, optimizer, seed) of the parts it writes, the last marking it done."""
        if self.kind == "train":
            return [("train", self.method, self.seed), ("zero-shot", self.method, self.seed)]
        if self.kind == "cold":
            return [("cold", self.method, self.seed)]
        if self.kind == "floor":
            return [("floor", FLOOR_METHOD, self.seed)]
        return [("warm", f"warm-{self.method}", self.seed)]

    def label(self) -> str:
        if self.kind == "train":
            return f"train {self.method} replicate {self.replicate}"
        if self.kind == "floor":
            return f"noise floor task {self.task + 1}"
        name = self.method if self.kind == "cold" else f"warm-{self.method}"
        return f"{name} task {self.task + 1} replicate {self.replicate}"


def _plan(config: BreakevenConfig) -> list[_Work]:
    work: list[_Work] = []
    for k, seed in enumerate(config.train_seeds()):
        work += [_Work("train", m, seed, k) for m in config.learned]
    for i in range(config.size.tasks):
        for method in COLD_METHODS:
            work += [
                _Work("cold", method, seed, k, i)
                for k, seed in enumerate(config.run_seeds(method, i))
            ]
    # After every cold run (the floor's design is the best of the task's cold CMA-ES runs).
    work += [
        _Work("floor", FLOOR_METHOD, config.floor_seed(i), -1, i) for i in range(config.size.tasks)
    ]
    for i in range(config.size.tasks):
        seeds = config.run_seeds("cmaes", i)
        for method in config.learned:
            work += [_Work("warm", method, seed, k, i) for k, seed in enumerate(seeds)]
    return work


def _card_path(out: Path, method: str, replicate: int) -> Path:
    return out / "policies" / f"{method}-{replicate}.json"


def _task_env(task: RLTask) -> Any:
    """``ToolDesignRL-v0`` with the task's scene (its friction); goal and mass come per reset."""
    from tooldesign_env.specs import SceneSpec

    scene = SceneSpec() if task.box_friction is None else SceneSpec(box_friction=task.box_friction)
    return make_env(scene=scene)


def _unit_fields(key: tuple[str, str, int], k: int) -> dict[str, Any]:
    """The part's columns of its k-th evaluation: one iteration, evaluations in order."""
    return {
        "suite": BREAKEVEN_NAME,
        "variant": key[0],
        "optimizer": key[1],
        "seed": key[2],
        "iteration": 0,
        "candidate": k,
        "eval_id": k,
    }


def _frame(
    records: Sequence[EpisodeRecord],
    *,
    work: _Work,
    key: tuple[str, str, int],
    seconds: float,
    task: int,
    friction: float,
    sigma0: float = math.nan,
    failed: Iterable[int] = (),
) -> pd.DataFrame:
    failed = set(failed)
    simulated = sum(r.seconds for r in records)
    agent = max(seconds - simulated, 0.0) / len(records)
    rows = []
    for k, r in enumerate(records):
        rows.append(
            {
                **_unit_fields(key, k),
                **{f"c{i + 1}": c for i, c in enumerate(r.coefficients)},
                "free_energy": r.free_energy,
                "goal_error": r.goal_error,
                "confidence": r.confidence,
                "final_distance": r.final_distance,
                "status": "failed" if k in failed else "ok" if r.valid else "invalid",
                "eval_time": r.seconds,
                "opt_time": agent,
                "goal_x": r.goal[0],
                "goal_y": r.goal[1],
                "goal_z": r.goal[2],
                "goal_precision": r.goal_precision,
                "box_mass": r.box_mass,
                "normalized_reward": r.reward,
                **{f"a{i + 1}": a for i, a in enumerate(r.action)},
                "task_index": task,
                "replicate": work.replicate,
                "box_friction": friction,
                "sigma0": sigma0,
            }
        )
    return pd.DataFrame(rows)


def _zero_shot_frame(
    evaluated: pd.DataFrame,
    *,
    work: _Work,
    key: tuple[str, str, int],
    seconds: float,
    tasks: Sequence[RLTask],
) -> pd.DataFrame:
    """The zero-shot rows; a failed design (an error, F NaN) gets the F of an unusable one."""
    rows = []
    for i, row in evaluated.iterrows():
        free_energy = float(row["free_energy"])
        if row["status"] == "failed":
            free_energy = unusable_free_energy(tasks[int(cast("int", i))])
        rows.append(
            {
                **_unit_fields(key, int(cast("int", i))),
                "c1": row["c1"],
                "c2": row["c2"],
                "c3": row["c3"],
                "free_energy": free_energy,
                "goal_error": row["goal_error"],
                "confidence": row["confidence"],
                "final_distance": row["final_distance"],
                "status": row["status"],
                "eval_time": row["eval_time"],
                "opt_time": max(seconds - float(evaluated["eval_time"].sum()), 0.0)
                / len(evaluated),
                "goal_x": row["goal_x"],
                "goal_y": row["goal_y"],
                "goal_z": row["goal_z"],
                "goal_precision": DEFAULT_GOAL_PRECISION,
                "box_mass": row["box_mass"],
                "normalized_reward": math.nan,
                "a1": row["a1"],
                "a2": row["a2"],
                "a3": row["a3"],
                "task_index": int(cast("int", i)),
                "replicate": work.replicate,
                "box_friction": row["box_friction"],
                "sigma0": math.nan,
            }
        )
    return pd.DataFrame(rows)


def unusable_free_energy(task: RLTask) -> float:
    """F of an unusable design at ``task``: F_idle (the box never moves) + the invalid penalty.

    What the env scores a design it cannot build or use, and what the study counts for a
    design whose evaluation failed (an error in the simulation): a failure counts against its
    method like the worst design, not as a missing value.
    """
    env = _task_env(task)
    try:
        env.reset(options={"goal": task.goal, "box_mass": task.box_mass})
        return float(env.idle_free_energy() + env.base.objective.invalid_penalty)
    finally:
        env.close()


class _Guarded(gym.Wrapper[np.ndarray, np.ndarray, np.ndarray, np.ndarray]):
    """The task's env; an exception in a step becomes a failed evaluation, not the study's end.

    The failed step returns what an unusable design gets (F_idle + the invalid penalty, the
    lowest normalized reward), so CMA-ES is told a finite F and goes on; the env is made
    again (its simulation may be in any state) and reset to the episode's task. ``failures``
    maps the step's index (0-based, in order) to the error's message.
    """

    def __init__(self, task: RLTask) -> None:
        super().__init__(_task_env(task))
        self.task = task
        self.failures: dict[int, str] = {}
        self.steps = 0
        self._options: dict[str, Any] | None = None

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        self._options = None if options is None else dict(options)
        return self.env.reset(seed=seed, options=options)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        index = self.steps
        self.steps += 1
        rl = cast("ToolDesignRLEnv", self.env.unwrapped)
        coefficients = rl.to_coefficients(action)  # a bad action is an error, not a failure
        try:
            obs, reward, terminated, truncated, info = self.env.step(action)
            return obs, float(reward), terminated, truncated, info
        except Exception as error:  # noqa: BLE001 - any error of the simulation is recorded
            self.failures[index] = f"{type(error).__name__}: {error}"
        self.env.close()
        self.env = _task_env(self.task)
        obs, task = self.env.reset(options=self._options)
        rl = cast("ToolDesignRLEnv", self.env.unwrapped)
        idle = float(rl.idle_free_energy())
        goal = np.asarray(task["goal"], dtype=float)
        info = {
            "goal": goal,
            "box_mass": float(task["box_mass"]),
            "coefficients": np.asarray(coefficients, dtype=float),
            "free_energy": idle + float(rl.base.objective.invalid_penalty),
            "normalized_reward": REWARD_FLOOR,
            "valid": False,
            "final_distance": float(np.linalg.norm(rl.base.box_start() - goal)),
            "goal_error": idle,
            "confidence": 0.0,
            "failed": self.failures[index],
        }
        return obs, REWARD_FLOOR, True, False, info


def _failures_path(out: Path, key: tuple[str, str, int]) -> Path:
    return out / FAILURES_DIR / f"{key[0]}-{key[1]}-{key[2]}.json"


def _record_failures(out: Path, key: tuple[str, str, int], failures: dict[int, str]) -> None:
    """Write the messages of a part's failed evaluations (or remove a stale file: none)."""
    from benchmarks.storage import atomic_write_text, json_text

    path = _failures_path(out, key)
    if failures:
        messages = [{"evaluation": k + 1, "message": m} for k, m in sorted(failures.items())]
        atomic_write_text(path, json_text({"part": list(key), "failed": messages}))
    elif path.exists():
        path.unlink()


def _floor_candidates(out: Path, config: BreakevenConfig, task: int) -> pd.DataFrame:
    """The task's cold CMA-ES designs, best first: the usable ones, each design once."""
    from benchmarks.storage import Unit

    seeds = config.run_seeds("cmaes", task)
    units = [
        Unit(suite=BREAKEVEN_NAME, variant="cold", optimizer="cmaes", seed=s, iteration=0)
        for s in seeds
    ]
    rows = ResultStore(out)._read_parts(units)
    rows = rows[(rows["status"] == "ok") & np.isfinite(rows["free_energy"])].copy()
    rows["replicate"] = rows["seed"].map({s: k for k, s in enumerate(seeds)})
    rows = rows.sort_values(["free_energy", "replicate", "candidate"], kind="stable")
    return rows.drop_duplicates(["c1", "c2", "c3"]).head(MAX_REFERENCE_CANDIDATES)


def _floor_frame(work: _Work, config: BreakevenConfig, out: Path) -> pd.DataFrame:
    """The noise floor unit of a task: its reference design in ``floor_scenes`` nudged scenes.

    The design is the best of the task's cold CMA-ES runs (all replicates, largest budget):
    where the compared runs end, and the same for every warm-started method. As the
    protocol's ``compute_cell`` does, a design invalid in a nudged scene has no floor and the
    next best is tried (at most ``MAX_REFERENCE_CANDIDATES``). One row per scene (candidate k
    is scene k, the first the task's own); no usable design or an error: one failed row (F
    NaN), and the report falls back to the least floor.
    """
    from benchmarks.rl.evaluation import _task_settings
    from benchmarks.storage import INVALID_IN_SCENE
    from benchmarks.suites.retest import RetestConfig, RetestItem, retest_design

    started = time.perf_counter()
    task = config.tasks[work.task]
    key = work.keys()[0]
    settings = _task_settings(task, section_shape=None, merge_fixed_links=None)
    retest = RetestConfig(nudges=config.size.floor_scenes, seed=work.seed, repeats=1)
    chosen, noise, message = None, [], "no usable design in the cold CMA-ES runs"
    for row in _floor_candidates(out, config, work.task).itertuples():
        item = RetestItem(coeffs=(row.c1, row.c2, row.c3), task=settings, config=retest)
        try:
            noise = retest_design(item)["noise"]
        except Exception as error:  # noqa: BLE001 - recorded; the study goes on
            message = f"{type(error).__name__}: {error}"
            if INVALID_IN_SCENE in str(error):
                continue
            break
        chosen = row
        break
    friction = math.nan if task.box_friction is None else task.box_friction
    seconds = time.perf_counter() - started
    common = {
        "goal_x": task.goal[0],
        "goal_y": task.goal[1],
        "goal_z": task.goal[2],
        "goal_precision": DEFAULT_GOAL_PRECISION,
        "box_mass": task.box_mass,
        "normalized_reward": math.nan,
        "task_index": work.task,
        "replicate": -1,
        "box_friction": friction,
        "sigma0": math.nan,
        "opt_time": 0.0,
    }
    if chosen is None:
        _record_failures(out, key, {0: message})
        nan = dict.fromkeys(("c1", "c2", "c3", "a1", "a2", "a3"), math.nan)
        metrics = dict.fromkeys(("free_energy", "goal_error", "confidence", "final_distance"))
        return pd.DataFrame(
            [
                {
                    **_unit_fields(key, 0),
                    **nan,
                    **{k: math.nan for k in metrics},
                    "status": "failed",
                    "eval_time": seconds,
                    **common,
                }
            ]
        )
    _record_failures(out, key, {})
    rows = []
    for k, scene in enumerate(noise):
        rows.append(
            {
                **_unit_fields(key, k),
                **{f"c{i}": getattr(chosen, f"c{i}") for i in (1, 2, 3)},
                **{f"a{i}": getattr(chosen, f"a{i}") for i in (1, 2, 3)},
                **{m: float(scene[m]) for m in ("free_energy", "goal_error", "confidence")},
                "final_distance": float(scene["final_distance"]),
                "status": "ok",
                "eval_time": seconds / len(noise),
                **common,
            }
        )
    return pd.DataFrame(rows)


def _train(config: MethodConfig, size: BreakevenSize, seed: int, masses: Any) -> Trained:
    env_kwargs = {"mass_range": masses}
    if isinstance(config, ContextualConfig):
        return train_contextual(config, seed=seed, env_kwargs=env_kwargs)
    common: dict[str, Any] = {
        "total_episodes": size.train_episodes,
        "seed": seed,
        "randomize_goal": True,
        "env_kwargs": env_kwargs,
    }
    if isinstance(config, PPOConfig):
        return train_ppo(config, **common)
    if isinstance(config, SACConfig):
        return train_sac(config, **common)
    raise TypeError(f"not a learned method's config: {config!r}")


def _run_work(work: _Work, config: BreakevenConfig, out: Path) -> list[pd.DataFrame]:
    """Do one unit of work; the frames of :meth:`_Work.keys`, in order (runs in a worker)."""
    from benchmarks.rl.policies import load_policy, save_policy
    from benchmarks.rl.warmstart import run_warm_cmaes

    started = time.perf_counter()
    keys = work.keys()
    tasks = config.tasks
    budget = config.max_budget
    if work.kind == "train":
        trained = _train(config.configs[work.method], config.size, work.seed, config.mass_range)
        card = _card_path(out, work.method, work.replicate)
        save_policy(
            trained.model,
            work.method,
            card,
            config=config.configs[work.method],
            train_episodes=len(trained.records),
            goal_range=(GOAL_LOW, GOAL_HIGH),
            mass_range=config.mass_range,
            extra={"seed": work.seed, "replicate": work.replicate, "study": BREAKEVEN_NAME},
        )
        training = _frame(
            trained.records,
            work=work,
            key=keys[0],
            seconds=time.perf_counter() - started,
            task=-1,
            friction=math.nan,
        )
        started = time.perf_counter()
        # The card, as every later unit reads it (not the model in memory): what is scored is
        # what was saved.
        policy, saved = load_policy(card)
        evaluated = evaluate_policy_on_tasks(
            policy,
            tasks,
            executor="serial",
            section_shape=saved["section_shape"],
            merge_fixed_links=saved["merge_fixed_links"],
        )
        failed = evaluated["status"] == "failed"
        _record_failures(
            out,
            keys[1],
            {int(i): str(evaluated.loc[i, "message"]) for i in evaluated.index[failed]},
        )
        zero = _zero_shot_frame(
            evaluated, work=work, key=keys[1], seconds=time.perf_counter() - started, tasks=tasks
        )
        return [training, zero]
    if work.kind == "floor":
        return [_floor_frame(work, config, out)]
    task = tasks[work.task]
    friction = math.nan if task.box_friction is None else task.box_friction
    guarded = _Guarded(task)
    env = cast("ToolDesignRLEnv", guarded)
    try:
        if work.kind == "cold":
            runner = run_random if work.method == "random" else run_cmaes
            kwargs: dict[str, Any] = (
                {} if work.method == "random" else {"popsize": config.size.popsize}
            )
            records = runner(
                total_episodes=budget,
                seed=work.seed,
                goal=task.goal,
                box_mass=task.box_mass,
                env=env,
                **kwargs,
            )
            sigma0 = math.nan if work.method == "random" else 0.3
        else:
            policy, _ = load_policy(_card_path(out, work.method, work.replicate))
            records, sigma0 = run_warm_cmaes(
                policy,
                total_episodes=budget,
                seed=work.seed,
                goal=task.goal,
                box_mass=task.box_mass,
                popsize=config.size.popsize,
                env=env,
            )
    finally:
        env.close()
    _record_failures(out, keys[0], guarded.failures)
    frame = _frame(
        records,
        work=work,
        key=keys[0],
        seconds=time.perf_counter() - started,
        task=work.task,
        friction=friction,
        sigma0=sigma0,
        failed=guarded.failures,
    )
    return [frame]


# --- the run -------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class BreakevenResult:
    """What :func:`run_breakeven` did.

    Attributes:
        out_dir: The run folder.
        config: The study's configuration.
        evaluations: Every evaluation (:func:`load_breakeven`'s frame).
        units: Units of work in the study.
        units_run: Units done by this call (the others were on disk).
        wall_time: s, summed over the sessions of the folder.
    """

    out_dir: Path
    config: BreakevenConfig
    evaluations: pd.DataFrame
    units: int
    units_run: int
    wall_time: float


def _write(
    session: RunSession,
    work: _Work,
    frames: list[pd.DataFrame],
    stored: set[tuple[str, str, int]],
) -> None:
    """Write the parts of a finished unit not on disk; check those that are."""
    from benchmarks.rl.suite import _write_parts

    if work.kind == "train":
        # Recorded before its parts: a later session refuses the folder if the card changes.
        session.record_file(_card_path(session.out, work.method, work.replicate))
        weights = _card_path(session.out, work.method, work.replicate).with_suffix(".safetensors")
        if weights.is_file():
            session.record_file(weights)
    for key in work.keys():
        failures = _failures_path(session.out, key)
        if failures.is_file():
            session.record_file(failures)
    _write_parts(session, work.label(), work.keys(), frames, stored, suite=BREAKEVEN_NAME)


def run_breakeven(
    config: BreakevenConfig | str,
    out_dir: str | os.PathLike[str],
    *,
    resume: bool = True,
    progress: Progress | None = None,
) -> BreakevenResult:
    """Run the break-even study into one run folder, resuming what is there.

    The report is not written here: :func:`benchmarks.reports.breakeven.make_breakeven_report`
    makes it from the stored files (``tooldesign rl breakeven`` calls both).

    Args:
        config: From :func:`breakeven_config`, or a size's name.
        out_dir: The run folder; created if absent.
        resume: Continue the study in a non-empty ``out_dir`` (made with the same settings
            apart from ``workers``, ``executor`` and ``scheduler``).
        progress: Called with a line of text after each unit of work.

    Returns:
        The evaluations and counts.

    Raises:
        TypeError / ValueError: a bad configuration or folder; a folder that holds another run
            or whose parts do not match (:class:`~benchmarks.storage.ResumeError`).
    """
    from benchmarks.execution import check_main_guard, make_executor
    from benchmarks.rl.suite import _stored_keys

    if not isinstance(config, BreakevenConfig):
        config = breakeven_config(config)
    work = _plan(config)
    planned = {key for w in work for key in w.keys()}
    # A process pool of one is this process; Dask was asked for by name, so it is used.
    parallel = config.workers > 1 or config.executor == "dask"
    if parallel:
        check_main_guard(config.executor, config.scheduler, function="run_breakeven")
    with RunSession(
        out_dir,
        kind=BREAKEVEN_KIND,
        config=config.to_json(),
        resume=bool(resume),
        runtime_fields=RUNTIME_FIELDS,
        extra={
            "size": config.size.name,
            "units": len(work),
            "planned_evaluations": config.planned_evaluations(),
        },
        first_fields=("size.name", "learned"),
    ) as session:
        stored = _stored_keys(session.store, planned, BREAKEVEN_NAME, "break-even study")
        session.start()
        pending = [w for w in work if not all(k in stored for k in w.keys())]
        say = progress or (lambda line: None)
        say(estimate_text(config))
        say(f"{len(work) - len(pending)} of {len(work)} units on disk, {len(pending)} to run")

        def finished(item: _Work, frames: list[pd.DataFrame]) -> None:
            _write(session, item, frames, stored)
            best = min(float(f["free_energy"].min()) for f in frames)
            seconds = sum(float(f["eval_time"].sum() + f["opt_time"].sum()) for f in frames)
            say(
                f"{item.label()}: {sum(len(f) for f in frames)} evaluations, best F {best:.0f} "
                f"({seconds:.0f} s)"
            )

        if not parallel:
            for item in pending:
                finished(item, _run_work(item, config, session.out))
        else:
            with make_executor(config.executor, config.workers, config.scheduler) as executor:
                _run_parallel(pending, stored, config, session.out, executor, finished)
        evaluations = session.store.read(verify=False)
        session.store.consolidate()
        manifest = session.finish(evaluations)
    return BreakevenResult(
        out_dir=session.out,
        config=config,
        evaluations=load_breakeven(session.out),
        units=len(work),
        units_run=len(pending),
        wall_time=float(manifest["wall_time"]),
    )


def _needs(item: _Work, config: BreakevenConfig) -> set[tuple[str, str, int]]:
    """The parts a unit reads: a warm run its card's training, a floor its task's cold CMA-ES."""
    if item.kind == "warm":
        seed = config.train_seeds()[item.replicate]
        return {("zero-shot", item.method, seed)}
    if item.kind == "floor":
        return {("cold", "cmaes", s) for s in config.run_seeds("cmaes", item.task)}
    return set()


def _run_parallel(
    pending: list[_Work],
    stored: set[tuple[str, str, int]],
    config: BreakevenConfig,
    out: Path,
    executor: Any,
    finished: Callable[[_Work, list[pd.DataFrame]], None],
) -> None:
    """Run the units on the executor; a unit goes once the parts it reads are stored."""
    waiting = list(pending)
    futures: dict[Future[Any], _Work] = {}

    def submit() -> None:
        nonlocal waiting
        ready = [w for w in waiting if _needs(w, config) <= stored]
        waiting = [w for w in waiting if w not in ready]
        for item in ready:
            futures[executor.submit(_run_work, item, config, out)] = item

    submit()
    while futures:
        done, _ = wait(list(futures), return_when=FIRST_COMPLETED)
        for future in sorted(done, key=lambda f: pending.index(futures[f])):
            item = futures.pop(future)
            finished(item, future.result())
        submit()
    if waiting:  # cannot happen: every unit's needs come before it in the plan
        raise RuntimeError(f"units never ready: {[w.label() for w in waiting][:3]}")


#: The columns of :func:`load_breakeven`'s frame, documented in docs/rl.md.
BREAKEVEN_COLUMNS: tuple[str, ...] = (
    "variant",
    "method",
    "replicate",
    "task",
    "task_set",
    "evaluation",
    "seed",
    "goal_x",
    "goal_y",
    "goal_z",
    "box_mass",
    "box_friction",
    "a1",
    "a2",
    "a3",
    "c1",
    "c2",
    "c3",
    "free_energy",
    "goal_error",
    "confidence",
    "final_distance",
    "status",
    "normalized_reward",
    "sigma0",
    "best_so_far",
    "eval_time",
    "opt_time",
)


def load_breakeven(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Every evaluation of a break-even study, as one frame (the offline dataset).

    Args:
        path: The run folder (its checksums are verified) or its ``evaluations.parquet``
            alone (with ``manifest.json`` beside it, for the task names).

    Returns:
        :data:`BREAKEVEN_COLUMNS`, one row per evaluation: ``variant`` is ``train``,
        ``zero-shot``, ``cold`` or ``warm``; ``method`` the method (``random``, ``cmaes``,
        ``contextual``, ``warm-ppo``, ...); ``replicate`` the training seed's index (0-based;
        the cold runs of the same index share its seeds); ``task`` the task id (``""`` for
        training episodes, at random tasks) and ``task_set`` ``held-out``/``fresh``;
        ``evaluation`` the 1-based count within its run (its budget so far; a zero-shot row
        is 1); ``seed`` the run's seed; ``sigma0`` the CMA-ES step size (cold 0.3, warm the
        policy's; NaN otherwise); ``best_so_far`` the lowest F of the run up to the row (for
        ``zero-shot`` rows, the row's F).

    Raises:
        FileNotFoundError: no such folder or file.
        ValueError: not a break-even run folder, or its files do not match their checksums.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a run folder or its evaluations.parquet, got {path!r}")
    target = Path(path)
    if target.is_file() and target.suffix == ".parquet":
        folder = target.parent
        log = validate_evaluations(pd.read_parquet(target), source=str(target))
    elif target.is_dir():
        folder = target
        log = None
    else:
        raise FileNotFoundError(f"no break-even run folder or evaluations.parquet at {target}")
    manifest = read_manifest(folder)
    extra, config = manifest.get("extra"), manifest.get("config")
    if not isinstance(extra, dict) or extra.get("kind") != BREAKEVEN_KIND:
        raise ValueError(
            f"{folder} is not a break-even run folder (manifest kind is not {BREAKEVEN_KIND})"
        )
    assert isinstance(config, dict)
    if log is None:
        log = ResultStore(folder).read()
    log = log[log["suite"] == BREAKEVEN_NAME].copy()
    ids = [t["id"] for t in config["tasks"]]
    sets = [t["set"] for t in config["tasks"]]
    index = log["task_index"].astype(int)
    log["task"] = [ids[i] if i >= 0 else "" for i in index]
    log["task_set"] = [sets[i] if i >= 0 else "" for i in index]
    log["method"] = log["optimizer"]
    log["replicate"] = log["replicate"].astype(int)
    zero = log["variant"] == "zero-shot"
    log["evaluation"] = np.where(zero, 1, log["candidate"] + 1).astype(int)
    order = ["variant", "optimizer", "seed", "candidate"]
    log = log.sort_values(order, kind="stable")
    running = log.groupby(["variant", "optimizer", "seed"], sort=False)["free_energy"].cummin()
    log["best_so_far"] = np.where(zero, log["free_energy"], running)
    return log[list(BREAKEVEN_COLUMNS)].reset_index(drop=True)


#: The columns of :func:`noise_floors`, one row per task.
NOISE_FLOOR_COLUMNS: tuple[str, ...] = (
    "task",
    "c1",
    "c2",
    "c3",
    "f_design",
    "noise_range",
    "scenes",
    "status",
)


def noise_floors(evaluations: pd.DataFrame | str | os.PathLike[str]) -> pd.DataFrame:
    """Each task's measured noise of F: its reference design's range over nudged scenes.

    Args:
        evaluations: :func:`load_breakeven`'s frame, or a run folder (loaded with it).

    Returns:
        :data:`NOISE_FLOOR_COLUMNS`, one row per task with a floor unit: the design (the best
        of the task's cold CMA-ES runs that is usable in every nudged scene), ``f_design`` its
        F in the task's own scene, ``noise_range`` max - min of F over the ``scenes`` scenes
        (NaN when ``status`` is ``failed``: no design had a floor). The floor the report uses
        is the larger of ``noise_range`` and the least floor ``fraction x |F_ref|``
        (:func:`benchmarks.reports.breakeven.task_floors`).

    Raises:
        ValueError: a frame without the study log's columns (naming them).
    """
    log = evaluations if isinstance(evaluations, pd.DataFrame) else load_breakeven(evaluations)
    needed = {"variant", "task", "evaluation", "status", "free_energy", "c1", "c2", "c3"}
    missing = sorted(needed - set(log.columns))
    if missing:
        raise ValueError(
            f"evaluations lacks the columns {missing}: give load_breakeven's frame or a run folder"
        )
    rows = []
    floor = log[log["variant"] == "floor"]
    for task, g in floor.groupby("task", sort=False):
        g = g.sort_values("evaluation")
        ok = g[g["status"] == "ok"]
        f = ok["free_energy"].to_numpy(dtype=np.float64)
        failed = ok.empty
        rows.append(
            {
                "task": task,
                **{c: float(g[c].iloc[0]) for c in ("c1", "c2", "c3")},
                "f_design": math.nan if failed else float(f[0]),
                "noise_range": math.nan if failed else float(f.max() - f.min()),
                "scenes": len(ok),
                "status": "failed" if failed else "ok",
            }
        )
    return pd.DataFrame(rows, columns=list(NOISE_FLOOR_COLUMNS))
