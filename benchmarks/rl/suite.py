"""The ``rl`` suite: RL baselines against random sampling and CMA-ES, at equal episodes.

Two parts (``docs/rl.md``):

* **Fixed goal** (the default goal (0, 1.5, 0.1)): PPO, SAC, CMA-ES and random sampling, each for
  ``fixed_episodes`` episodes per seed; the best F so far after every episode.
* **Task-conditioned**: PPO, SAC and the contextual regression train on goals drawn from the
  paper's range (``train_episodes`` each); on held-out goals, their zero-shot tool (one episode
  per goal) is compared with the straight tool, and with CMA-ES and random sampling run afresh
  on each goal at each budget. Every row carries the episodes the approach spent in total,
  training included.

Files written to ``out_dir`` (atomically): ``fixed_goal.csv`` (method, seed, episode,
free_energy, best_so_far_F, ...), ``held_out.csv`` (method, seed, goal, budget_per_goal,
train_episodes, total_episodes, free_energy, ...), ``summary.json``, and the trained policies
of the first seed under ``policies/``.
"""

from __future__ import annotations

import dataclasses
import os
import platform
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.rl._io import write_csv, write_json
from benchmarks.rl.agents import (
    EpisodeRecord,
    evaluate_design,
    make_env,
    run_cmaes,
    run_random,
    train_contextual,
    train_ppo,
    train_sac,
)
from benchmarks.rl.configs import ContextualConfig, default_config
from benchmarks.rl.policies import save_policy

__all__ = [
    "FIXED_COLUMNS",
    "HELD_OUT_COLUMNS",
    "NOISE_FLOOR",
    "SIZES",
    "SuiteSize",
    "run_rl_suite",
]

#: The default goal of the fixed-goal part, (x, y, z) in m.
FIXED_GOAL = (0.0, 1.5, 0.1)
#: Relative change of F below which two results are not told apart: a 0.1 mm nudge of the box
#: moves F by a median 1.4-1.6 % (docs/model.md, "Stability: the noise floor").
NOISE_FLOOR = 0.015
#: Root of the seeds: run seeds and held-out goals come from SeedSequence(ROOT_SEED).spawn.
ROOT_SEED = 20261123

FIXED_COLUMNS = (
    "method",
    "seed",
    "episode",
    "free_energy",
    "best_so_far_F",
    "normalized_reward",
    "valid",
    "a1",
    "a2",
    "a3",
)
HELD_OUT_COLUMNS = (
    "method",
    "seed",
    "goal_index",
    "goal_x",
    "goal_y",
    "goal_z",
    "budget_per_goal",
    "train_episodes",
    "total_episodes",
    "free_energy",
    "normalized_reward",
    "final_distance",
    "valid",
    "a1",
    "a2",
    "a3",
)

Progress = Callable[[str], None]


@dataclass(frozen=True, kw_only=True)
class SuiteSize:
    """How big a run of the suite is.

    Attributes:
        name: the size's name.
        seeds: seeds of the fixed-goal part.
        task_seeds: seeds of the task-conditioned part (trainings per method).
        fixed_episodes: episodes per method and seed at the fixed goal.
        train_episodes: training episodes of PPO, SAC and the contextual method (its CMA-ES
            runs: ``contextual_goals`` goals of ``train_episodes / contextual_goals`` each).
        contextual_goals: training goals of the contextual method.
        held_out_goals: goals the trained policies are tested on, zero-shot.
        budgets: episodes per held-out goal at which CMA-ES and random sampling are read
            (1, and the budget of equal total episodes with a trained policy, are added).
        popsize: CMA-ES population size (held-out runs and the contextual method).
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
    # Runs in CI (about 80 episodes).
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
    # What docs/rl.md reports: about 5,500 episodes, what fitted the time on a shared machine.
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
    # The size: 10 seeds of 1,024 episodes, 20 held-out goals, budgets 50/100/200
    # (about 60,000 episodes: 4-5 hours on one core at 4-5 episodes/s).
    "paper": SuiteSize(
        name="paper",
        seeds=10,
        task_seeds=3,
        fixed_episodes=1024,
        train_episodes=1024,
        contextual_goals=16,
        held_out_goals=20,
        budgets=(50, 100, 200),
    ),
}


def _configs(size: SuiteSize) -> dict[str, Any]:
    configs: dict[str, Any] = {m: default_config(m) for m in ("ppo", "sac")}
    contextual = default_config("contextual")
    assert isinstance(contextual, ContextualConfig)
    configs["contextual"] = dataclasses.replace(
        contextual,
        n_goals=size.contextual_goals,
        episodes_per_goal=max(1, size.train_episodes // size.contextual_goals),
        popsize=size.popsize,
    )
    changes: dict[str, dict[str, Any]] = {}
    for method, name, value in size.overrides:
        changes.setdefault(method, {})[name] = value
    for method, fields_ in changes.items():
        configs[method] = dataclasses.replace(configs[method], **fields_)
    return configs


def _seeds(root: int, n: int, part: int) -> list[int]:
    children = np.random.SeedSequence([root, part]).spawn(n)
    return [int(c.generate_state(1)[0]) for c in children]


def held_out_goals(n: int, root: int = ROOT_SEED) -> np.ndarray:
    """(n, 3) held-out goals, uniform in the paper's range, from their own seed stream."""
    env = make_env()
    low, high = env.goal_range
    env.close()
    return np.random.default_rng(np.random.SeedSequence([root, 99])).uniform(low, high, (n, 3))


def _fixed_rows(method: str, seed: int, records: Sequence[EpisodeRecord]) -> list[dict[str, Any]]:
    rows = []
    best = float("inf")
    for k, r in enumerate(records, start=1):
        best = min(best, r.free_energy)
        rows.append(
            {
                "method": method,
                "seed": seed,
                "episode": k,
                "free_energy": round(r.free_energy, 3),
                "best_so_far_F": round(best, 3),
                "normalized_reward": round(r.reward, 6),
                "valid": int(r.valid),
                "a1": round(r.action[0], 5),
                "a2": round(r.action[1], 5),
                "a3": round(r.action[2], 5),
            }
        )
    return rows


def _held_row(
    method: str,
    seed: int,
    index: int,
    record: EpisodeRecord,
    *,
    budget: int,
    train: int,
    n_goals: int,
) -> dict[str, Any]:
    return {
        "method": method,
        "seed": seed,
        "goal_index": index,
        "goal_x": round(record.goal[0], 6),
        "goal_y": round(record.goal[1], 6),
        "goal_z": round(record.goal[2], 6),
        "budget_per_goal": budget,
        "train_episodes": train,
        "total_episodes": train + budget * n_goals,
        "free_energy": round(record.free_energy, 3),
        "normalized_reward": round(record.reward, 6),
        "final_distance": round(record.final_distance, 6),
        "valid": int(record.valid),
        "a1": round(record.action[0], 5),
        "a2": round(record.action[1], 5),
        "a3": round(record.action[2], 5),
    }


def _check_size(size: Any) -> SuiteSize:
    if isinstance(size, SuiteSize):
        return size
    if not isinstance(size, str):
        raise TypeError(f"size must be a name in {sorted(SIZES)} or a SuiteSize, got {size!r}")
    if size not in SIZES:
        raise ValueError(f"size must be one of {sorted(SIZES)}, got {size!r}")
    return SIZES[size]


def run_rl_suite(
    size: str | SuiteSize,
    out_dir: str | os.PathLike[str],
    *,
    seeds: int | None = None,
    methods: Sequence[str] = ("random", "cmaes", "ppo", "sac"),
    parts: Sequence[str] = ("fixed", "task"),
    progress: Progress | None = None,
) -> dict[str, Any]:
    """Run the ``rl`` suite and write its CSV files and JSON summary to ``out_dir``.

    Args:
        size: ``"smoke"`` (CI), ``"short"`` (docs/rl.md) or ``"paper"``, or a :class:`SuiteSize`.
        out_dir: folder for ``fixed_goal.csv``, ``held_out.csv``, ``summary.json`` and
            ``policies/``; created if missing.
        seeds: number of seeds of the fixed-goal part instead of the size's.
        methods: fixed-goal methods, a subset of random, cmaes, ppo, sac.
        parts: ``"fixed"`` and/or ``"task"``.
        progress: called with a line of text after each run.

    Returns:
        The summary (also written as ``summary.json``).

    Raises:
        TypeError / ValueError: an unknown size, method or part, or a bad ``seeds``.
    """
    suite = _check_size(size)
    if seeds is not None:
        if isinstance(seeds, bool) or not isinstance(seeds, int):
            raise TypeError(f"seeds must be an int >= 1 or None, got {seeds!r}")
        if seeds < 1:
            raise ValueError(f"seeds must be an int >= 1 or None, got {seeds!r}")
        suite = dataclasses.replace(suite, seeds=seeds)
    allowed = ("random", "cmaes", "ppo", "sac")
    if isinstance(methods, str) or any(m not in allowed for m in methods):
        raise ValueError(f"methods must be a subset of {allowed}, got {methods!r}")
    if isinstance(parts, str) or not parts or any(p not in ("fixed", "task") for p in parts):
        raise ValueError(f"parts must be a non-empty subset of ('fixed', 'task'), got {parts!r}")
    if not isinstance(out_dir, (str, os.PathLike)):
        raise TypeError(f"out_dir must be a str or os.PathLike, got {out_dir!r}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    say = progress or (lambda line: None)
    configs = _configs(suite)
    started = time.time()
    summary: dict[str, Any] = {
        "suite": "rl",
        "size": dataclasses.asdict(suite),
        "root_seed": ROOT_SEED,
        "noise_floor": {
            "relative_F": NOISE_FLOOR,
            "note": "a 0.1 mm nudge of the box moves F by a median 1.4-1.6 % (docs/model.md); "
            "differences of F below this are not told apart",
        },
        "configs": {m: dataclasses.asdict(c) for m, c in configs.items()},
        "machine": {"python": platform.python_version(), "processor": platform.machine()},
    }
    if "fixed" in parts:
        summary["fixed_goal"] = _fixed_part(suite, configs, methods, out, say)
    if "task" in parts:
        summary["task_conditioned"] = _task_part(suite, configs, out, say)
    summary["wall_time_s"] = round(time.time() - started, 1)
    write_json(out / "summary.json", summary)
    return summary


def _fixed_part(
    suite: SuiteSize,
    configs: dict[str, Any],
    methods: Sequence[str],
    out: Path,
    say: Progress,
) -> dict[str, Any]:
    rows: list[dict[str, Any]] = []
    result: dict[str, Any] = {"goal": list(FIXED_GOAL), "episodes": suite.fixed_episodes}
    straight = evaluate_design(_Fixed(np.zeros(3, np.float32)), FIXED_GOAL)
    result["straight_F"] = straight.free_energy
    checkpoints = sorted({c for c in (16, 32, 64, 128, 256, 512, 1024) if c < suite.fixed_episodes})
    checkpoints.append(suite.fixed_episodes)
    per_method: dict[str, Any] = {}
    for method in methods:
        finals: dict[str, list[float]] = {str(c): [] for c in checkpoints}
        policy_f: list[float] = []
        seconds: list[float] = []
        for seed in _seeds(ROOT_SEED, suite.seeds, 0):
            t0 = time.time()
            n = suite.fixed_episodes
            if method == "random":
                records = run_random(total_episodes=n, seed=seed, goal=FIXED_GOAL)
            elif method == "cmaes":
                records = run_cmaes(
                    total_episodes=n, seed=seed, goal=FIXED_GOAL, popsize=suite.popsize
                )
            else:
                train = train_ppo if method == "ppo" else train_sac
                trained = train(configs[method], total_episodes=n, seed=seed, goal=FIXED_GOAL)
                records = trained.records[:n]
                policy_f.append(evaluate_design(trained.model, FIXED_GOAL).free_energy)
            seconds.append(time.time() - t0)
            rows.extend(_fixed_rows(method, seed, records))
            best = np.minimum.accumulate([r.free_energy for r in records])
            for c in checkpoints:
                finals[str(c)].append(float(best[min(c, len(best)) - 1]))
            say(f"fixed {method} seed {seed}: best F {best[-1]:.0f} ({seconds[-1]:.0f} s)")
        per_method[method] = {
            "best_so_far_F": finals,
            "median_best_so_far_F": {c: float(np.median(v)) for c, v in finals.items()},
            "final_policy_F": policy_f,
            "seconds_per_run": [round(s, 1) for s in seconds],
        }
        write_csv(out / "fixed_goal.csv", FIXED_COLUMNS, rows)
    result["methods"] = per_method
    if "random" in per_method:
        ref = per_method["random"]["median_best_so_far_F"]
        result["vs_random_at_equal_episodes"] = {
            m: {
                c: _compare(v["median_best_so_far_F"][c], ref[c]) for c in v["median_best_so_far_F"]
            }
            for m, v in per_method.items()
            if m != "random"
        }
    return result


def _compare(value: float, reference: float) -> dict[str, Any]:
    """How ``value`` compares with ``reference`` (lower F is better), against the noise floor."""
    relative = (value - reference) / abs(reference)
    if abs(relative) < NOISE_FLOOR:
        verdict = "within the noise floor"
    else:
        verdict = "better" if relative < 0 else "worse"
    return {"relative": round(relative, 4), "verdict": verdict}


class _Fixed:
    """A policy that always answers the same action (the straight tool, for one)."""

    def __init__(self, action: np.ndarray) -> None:
        self.action = action

    def predict(self, observation: Any, deterministic: bool = True) -> tuple[np.ndarray, None]:
        return self.action, None


def _task_part(
    suite: SuiteSize, configs: dict[str, Any], out: Path, say: Progress
) -> dict[str, Any]:
    goals = held_out_goals(suite.held_out_goals)
    n_goals = len(goals)
    rows: list[dict[str, Any]] = []
    env = make_env()
    train_cost: dict[str, int] = {}

    def zero_shot(method: str, seed: int, policy: Any, train: int) -> None:
        for i, goal in enumerate(goals):
            record = evaluate_design(policy, goal, env=env)
            rows.append(_held_row(method, seed, i, record, budget=1, train=train, n_goals=n_goals))

    zero_shot("straight", 0, _Fixed(env.to_action(np.zeros(3))), 0)
    policies_dir = out / "policies"
    for k, seed in enumerate(_seeds(ROOT_SEED, suite.task_seeds, 1)):
        for method in ("ppo", "sac", "contextual"):
            t0 = time.time()
            config = configs[method]
            if method == "contextual":
                trained = train_contextual(config, seed=seed, progress=say)
            else:
                train = train_ppo if method == "ppo" else train_sac
                trained = train(
                    config, total_episodes=suite.train_episodes, seed=seed, randomize_goal=True
                )
            spent = len(trained.records)
            train_cost[method] = spent
            zero_shot(method, seed, trained.model, spent)
            if k == 0:
                save_policy(
                    trained.model,
                    method,
                    policies_dir / f"{method}.json",
                    config=config,
                    train_episodes=spent,
                    extra={"seed": seed, "suite_size": suite.name},
                )
            say(
                f"task {method} seed {seed}: trained on {spent} episodes ({time.time() - t0:.0f} s)"
            )
            write_csv(out / "held_out.csv", HELD_OUT_COLUMNS, rows)
    budgets = _held_out_budgets(suite)
    budget = max(budgets)
    for i, goal in enumerate(goals):
        for method in ("cmaes", "random"):
            seed = _seeds(ROOT_SEED, n_goals, 2 if method == "cmaes" else 3)[i]
            if method == "cmaes":
                records = run_cmaes(
                    total_episodes=budget, seed=seed, goal=goal, popsize=suite.popsize, env=env
                )
            else:
                records = run_random(total_episodes=budget, seed=seed, goal=goal, env=env)
            for b in budgets:
                best = min(records[:b], key=lambda r: r.free_energy)
                rows.append(_held_row(method, seed, i, best, budget=b, train=0, n_goals=n_goals))
        say(f"held-out goal {i + 1}/{n_goals}: CMA-ES and random at {budgets}")
        write_csv(out / "held_out.csv", HELD_OUT_COLUMNS, rows)
    env.close()
    return _summarize_held_out(rows, goals, train_cost)


def _held_out_budgets(suite: SuiteSize) -> tuple[int, ...]:
    """The size's budgets, plus 1 and the budget whose total equals a trained policy's.

    A policy trained on ``train_episodes`` and tried once on each of n goals spends
    ``train_episodes + n`` episodes: CMA-ES and random sampling get the same total at
    ``ceil(train_episodes / n) + 1`` episodes per goal.
    """
    n = suite.held_out_goals
    equal = -(-suite.train_episodes // n) + 1
    return tuple(sorted({1, equal, *suite.budgets}))


def _summarize_held_out(
    rows: list[dict[str, Any]], goals: np.ndarray, train_cost: dict[str, int]
) -> dict[str, Any]:
    by: dict[str, list[dict[str, Any]]] = {}
    for row in rows:
        key = (
            row["method"]
            if row["budget_per_goal"] == 1
            else (f"{row['method']}@{row['budget_per_goal']}")
        )
        by.setdefault(key, []).append(row)
    straight = {r["goal_index"]: r["free_energy"] for r in by["straight"]}
    approaches: dict[str, Any] = {}
    for key, group in by.items():
        ratio = [r["free_energy"] / straight[r["goal_index"]] for r in group]
        approaches[key] = {
            "median_F": float(np.median([r["free_energy"] for r in group])),
            "median_F_over_straight": float(np.median(ratio)),
            "total_episodes": int(group[0]["total_episodes"]),
            "train_episodes": int(group[0]["train_episodes"]),
        }
    # Per goal, each zero-shot policy against CMA-ES and random at each budget.
    wins: dict[str, Any] = {}
    for key in ("ppo", "sac", "contextual", "straight"):
        if key not in by:
            continue
        mine = {(r["seed"], r["goal_index"]): r["free_energy"] for r in by[key]}
        for ref in [k for k in by if "@" in k]:
            theirs = {r["goal_index"]: r["free_energy"] for r in by[ref]}
            verdicts = [_compare(f, theirs[g])["verdict"] for (_, g), f in mine.items()]
            wins[f"{key} vs {ref}"] = {v: verdicts.count(v) for v in sorted(set(verdicts))}
    return {
        "goals": goals.round(6).tolist(),
        "approaches": approaches,
        "per_goal_verdicts": wins,
        "train_episodes": train_cost,
    }
