"""The report of an rl suite run folder, made from its stored files alone (nothing simulated).

:func:`make_rl_report` reads ``manifest.json`` (the suite's configuration: sizes, held-out
tasks, budgets, noise floor) and the evaluation log (one row per episode, see
``docs/results-format.md``) and writes under ``run_folder/report/``:

- ``fixed-goal.csv/md`` and ``fixed-goal.png``: at the fixed goal, each method's best F so far
  after 16, 32, ... episodes (median, min and max over seeds) against random sampling's at the
  same number of episodes, with the verdict against the noise floor; the final deterministic
  policies' F and the straight tool's;
- ``held-out.csv/md`` and ``held-out.png`` (the ``task`` part), ``held-out-mass.csv/md`` and
  ``held-out-mass.png`` (the ``mass`` part): per approach (a policy's zero-shot tool, the
  straight tool, CMA-ES or random sampling afresh at a budget per task), the episodes spent in
  total (training included), the median F and F / straight tool's F, and per task the verdicts
  against random sampling and CMA-ES at the budget of equal total episodes;
- ``held-out-per-goal.csv/md`` (and ``held-out-mass-per-goal``): F of every approach on every
  held-out task;
- ``summary.json``: the numbers of all of the above; ``rl.md``: the page that shows them.

Best F so far counts every episode's F as the env scores it: an unusable design scores
F_idle + 1e5, so it is never the best of a run that has a usable one. The same stored results
give the same CSV, Markdown and JSON bytes.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, cast

import numpy as np
import pandas as pd
import scipy.stats as _sps
from matplotlib.axes import Axes
from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator

from benchmarks.reports.comparison import REPORT_DIR, new_figure
from benchmarks.reports.markdown import markdown_table
from benchmarks.reports.plots import save_png
from benchmarks.reports.stats import holm_bonferroni, vargha_delaney_a12
from benchmarks.reports.success import (
    design_succeeded,
    success_cell,
    success_criterion,
    success_rate,
    task_tolerance,
)
from benchmarks.rl.suite import RL_SUITE_KIND, RL_SUITE_NAME
from benchmarks.storage import ResultStore, atomic_write_text, json_text, read_manifest
from benchmarks.storage.table import csv_text

__all__ = [
    "fixed_goal_table",
    "held_out_per_goal",
    "held_out_table",
    "make_rl_report",
]

_POLICIES = ("contextual", "ppo", "sac")
_CHECKPOINTS = (16, 32, 64, 128, 256, 512, 1024)
#: Family-wise error rate of the seeds' tests against random sampling.
_ALPHA = 0.05
# One colour per method in every figure; CMA-ES and random sampling as in the other reports.
_COLORS = {
    "random": "tab:red",
    "cmaes": "tab:blue",
    "ppo": "tab:green",
    "sac": "tab:orange",
    "contextual": "tab:purple",
}
_LABELS = {
    "random": "random sampling",
    "cmaes": "CMA-ES",
    "ppo": "PPO",
    "sac": "SAC",
    "contextual": "contextual",
    "straight": "straight tool",
}


# --- reading --------------------------------------------------------------------------------


def _suite_config(folder: Path) -> dict[str, Any]:
    manifest = read_manifest(folder)
    extra, config = manifest.get("extra"), manifest.get("config")
    if not isinstance(extra, dict) or extra.get("kind") != RL_SUITE_KIND:
        raise ValueError(f"{folder} is not an rl suite run folder (manifest kind is not rl-suite)")
    if not isinstance(config, dict) or config.get("name") != RL_SUITE_NAME:
        raise ValueError(f"{folder}/manifest.json: config is not the rl suite's")
    return config


def _log(folder: Path) -> pd.DataFrame:
    log = ResultStore(folder).read()
    return log[log["suite"] == RL_SUITE_NAME]


def _rows(log: pd.DataFrame, variant: str) -> pd.DataFrame:
    return log[log["variant"] == variant].sort_values(["optimizer", "seed", "candidate"])


def _compare(value: float, reference: float, floor: float) -> tuple[float, str]:
    """Relative difference of F (lower is better) and its verdict against the noise floor."""
    relative = (value - reference) / abs(reference)
    if abs(relative) < floor:
        return relative, "within the noise floor"
    return relative, "better" if relative < 0 else "worse"


def _method_order(names: Iterable[str]) -> list[str]:
    order = ("random", "cmaes", "ppo", "sac", "contextual", "straight")
    unique = set(names)
    return [n for n in order if n in unique] + sorted(unique - set(order))


# --- fixed goal -----------------------------------------------------------------------------


def _best_so_far(log: pd.DataFrame) -> dict[str, np.ndarray]:
    """Per method, the (seeds, episodes) best F so far at the fixed goal."""
    fixed = _rows(log, "fixed")
    curves: dict[str, np.ndarray] = {}
    for method, rows in fixed.groupby("optimizer", sort=False):
        runs = [np.minimum.accumulate(r["free_energy"].to_numpy()) for _, r in rows.groupby("seed")]
        n = min(len(r) for r in runs)
        curves[str(method)] = np.array([r[:n] for r in runs])
    return curves


def _best_successes(log: pd.DataFrame) -> dict[str, list[list[bool | None]]]:
    """Per method, per seed, whether the best design so far succeeded after each episode."""
    fixed = _rows(log, "fixed")
    criterion = success_criterion()  # the rl suite's ToolDesignRL-v0 is the push task
    outcomes: dict[str, list[list[bool | None]]] = {}
    for method, rows in fixed.groupby("optimizer", sort=False):
        runs = []
        for _, run in rows.groupby("seed"):
            f = run["free_energy"].to_numpy(dtype=np.float64)
            f = np.where(np.isnan(f), np.inf, f)  # a failed episode has no F
            # A log without the columns (hand-made, or written by other code) has unknown
            # outcomes: n/a, never a failure.
            status = run["status"].to_numpy() if "status" in run else np.full(len(f), "ok")
            distance = (
                run["final_distance"].to_numpy(dtype=np.float64)
                if "final_distance" in run
                else np.full(len(f), np.nan)
            )
            # The box's final height and tilt, where stored: the task's whole test.
            height, tilt = (
                run[c].to_numpy(dtype=np.float64) if c in run else np.full(len(f), np.nan)
                for c in ("final_height", "final_tilt")
            )
            best, seen = 0, []
            for i in range(len(f)):
                best = i if f[i] < f[best] else best  # the first of equal lowest F
                seen.append(
                    design_succeeded(
                        status[best], distance[best], criterion, height[best], tilt[best]
                    )
                )
            runs.append(seen)
        n = min(len(r) for r in runs)
        outcomes[str(method)] = [r[:n] for r in runs]
    return outcomes


def fixed_goal_table(log: pd.DataFrame, noise_floor: float) -> pd.DataFrame:
    """Best F so far at the fixed goal per method and number of episodes, against random.

    Args:
        log: the rl suite's evaluation log.
        noise_floor: relative difference of F below which two values are not told apart.

    Returns:
        One row per (method, episodes): ``seeds``, ``median_best_F``, ``min_best_F``,
        ``max_best_F``, ``random_median_best_F``, ``relative_to_random`` and ``verdict``
        (empty for random sampling itself, or when random sampling was not run), and the
        seeds' test against random sampling's at the same number of episodes: ``a12`` (Vargha
        and Delaney's A12 of the method against random sampling: the probability that a seed
        of the method ends above one of random sampling's, ties counting half; below 0.5 the
        method tends to be better), ``p_holm`` (two-sided Mann-Whitney U, Holm-corrected over
        the methods at that number of episodes; NaN with fewer than 2 seeds) and
        ``significant`` (``p_holm < 0.05``); then ``successes``, ``success_seeds``,
        ``success_rate``, ``success_low`` and ``success_high``: the seeds whose best design so
        far succeeded (:mod:`benchmarks.reports.success`), with a 95 % Wilson interval.
    """
    curves = _best_so_far(log)
    outcomes = _best_successes(log)
    rows = []
    for method in _method_order(curves):
        runs = curves[method]
        n = runs.shape[1]
        for episodes in sorted({c for c in _CHECKPOINTS if c < n} | {n}):
            best = runs[:, episodes - 1]
            row: dict[str, Any] = {
                "method": method,
                "episodes": episodes,
                "seeds": len(best),
                "median_best_F": float(np.median(best)),
                "min_best_F": float(best.min()),
                "max_best_F": float(best.max()),
                "random_median_best_F": math.nan,
                "relative_to_random": math.nan,
                "verdict": "",
            }
            rate = success_rate(r[episodes - 1] for r in outcomes[method])
            row.update(
                successes=rate.successes,
                success_seeds=rate.n,
                success_rate=rate.rate,
                success_low=rate.low,
                success_high=rate.high,
            )
            reference = curves.get("random")
            if reference is not None and method != "random" and episodes <= reference.shape[1]:
                ref = float(np.median(reference[:, episodes - 1]))
                relative, verdict = _compare(row["median_best_F"], ref, noise_floor)
                row.update(random_median_best_F=ref, relative_to_random=relative, verdict=verdict)
            rows.append(row)
    table = pd.DataFrame(rows)
    tests = _seed_tests(curves)
    table["a12"] = [
        tests.get((r.method, r.episodes), (math.nan,) * 2)[0] for r in table.itertuples()
    ]
    table["p_holm"] = [
        tests.get((r.method, r.episodes), (math.nan,) * 2)[1] for r in table.itertuples()
    ]
    table["significant"] = (table["p_holm"] < _ALPHA).astype(bool)
    return table


def _seed_tests(curves: Mapping[str, np.ndarray]) -> dict[tuple[str, int], tuple[float, float]]:
    """(method, episodes) -> (A12 against random sampling, Holm-corrected p) over seeds.

    A12 is the method's against random sampling: below 0.5 the method tends to end lower.
    """
    reference = curves.get("random")
    if reference is None or reference.shape[0] < 2:
        return {}
    out: dict[tuple[str, int], tuple[float, float]] = {}
    for episodes in sorted({c for c in _CHECKPOINTS} | {r.shape[1] for r in curves.values()}):
        if episodes > reference.shape[1]:
            continue
        ref = reference[:, episodes - 1]
        names, a12, p = [], [], []
        for method, runs in curves.items():
            if method == "random" or episodes > runs.shape[1] or runs.shape[0] < 2:
                continue
            best = runs[:, episodes - 1]
            names.append(method)
            a12.append(vargha_delaney_a12(best, ref))
            if np.unique(np.concatenate([best, ref])).size == 1:
                p.append(1.0)
            else:
                p.append(float(_sps.mannwhitneyu(best, ref, alternative="two-sided").pvalue))
        for method, effect, adjusted in zip(names, a12, holm_bonferroni(np.array(p)), strict=True):
            out[(method, episodes)] = (float(effect), float(adjusted))
    return out


def _fixed_policies(log: pd.DataFrame) -> dict[str, list[float]]:
    rows = _rows(log, "fixed-policy")
    return {
        str(m): [float(v) for v in r["free_energy"]]
        for m, r in rows.groupby("optimizer", sort=True)
    }


def _fixed_figure(log: pd.DataFrame, straight: float | None, path: Path) -> Path:
    curves = _best_so_far(log)
    figure, ax = new_figure((6.4, 4.0))
    lows, early = [], []
    for method in _method_order(curves):
        runs = curves[method]
        x = np.arange(1, runs.shape[1] + 1)
        color = _COLORS.get(method, "tab:gray")
        seeds = f"{len(runs)} seed{'s' if len(runs) > 1 else ''}"
        label = f"{_LABELS.get(method, method)} ({seeds})"
        ax.plot(x, np.median(runs, axis=0), color=color, label=label)
        ax.fill_between(x, runs.min(0), runs.max(0), color=color, alpha=0.15, linewidth=0)
        lows.append(runs.min())
        early.append(runs[:, min(8, runs.shape[1]) - 1].max())
    if straight is not None:
        ax.axhline(straight, color="k", ls="--", lw=1, label=f"straight tool ({straight:.0f})")
    if lows:
        # From the best of all to where the curves are after about 8 episodes.
        ax.set_ylim(min(lows) * 0.99, max(early) * 1.02)
    _log_x(ax)
    ax.set_xlabel("episodes (tools simulated)")
    ax.set_ylabel("best F so far")
    ax.set_title("Fixed goal: median and range over seeds")
    ax.grid(alpha=0.3)
    ax.legend(frameon=False, fontsize="small")
    return save_png(figure, path)


def _log_x(ax: Axes) -> None:
    """A log x axis with ticks at 1, 2, 4, ... (up to 2^15) labelled as plain numbers.

    Call it after plotting: the held-out figure's budgets reach 4,000 episodes at `full`.
    """
    ax.set_xscale("log", base=2)
    ax.xaxis.set_major_locator(FixedLocator([2.0**k for k in range(16)]))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:.0f}"))
    ax.xaxis.set_minor_locator(NullLocator())


def _fixed_markdown(
    table: pd.DataFrame, policies: Mapping[str, list[float]], floor: float
) -> list[str]:
    methods = [m for m in _method_order(table["method"])]
    lines = [
        "Best F so far at the fixed goal, median over seeds (min-max); for each method its "
        "relative difference to random sampling's median at the same number of episodes, and "
        f"whether it exceeds the noise floor ({floor:.1%} of F).",
        "",
    ]
    header = ["episodes", *(_LABELS.get(m, m) for m in methods)]
    body = []
    for episodes in sorted(set(table["episodes"])):
        cells = [str(episodes)]
        for method in methods:
            row = table[(table["method"] == method) & (table["episodes"] == episodes)]
            if row.empty:
                cells.append("")
                continue
            r = row.iloc[0]
            cell = f"{r.median_best_F:.0f} ({r.min_best_F:.0f}-{r.max_best_F:.0f})"
            if r.verdict:
                mark = (
                    f"**{r.relative_to_random:+.1%}**"
                    if r.verdict == "better"
                    else (f"{r.relative_to_random:+.1%}")
                )
                suffix = ", noise" if r.verdict == "within the noise floor" else ""
                cell += f": {mark}{suffix}"
            cells.append(cell)
        body.append(cells)
    lines += markdown_table(header, body)
    lines += [
        "",
        "Success at each number of episodes: the share of seeds whose best design so far was "
        f"usable and left the box within {task_tolerance():g} m of the goal (the push task's "
        "tolerance; from the stored status and final distance), with a 95 % Wilson interval; "
        "n/a where no final distance was stored.",
        "",
    ]
    rows_ = []
    for episodes in sorted(set(table["episodes"])):
        cells = [str(episodes)]
        for method in methods:
            row = table[(table["method"] == method) & (table["episodes"] == episodes)]
            cells.append("" if row.empty else _success_of(row.iloc[0], "success_seeds", "seeds"))
        rows_.append(cells)
    lines += markdown_table(header, rows_)
    tested = table[table["p_holm"].notna()]
    if not tested.empty:
        others = [m for m in methods if m in set(tested["method"])]
        lines += [
            "",
            "The seeds against random sampling's at the same number of episodes: Vargha and "
            "Delaney's A12 (the chance that a seed of the method ends above one of random "
            "sampling's; below 0.5 the method tends to be better) and the Holm-corrected p of a "
            "two-sided Mann-Whitney U test over seeds (bold: significant at 0.05).",
            "",
        ]
        rows = []
        for episodes in sorted(set(tested["episodes"])):
            cells = [str(episodes)]
            for method in others:
                row = tested[(tested["method"] == method) & (tested["episodes"] == episodes)]
                if row.empty:
                    cells.append("")
                    continue
                r = row.iloc[0]
                text = f"A12 {r.a12:.2f}, p {r.p_holm:.3g}"
                cells.append(f"**{text}**" if r.significant else text)
            rows.append(cells)
        lines += markdown_table(["episodes", *(_LABELS.get(m, m) for m in others)], rows)
    if policies:
        lines.append("")
        for method in _method_order(policies):
            values = ", ".join(f"{v:.0f}" for v in policies[method])
            what = (
                "the straight tool"
                if method == "straight"
                else (f"{_LABELS.get(method, method)}'s final deterministic policy (one per seed)")
            )
            lines.append(f"- F of {what}: {values}")
    return lines


def _success_of(row: Any, known: str, total: str) -> str:
    from benchmarks.reports.success import SuccessRate

    n = int(row[known])
    return success_cell(
        SuccessRate(
            successes=int(row["successes"]),
            n=n,
            unknown=int(row[total]) - n,
            rate=float(row["success_rate"]),
            low=float(row["success_low"]),
            high=float(row["success_high"]),
        )
    )


# --- held-out tasks -------------------------------------------------------------------------


def _prefix(part: str) -> str:
    return "mass-" if part == "mass" else ""


def held_out_per_goal(log: pd.DataFrame, config: Mapping[str, Any], part: str) -> pd.DataFrame:
    """F of every approach on every held-out task of a part (``"task"`` or ``"mass"``).

    An approach is a policy's zero-shot tool (``budget_per_goal`` 1, its training episodes
    counted), the straight tool, or CMA-ES / random sampling afresh on the task, read after
    ``budget_per_goal`` episodes (the best F of its first that many).

    Args:
        log: the rl suite's evaluation log.
        config: the suite's configuration (the manifest's ``config``).
        part: ``"task"`` or ``"mass"``.

    Returns:
        One row per (approach, seed, goal_index): ``approach``, ``method``, ``seed``,
        ``budget_per_goal``, ``goal_index``, ``goal_x/y/z`` (m), ``box_mass`` (kg),
        ``train_episodes``, ``total_episodes``, ``free_energy``, ``straight_F``,
        ``F_over_straight``, ``final_distance`` (m) and ``success`` (the design was usable and
        left the box within the push task's tolerance; None without a stored distance); empty
        if the part was not run.
    """
    criterion = success_criterion()
    prefix = _prefix(part)
    zero = _rows(log, f"{prefix}zero-shot")
    if zero.empty:
        return pd.DataFrame()
    n_goals = int(config["size"]["held_out_goals"])
    train = _rows(log, f"{prefix}train").groupby(["optimizer", "seed"]).size()
    straight = zero[zero["optimizer"] == "straight"].set_index("goal_index")["free_energy"]
    rows: list[dict[str, Any]] = []

    def add(approach: str, method: str, seed: int, budget: int, trained: int, r: Any) -> None:
        index = int(r["goal_index"])
        f = float(r["free_energy"])
        reference = float(straight.get(index, math.nan))
        rows.append(
            {
                "approach": approach,
                "method": method,
                "seed": int(seed),
                "budget_per_goal": budget,
                "goal_index": index,
                "goal_x": float(r["goal_x"]),
                "goal_y": float(r["goal_y"]),
                "goal_z": float(r["goal_z"]),
                "box_mass": float(r["box_mass"]),
                "train_episodes": trained,
                "total_episodes": trained + budget * n_goals,
                "free_energy": f,
                "straight_F": reference,
                "F_over_straight": f / reference,
                "final_distance": float(r.get("final_distance", math.nan)),
                "success": design_succeeded(
                    r.get("status", "ok"),
                    r.get("final_distance"),
                    criterion,
                    r.get("final_height"),
                    r.get("final_tilt"),
                ),
            }
        )

    for (method, seed), group in zero.groupby(["optimizer", "seed"], sort=True):
        trained = int(train.get((method, seed), 0))
        for _, r in group.iterrows():
            add(str(method), str(method), int(seed), 1, trained, r)
    search = _rows(log, f"{prefix}held-out")
    for (method, seed), group in search.groupby(["optimizer", "seed"], sort=True):
        energies = group["free_energy"].to_numpy()
        for budget in config["budgets"]:
            best = int(np.argmin(energies[:budget]))
            add(f"{method}@{budget}", str(method), int(seed), int(budget), 0, group.iloc[best])
    frame = pd.DataFrame(rows)
    return frame.sort_values(["total_episodes", "approach", "seed", "goal_index"]).reset_index(
        drop=True
    )


def _equal_budget(config: Mapping[str, Any]) -> int:
    size = config["size"]
    return -(-int(size["train_episodes"]) // int(size["held_out_goals"])) + 1


def held_out_table(per_goal: pd.DataFrame, config: Mapping[str, Any]) -> pd.DataFrame:
    """Per approach: episodes spent, median F and F / straight, verdicts per task.

    Args:
        per_goal: from :func:`held_out_per_goal`.
        config: the suite's configuration (the manifest's ``config``).

    Returns:
        One row per approach, sorted by total episodes: ``approach``, ``seeds`` (training seeds
        of a policy; 1 for the others), ``budget_per_goal``, ``train_episodes``, ``total_episodes``,
        ``goals``, ``median_F``, ``median_F_over_straight``, ``better_than_straight`` (tasks
        where F is lower than the straight tool's by more than the noise floor), and for the
        zero-shot approaches ``vs_random_<b>`` and ``vs_cmaes_<b>`` at the equal budget ``b``:
        ``better/within/worse`` counts over (seed, task); ``successes``, ``success_tasks``
        (tasks whose outcome is known), ``success_rate``, ``success_low``, ``success_high``
        (95 % Wilson interval) over (seed, task).
    """
    if per_goal.empty:
        return pd.DataFrame()
    floor = float(config["noise_floor"])
    equal = _equal_budget(config)
    refs = {
        m: per_goal[per_goal["approach"] == f"{m}@{equal}"].set_index("goal_index")["free_energy"]
        for m in ("random", "cmaes")
    }
    rows = []
    for approach, group in per_goal.groupby("approach", sort=False):
        ratio = group["F_over_straight"].to_numpy()
        row: dict[str, Any] = {
            "approach": approach,
            # Search methods run once per task, each task with its own seed.
            "seeds": 1 if "@" in str(approach) else int(group["seed"].nunique()),
            "budget_per_goal": int(group["budget_per_goal"].iloc[0]),
            "train_episodes": int(group["train_episodes"].max()),
            "total_episodes": int(group["total_episodes"].max()),
            "goals": int(group["goal_index"].nunique()),
            "tasks": len(group),
            "median_F": float(group["free_energy"].median()),
            "median_F_over_straight": float(np.median(ratio)),
            "better_than_straight": int(np.sum(ratio < 1.0 - floor)),
        }
        rate = success_rate(group["success"])
        row.update(
            successes=rate.successes,
            success_tasks=rate.n,
            success_rate=rate.rate,
            success_low=rate.low,
            success_high=rate.high,
        )
        if "@" not in str(approach):
            for method, ref in refs.items():
                if ref.empty:
                    continue
                verdicts = [
                    _compare(float(f), float(ref[g]), floor)[1]
                    for f, g in zip(group["free_energy"], group["goal_index"], strict=True)
                ]
                row[f"vs_{method}_{equal}"] = "/".join(
                    str(verdicts.count(v)) for v in ("better", "within the noise floor", "worse")
                )
        rows.append(row)
    rows.sort(key=lambda r: (r["total_episodes"], _approach_key(str(r["approach"]))))
    return pd.DataFrame(rows)


def _held_out_markdown(
    table: pd.DataFrame, per_goal: pd.DataFrame, config: Mapping[str, Any], part: str
) -> list[str]:
    equal = _equal_budget(config)
    n = int(config["size"]["held_out_goals"])
    task = "(goal, box mass) task" if part == "mass" else "goal"
    lines = [
        f"{n} held-out {task}s. F of each approach, its median over tasks and the median of F "
        "divided by the straight tool's F at the same task; episodes in total, training "
        f"included. The zero-shot approaches are compared per {task} with random sampling and "
        f"CMA-ES afresh at {equal} episodes per task, the budget of equal total episodes "
        "(better / within the noise floor / worse, counted over training seeds and tasks). "
        + f"Success: the share of tasks (once per training seed) whose design was usable and "
        f"left the box within {task_tolerance():g} m of the goal (the push task's tolerance; "
        "from the stored status and final distance), with a 95 % Wilson interval; n/a where no "
        "final distance was stored.",
        "",
    ]
    header = [
        "approach",
        "episodes in total",
        "median F",
        "success",
        "median F / straight",
        "better than straight",
        f"vs random@{equal}",
        f"vs CMA-ES@{equal}",
    ]
    body = []
    for _, r in table.iterrows():
        name = str(r["approach"])
        method, _, budget = name.partition("@")
        label = _LABELS.get(method, method) + (f"@{budget}" if budget else "")
        if method in _POLICIES:
            label += " (zero-shot)"
        if r["train_episodes"]:
            total = f"{r['train_episodes']} + {n} = {r['total_episodes']}"
        else:
            total = str(r["total_episodes"])
        seeds = f", {r['seeds']} training seeds" if method in _POLICIES and r["seeds"] > 1 else ""
        body.append(
            [
                label,
                total + seeds,
                f"{r['median_F']:.0f}",
                _success_of(r, "success_tasks", "tasks"),
                f"{r['median_F_over_straight']:.2f}",
                f"{r['better_than_straight']} of {r['tasks']}",
                _text(r.get(f"vs_random_{equal}")),
                _text(r.get(f"vs_cmaes_{equal}")),
            ]
        )
    lines += markdown_table(header, body)
    return lines


def _approach_key(approach: str) -> tuple[int, int, int]:
    """Table order: the straight tool, the policies, then each search method by budget."""
    method, _, budget = approach.partition("@")
    order = _method_order([method, *_LABELS])
    group = 0 if method == "straight" else 2 if budget else 1
    return group, order.index(method), int(budget or 0)


def _text(value: Any) -> str:
    """A table cell: "" for a missing value (NaN, None)."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    return str(value)


def _per_goal_markdown(per_goal: pd.DataFrame, part: str) -> list[str]:
    """Goals as rows, approaches as columns (policies: the median over training seeds)."""
    approaches = sorted(set(per_goal["approach"]), key=_approach_key)
    wide = per_goal.groupby(["goal_index", "approach"])["free_energy"].median().unstack()
    tasks = per_goal.drop_duplicates("goal_index").set_index("goal_index").sort_index()
    header = ["task", "goal (x, y, z) m"] + (["box mass kg"] if part == "mass" else [])
    header += [str(a) for a in approaches]
    body = []
    for index, task in tasks.iterrows():
        cells = [str(index), f"({task['goal_x']:.3f}, {task['goal_y']:.3f}, {task['goal_z']:.3f})"]
        if part == "mass":
            cells.append(f"{task['box_mass']:.3f}")
        cells += [f"{wide.loc[index, a]:.0f}" for a in approaches]
        body.append(cells)
    return [
        "F of every approach on every held-out task (policies: median over training seeds).",
        "",
        *markdown_table(header, body),
    ]


def _held_out_figure(per_goal: pd.DataFrame, part: str, path: Path) -> Path:
    figure, ax = new_figure((6.4, 4.2))
    for method in _method_order(per_goal["method"]):
        mine = per_goal[per_goal["method"] == method]
        if method == "straight":
            continue
        points = mine.groupby("total_episodes")["F_over_straight"]
        x = np.array(sorted(points.groups))
        medians = np.array([points.get_group(v).median() for v in x])
        color = _COLORS.get(method, "tab:gray")
        ax.scatter(
            mine["total_episodes"], mine["F_over_straight"], s=8, color=color, alpha=0.35, lw=0
        )
        style = "-o" if method in ("cmaes", "random") else "D"
        label = _LABELS.get(method, method) + (
            " afresh per task" if method in ("cmaes", "random") else " (zero-shot)"
        )
        ax.plot(x, medians, style, color=color, label=label, markersize=6)
    ax.axhline(1.0, color="k", ls="--", lw=1, label="straight tool")
    _log_x(ax)
    ax.set_xlabel("episodes in total (training included)")
    ax.set_ylabel("F / straight tool's F at the task")
    task = "goal and box-mass tasks" if part == "mass" else "goals"
    ax.set_title(f"Held-out {task}: each task (dots) and the median")
    ax.grid(alpha=0.3)
    ax.legend(frameon=False, fontsize="small")
    return save_png(figure, path)


# --- files ----------------------------------------------------------------------------------


def _records(frame: pd.DataFrame) -> list[dict[str, Any]]:
    return cast("list[dict[str, Any]]", frame.to_dict("records"))


def make_rl_report(
    run_folder: str | os.PathLike[str], *, out_dir: str | os.PathLike[str] | None = None
) -> list[Path]:
    """Write the rl suite's report from its stored files alone (see the module docstring).

    Args:
        run_folder: a run folder of :func:`benchmarks.rl.run_rl_suite` (its ``manifest.json``
            and its parts or consolidated evaluations file).
        out_dir: where to write; ``run_folder/report`` if None.

    Returns:
        The files written.

    Raises:
        FileNotFoundError: no such folder, or no ``manifest.json`` in it.
        ValueError: not an rl suite run folder, or a stored file is malformed.
        benchmarks.storage.EmptyStoreError: the folder holds no episodes yet.
    """
    folder = Path(run_folder)
    if not folder.is_dir():
        raise FileNotFoundError(f"run folder {folder} does not exist or is not a folder")
    config = _suite_config(folder)
    log = _log(folder)
    target = folder / REPORT_DIR if out_dir is None else Path(out_dir)
    floor = float(config["noise_floor"])
    size = config["size"]
    written: list[Path] = []
    summary: dict[str, Any] = {
        "suite": RL_SUITE_NAME,
        "size": size,
        "parts": config["parts"],
        "noise_floor": floor,
        "episodes": int(len(log)),
    }
    page = [
        f"# The rl suite, size `{size['name']}`",
        "",
        "Made from the stored files alone by `tooldesign report` "
        "(`benchmarks.reports.make_suite_report`); see docs/rl.md for what the suite does. "
        f"{len(log)} episodes in all. Differences of F below {floor:.1%} are within the noise "
        "floor (a 0.1 mm nudge of the box moves F by a median 1.4-1.6 %).",
        "",
    ]
    fixed = fixed_goal_table(log, floor)
    if not fixed.empty:
        policies = _fixed_policies(log)
        straight = policies.get("straight", [None])[0]
        lines = _fixed_markdown(fixed, policies, floor)
        written.append(atomic_write_text(target / "fixed-goal.csv", csv_text(fixed)))
        written.append(atomic_write_text(target / "fixed-goal.md", "\n".join(lines) + "\n"))
        written.append(_fixed_figure(log, straight, target / "fixed-goal.png"))
        goal = ", ".join(f"{v:g}" for v in config["fixed_goal"])
        page += [f"## Fixed goal ({goal})", "", *lines, "", "![Best F so far](fixed-goal.png)", ""]
        summary["fixed_goal"] = {
            "goal": config["fixed_goal"],
            "episodes": int(size["fixed_episodes"]),
            "best_so_far": _records(fixed),
            "final_policy_F": policies,
        }
    for part in ("task", "mass"):
        per_goal = held_out_per_goal(log, config, part)
        if per_goal.empty:
            continue
        table = held_out_table(per_goal, config)
        stem = f"held-out{'-mass' if part == 'mass' else ''}"
        lines = _held_out_markdown(table, per_goal, config, part)
        goal_lines = _per_goal_markdown(per_goal, part)
        written.append(atomic_write_text(target / f"{stem}.csv", csv_text(table)))
        written.append(atomic_write_text(target / f"{stem}.md", "\n".join(lines) + "\n"))
        written.append(atomic_write_text(target / f"{stem}-per-goal.csv", csv_text(per_goal)))
        written.append(
            atomic_write_text(target / f"{stem}-per-goal.md", "\n".join(goal_lines) + "\n")
        )
        written.append(_held_out_figure(per_goal, part, target / f"{stem}.png"))
        title = (
            "Held-out goals and box masses (`mass` part)"
            if part == "mass"
            else "Held-out goals (`task` part)"
        )
        page += [f"## {title}", "", *lines, "", f"![F per task]({stem}.png)", "", *goal_lines, ""]
        summary[part] = {
            "equal_budget": _equal_budget(config),
            "budgets": config["budgets"],
            "approaches": _records(table),
        }
        if part == "mass":
            summary[part]["mass_range"] = config["mass_range"]
    written.append(atomic_write_text(target / "summary.json", json_text(summary)))
    written.append(atomic_write_text(target / "rl.md", "\n".join(page)))
    return written
