"""Tiers per (task, degree): the share of random designs that succeed, and CMA-ES's regret.

Issue 35 asks for each (task, degree) to be labelled easy, medium or hard from baseline
results, as EvoGym labels its tasks. Two baselines, each giving a tier; the label is the harder
of the two (easy < medium < hard), and both are kept beside it. By design a cell is labelled by
its harder side; since each side is a noisy estimate, the harder of two leans toward hard (an
error of either side toward hard moves the label, an error toward easy only where the other
side agrees), which the flag of labels the intervals leave open (below) makes visible.

**Random share.** ``perf.studies.task_baselines`` labels each task at d = 3 from the share p of 64
random designs that succeed (*easy* for p >= 10 %, *medium* for 1 % <= p < 10 %, *hard* for p < 1 %:
:data:`~perf.studies.task_baselines.EASY_SHARE`, :data:`~perf.studies.task_baselines.HARD_SHARE`).
With 64 designs one success is 1.6 %, so *hard* on the share means no success observed among the 64,
not a share measured below 1 % (0 of 64 has the Wilson interval [0, 5.7] %, which reaches medium).
This study measures p at every degree of the benchmark protocol's dimension axis: per task and d,
``--random`` (64) designs drawn uniformly in the protocol's bounds of that degree
(:func:`benchmarks.protocol.dimensions.bounds_of`: +-1.5 for every coefficient but the linear one,
+-0.5), scored at the task's default goal with p^X = 20 and the env's defaults; success is
``info["success"]`` (the box stands within the task's radius of the goal), an unusable design a
failure. The share is measured at that one goal, while the regret below is over the protocol's
instances (goals drawn from the task's range, for push also the box's mass and friction): the two
baselines do not see the same instances. Per (task, d): the share, its 95 % Wilson interval, the
usable share, F's median over the usable designs and the tier (``random_tier``); the interval says
how far a label near a boundary may move with another draw. The d = 3 draw is the baselines' own
(``np.random.SeedSequence(seed)`` in the same bounds), so its shares equal
``docs/results/tasks/baselines.json`` (a test checks it); d = 5 and 8 draw from
``SeedSequence((seed, d))``. The (task, d) pairs run in parallel on ``--workers`` processes, one env
each. ``--from FILE`` takes these figures from a tiers JSON written before (the committed
``docs/results/tasks/tiers.json``) instead of simulating again.

**CMA-ES's regret** (``--protocol DIR``, :func:`protocol_baselines`): from a benchmark protocol
run folder's report (``DIR/report/runs.csv``, written by ``tooldesign bench protocol`` or
``tooldesign report DIR``; nothing is simulated), per (task, d) the protocol ran, CMA-ES's runs
(``optimizer == "cmaes"``, one per instance and seed): the median over runs of the final
normalized regret at the budget (``regret_1``: (b - F_ref) / (F_random(budget) - F_ref), 0 the
instance's reference, 1 random sampling with the same budget; a run whose instance has no scale,
random sampling as good as the reference, has none and is counted apart), with a 95 %
percentile bootstrap interval over instances (:data:`BOOTSTRAP_RESAMPLES` resamples of the
instances with replacement, each bringing all its runs, seed :data:`BOOTSTRAP_SEED`, as the
report's ECDF bands; none with one instance; with few instances it covers less than 95 %, so
read it as a spread), the number of runs and instances, and the share of runs whose final
design succeeds (``success_1``) with its Wilson interval (n/a where the folder stored no final
distance). The regret tier: *easy* for a median below :data:`EASY_REGRET` (0.25: CMA-ES closes
more than three quarters of the gap between random sampling and the best known design), *hard*
at or above :data:`HARD_REGRET` (0.75: it closes less than a quarter, barely better than random
sampling with its budget), *medium* between. A cell the protocol did not run (the tasks other
than push at d = 5 and 8) has no regret tier and keeps the random share's label; the output
says which.

**Labels the intervals leave open.** A side's tier is uncertain when its interval (closed:
Wilson for the share, bootstrap for the regret) reaches another tier of that side, that is
straddles (or touches) the threshold next to its estimate (:meth:`TierRule.share_tiers`,
:meth:`TierRule.regret_tiers`). The label is uncertain when the easiest and the hardest label
over both intervals differ (:meth:`TierRule.label_tiers`: the harder of the sides' easiest,
and the harder of their hardest), so a side's uncertainty counts only where it can change the
label: an uncertain random tier of medium beside a surely hard regret leaves the label surely
hard. A regret without an interval (one instance) counts as its median's tier and its own flag
is None (not known). Printed and tabled, each uncertain tier carries a ``?`` (``medium?``),
the label's line says which tiers it spans, and :data:`UNCERTAIN_NOTE` follows the cells.

The success share of CMA-ES's runs is shown but does not enter the label: the random share
already says how rare success is, and CMA-ES minimizes F, whose lowest design need not succeed.
The regret depends on the budget, so labels are those of the protocol size they were read from.
Thresholds are parameters (:class:`TierRule`; ``--easy-share``, ``--hard-share``,
``--easy-regret``, ``--hard-regret``; not positive or not ordered: refused).

Written (``--json``): per cell the random figures, ``random_tier``, ``baseline`` (CMA-ES's
figures; None where the protocol did not run the cell, and without ``--protocol``),
``regret_tier``, ``tier`` (the label), ``random_uncertain``, ``regret_uncertain``,
``tier_range`` (the easiest and the hardest label within the intervals) and ``uncertain``;
beside the cells ``random``, ``seed``, ``random_from`` (the ``--from`` file), ``rule`` and
``protocol`` (the folder, its size, the optimizer, the budgets and how the interval was
made). ``--from`` also reads a file written before these fields existed, whose ``tier`` is the
random share's; it checks every field it reads (:func:`read_random_cells`) and refuses a bad
one in one line naming the file, the cell and the field; where the file does not record
``random`` or ``seed``, the output says "not recorded in FILE". A task or degree given twice
is labelled once. Printed: a line per cell (the random figures and tier), without
``--protocol`` as the study always printed them but for the ``?``; with it, a line of
CMA-ES's figures under each cell, the cells without them, and the labels as a Markdown table
(docs/tasks.md).

Run: ``python -m perf.studies.task_tiers [--task hook] [--degrees 3 5 8] [--random 64]
[--seed 0] [--workers 2] [--json FILE]``; 64 x 3 x 4 = 768 evaluations, about a minute on 2
idle cores. Output: docs/results/tasks/tiers.json and tiers-output.txt. With the protocol's
baseline and no simulation: ``python -m perf.studies.task_tiers --from
docs/results/tasks/tiers.json --protocol DIR --json FILE``.
"""

from __future__ import annotations

import argparse
import dataclasses
import io
import json
import math
import os
import statistics
import sys
from collections.abc import Iterable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.protocol.dimensions import DEGREES, bounds_of
from benchmarks.reports.success import success_rate, wilson_interval
from benchmarks.storage import atomic_write_text
from perf.studies.task_baselines import EASY_SHARE, HARD_SHARE, tier
from tooldesign_env.tasks import BUILTIN_TASKS, get_task

#: CMA-ES's median final normalized regret: below the first a cell is easy, at or above the
#: second hard, between them medium (regret 1 is random sampling with the same budget).
EASY_REGRET = 0.25
HARD_REGRET = 0.75

#: The protocol's optimizer whose regret labels a cell.
BASELINE_OPTIMIZER = "cmaes"

#: Resamples of the instances, and the generator's seed, of the regret median's interval.
BOOTSTRAP_RESAMPLES = 10_000
BOOTSTRAP_SEED = 0

#: The tiers, easiest first: the label of two is the later one.
TIERS: tuple[str, ...] = ("easy", "medium", "hard")

#: The report's table the baseline is read from, inside a protocol run folder.
RUNS_TABLE = "report/runs.csv"

#: The figures of a cell's random part, as ``measure_cell`` writes them (``--from`` reads them).
_RANDOM_FIELDS = (
    "task",
    "degree",
    "n",
    "usable",
    "successes",
    "success_rate",
    "success_95",
    "free_energy_median",
)


@dataclasses.dataclass(frozen=True, kw_only=True)
class TierRule:
    """The thresholds of both tiers.

    Attributes:
        easy_share: A share of random designs that succeed at or above which the random tier is
            easy.
        hard_share: A share below which it is hard (medium between the two).
        easy_regret: A median final normalized regret of CMA-ES below which the regret tier is
            easy.
        hard_regret: A median at or above which it is hard (medium between the two).
    """

    easy_share: float = EASY_SHARE
    hard_share: float = HARD_SHARE
    easy_regret: float = EASY_REGRET
    hard_regret: float = HARD_REGRET

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"{field.name} must be a number, got {value!r}")
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{field.name} must be a finite number > 0, got {value!r}")
        if not self.hard_share < self.easy_share <= 1:
            raise ValueError(
                f"the shares must be ordered 0 < hard_share < easy_share <= 1, got hard_share "
                f"{self.hard_share!r} and easy_share {self.easy_share!r}"
            )
        if not self.easy_regret < self.hard_regret:
            raise ValueError(
                f"the regrets must be ordered 0 < easy_regret < hard_regret, got easy_regret "
                f"{self.easy_regret!r} and hard_regret {self.hard_regret!r}"
            )

    def share_tier(self, share: float) -> str:
        """The random tier of a share of random designs that succeed, in [0, 1]."""
        if not 0 <= share <= 1:
            raise ValueError(f"a share of successes must be in [0, 1], got {share!r}")
        if share >= self.easy_share:
            return "easy"
        return "medium" if share >= self.hard_share else "hard"

    def regret_tier(self, regret: float | None) -> str | None:
        """The regret tier of CMA-ES's median final normalized regret; None without one."""
        if regret is None or math.isnan(regret):
            return None
        if regret < self.easy_regret:
            return "easy"
        return "medium" if regret < self.hard_regret else "hard"

    def label(self, share: float, regret: float | None) -> str:
        """The tier of a cell: the harder of its random tier and its regret tier (if any)."""
        return harder(self.share_tier(share), self.regret_tier(regret))

    def share_tiers(self, share: float, interval: Sequence[float] | None) -> tuple[str, str]:
        """The easiest and the hardest random tier of a share and its interval's ends.

        They differ when the interval (closed) reaches across a threshold: the tier may move
        with another draw. Without an interval, the share's tier twice.
        """
        return _span([self.share_tier(v) for v in (share, *(interval or ()))])

    def regret_tiers(
        self, regret: float | None, interval: Sequence[float] | None
    ) -> tuple[str, str] | None:
        """The easiest and the hardest regret tier of a median and its interval's ends.

        None without a regret; without an interval, the median's tier twice.
        """
        tier_ = self.regret_tier(regret)
        if tier_ is None:
            return None
        others = [self.regret_tier(v) for v in interval or ()]
        return _span([tier_, *(t for t in others if t is not None)])

    def label_tiers(
        self,
        share: float,
        share_interval: Sequence[float] | None,
        regret: float | None = None,
        regret_interval: Sequence[float] | None = None,
    ) -> tuple[str, str]:
        """The easiest and the hardest label a cell could have within its intervals.

        The label is the harder of two tiers, so its easiest is the harder of their easiest
        and its hardest the harder of their hardest: a side's uncertainty moves the label only
        where that side can decide it (a random tier that is medium or easy beside a regret
        tier that is surely hard leaves the label hard).
        """
        shares = self.share_tiers(share, share_interval)
        regrets = self.regret_tiers(regret, regret_interval) or (None, None)
        return harder(shares[0], regrets[0]), harder(shares[1], regrets[1])

    def describe(self, *, regret: bool = True) -> str:
        """The rule in one sentence; the random share's alone if not ``regret``."""
        share = (
            f"easy p >= {_pct(self.easy_share)}, medium {_pct(self.hard_share)} <= p < "
            f"{_pct(self.easy_share)}, hard p < {_pct(self.hard_share)}"
        )
        if not regret:
            return share
        return (
            f"random share p: {share}; CMA-ES's median final regret r: easy r < "
            f"{self.easy_regret:g}, medium {self.easy_regret:g} <= r < {self.hard_regret:g}, "
            f"hard r >= {self.hard_regret:g}; tier = the harder of the two"
        )


def _pct(share: float) -> str:
    return f"{100 * share:g} %"


def _span(tiers: Sequence[str]) -> tuple[str, str]:
    return min(tiers, key=TIERS.index), max(tiers, key=TIERS.index)


def harder(*tiers: str | None) -> str:
    """The hardest of some tiers (None, no tier, is left out).

    Raises:
        ValueError: If none is given, or one is not easy, medium or hard.
    """
    known = [t for t in tiers if t is not None]
    for t in known:
        if t not in TIERS:
            raise ValueError(f"a tier is one of {', '.join(TIERS)}, got {t!r}")
    if not known:
        raise ValueError("harder() needs at least one tier")
    return max(known, key=TIERS.index)


def draw(degree: int, random: int, seed: int) -> np.ndarray:
    """The (random, degree) designs of one cell: uniform in the protocol's bounds of ``degree``.

    At d = 3 the draw of ``perf.studies.task_baselines`` (the same seed sequence and bounds).
    """
    bounds = np.asarray(bounds_of(degree), dtype=float)
    key = np.random.SeedSequence(seed) if degree == 3 else np.random.SeedSequence((seed, degree))
    rng = np.random.default_rng(key)
    return rng.uniform(bounds[:, 0], bounds[:, 1], size=(random, degree))


def measure_cell(task: str, degree: int, random: int, seed: int) -> dict[str, Any]:
    """The success share and tier of ``random`` designs of one (task, d) at its default goal."""
    from tooldesign_env import ToolDesignEnv, ToolSpec

    env = ToolDesignEnv(task=task, tool=ToolSpec(degree=degree), bounds=bounds_of(degree))
    env.reset(seed=0)
    rows = []
    try:
        for design in draw(degree, random, seed):
            info = env.step(design)[4]
            rows.append((bool(info["valid"]), bool(info["success"]), float(info["free_energy"])))
    finally:
        env.close()
    successes = sum(s for _, s, _ in rows)
    usable = [f for v, _, f in rows if v]
    low, high = wilson_interval(successes, len(rows))
    return {
        "task": task,
        "degree": degree,
        "n": len(rows),
        "usable": len(usable),
        "successes": successes,
        "success_rate": successes / len(rows),
        "success_95": [low, high],
        "free_energy_median": statistics.median(usable) if usable else None,
        "tier": tier(successes / len(rows)),
    }


def bootstrap_median(
    groups: Sequence[Sequence[float]],
    *,
    resamples: int = BOOTSTRAP_RESAMPLES,
    level: float = 0.95,
    seed: int = BOOTSTRAP_SEED,
) -> tuple[float, float] | None:
    """A percentile bootstrap interval of the median of pooled groups, resampling the groups.

    Args:
        groups: The values of each group (an instance's runs); at least one value each.
        resamples: Bootstrap resamples, >= 1.
        level: Coverage, in (0, 1).
        seed: Seed of the generator.

    Returns:
        ``(low, high)``; None with fewer than two groups (a resample of one group is that group).

    Raises:
        ValueError: If a group is empty or holds a value that is not finite, or ``resamples``
            or ``level`` is out of range.
    """
    if isinstance(resamples, bool) or not isinstance(resamples, int) or resamples < 1:
        raise ValueError(f"resamples must be a whole number >= 1, got {resamples!r}")
    if not 0 < level < 1:
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    arrays = [np.asarray(g, dtype=float) for g in groups]
    if any(a.size == 0 or not np.isfinite(a).all() for a in arrays):
        raise ValueError("every group must hold at least one value, all finite")
    if len(arrays) < 2:
        return None
    # Groups padded with NaN to one width: a resample's median is the NaN-ignoring median of
    # its rows, the median of the runs it pooled.
    width = max(a.size for a in arrays)
    table = np.full((len(arrays), width), np.nan)
    for row, values in zip(table, arrays, strict=True):
        row[: values.size] = values
    rng = np.random.default_rng(seed)
    picks = rng.integers(0, len(arrays), size=(resamples, len(arrays)))
    medians = np.nanmedian(table[picks].reshape(resamples, -1), axis=1)
    alpha = (1 - level) / 2
    low, high = np.quantile(medians, [alpha, 1 - alpha])
    return float(low), float(high)


def protocol_baselines(
    folder: str | os.PathLike[str],
    *,
    optimizer: str = BASELINE_OPTIMIZER,
    resamples: int = BOOTSTRAP_RESAMPLES,
    seed: int = BOOTSTRAP_SEED,
) -> dict[str, Any]:
    """CMA-ES's final regret and success per (task, d) of a protocol run folder's report.

    Reads ``protocol.json`` (the plan: tasks, instances, degrees, seeds, budgets) and the
    report's ``report/runs.csv`` (one row per run); simulates nothing.

    Args:
        folder: The protocol run folder.
        optimizer: The optimizer whose runs are read (its label in the report).
        resamples: Bootstrap resamples of the regret median's interval.
        seed: Seed of the bootstrap.

    Returns:
        ``{"folder", "size", "optimizer", "budgets": {d: evaluations}, "interval", "cells":
        {(task, d): cell}}``, a cell: ``runs``, ``instances``, ``budget``,
        ``regret_median`` (None if no run has a regret), ``regret_95`` (None with fewer than
        two instances with one), ``regret_undefined`` (runs without a regret), ``successes``,
        ``success_known`` (runs whose outcome is stored), ``success_rate`` and
        ``success_95`` (None where none is stored).

    Raises:
        ValueError: In one line naming the folder: it is not a protocol run folder, has no
            report, its report lacks a column or the optimizer, or the optimizer's runs of a
            planned cell are not the plan's.
    """
    import pandas as pd

    from benchmarks.protocol.suite import read_protocol
    from benchmarks.storage.runfiles import read_run_file

    config = read_protocol(folder)  # ValueError: "... is not a protocol run folder: ..."
    try:
        text = read_run_file(folder, RUNS_TABLE)
    except FileNotFoundError:
        raise ValueError(
            f"{folder} has no report ({RUNS_TABLE}): make it with `tooldesign report {folder}` "
            "once the run is finished"
        ) from None
    try:
        runs = pd.read_csv(io.BytesIO(text))
    except (ValueError, pd.errors.ParserError) as err:
        first = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise ValueError(f"{folder}/{RUNS_TABLE} is not a report table: {first}") from None
    missing = [c for c in ("optimizer", "instance", "degree", "seed", "regret_1") if c not in runs]
    if missing:
        raise ValueError(
            f"{folder}/{RUNS_TABLE} is not a protocol report's runs table: no column "
            f"{', '.join(missing)}"
        )
    if "task" not in runs:  # a report of one task has no task column
        runs = runs.assign(task=config.tasks[0])
    mine = runs[runs["optimizer"].astype(str) == optimizer]
    if mine.empty:
        found = ", ".join(sorted(str(o) for o in runs["optimizer"].unique()))
        raise ValueError(
            f"{folder}/{RUNS_TABLE} has no run of optimizer {optimizer!r} (it has: {found})"
        )
    cells: dict[tuple[str, int], dict[str, Any]] = {}
    for task in config.tasks:
        planned = config.task_cells(task)
        for degree in config.task_degrees_of(task):
            labels = {i.label for i, d in planned if d == degree}
            rows = mine[(mine["task"].astype(str) == task) & (mine["degree"] == degree)]
            wanted = len(labels) * config.n_seeds
            if len(rows) != wanted or set(rows["instance"].astype(str)) != labels:
                raise ValueError(
                    f"{folder}/{RUNS_TABLE} has {len(rows)} run(s) of {optimizer} on {task} at "
                    f"d = {degree}, its protocol.json plans {wanted} ({len(labels)} instances x "
                    f"{config.n_seeds} seeds): rebuild the report with `tooldesign report "
                    f"{folder}`"
                )
            cells[(task, degree)] = _baseline_cell(rows, config.budget(degree), resamples, seed)
    return {
        "folder": str(folder),
        "size": config.size,
        "optimizer": optimizer,
        "budgets": {d: config.budget(d) for d in config.all_degrees()},
        "interval": (
            f"95 % percentile bootstrap over instances ({resamples} resamples, seed {seed})"
        ),
        "cells": cells,
    }


def _baseline_cell(rows: Any, budget: int, resamples: int, seed: int) -> dict[str, Any]:
    regret = rows["regret_1"].to_numpy(dtype=float)
    defined = ~np.isnan(regret)
    groups = [
        group["regret_1"].dropna().to_numpy(dtype=float)
        for _, group in rows.groupby("instance", sort=True)
    ]
    groups = [g for g in groups if g.size]
    interval = bootstrap_median(groups, resamples=resamples, seed=seed) if groups else None
    outcomes = rows["success_1"].tolist() if "success_1" in rows else [None] * len(rows)
    rate = success_rate(outcomes)
    return {
        "runs": len(rows),
        "instances": int(rows["instance"].nunique()),
        "budget": budget,
        "regret_median": float(np.median(regret[defined])) if defined.any() else None,
        "regret_95": None if interval is None else list(interval),
        "regret_undefined": int((~defined).sum()),
        "successes": rate.successes,
        "success_known": rate.n,
        "success_rate": None if rate.n == 0 else rate.rate,
        "success_95": None if rate.n == 0 else [rate.low, rate.high],
    }


def read_random_cells(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The random-share part of a tiers JSON written before (``--json``), to label again.

    Every field read is checked, since the labels and their intervals are built on them: each
    cell's task (a task of the study) and degree (one of the protocol's), ``n`` (>= 1),
    ``usable`` (a whole number in [0, n]), ``successes`` (in [0, usable]: an unusable design
    never succeeds), ``success_rate`` (successes / n), ``success_95`` (the 95 % Wilson interval
    of successes of n) and ``free_energy_median`` (a finite number, None exactly when no design
    was usable); beside the cells ``random`` (the designs per cell: every cell's ``n``) and
    ``seed``, each a whole number or absent (None: the file does not record it).

    Returns:
        ``{"random", "seed", "cells"}``, each cell with the fields :func:`measure_cell` writes
        but the tier (which is recomputed by the rule in use).

    Raises:
        ValueError: In one line naming the file (and the cell and field at fault): missing, not
            JSON, not a tiers file, a field missing or out of range, or a (task, d) twice.
    """
    try:
        record = json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ValueError(f"{path} does not exist: give a tiers JSON (--json) to --from") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ValueError(f"{path} is not a tiers JSON: {err}") from None
    cells = record.get("cells") if isinstance(record, dict) else None
    if not isinstance(cells, list) or not cells:
        raise ValueError(f"{path} is not a tiers JSON: it has no list of cells")
    random, seed = record.get("random"), record.get("seed")
    if random is not None and not (_whole(random) and random >= 1):
        raise ValueError(f"{path}: random {random!r} must be a whole number >= 1 (or absent)")
    if seed is not None and not _whole(seed):
        raise ValueError(f"{path}: seed {seed!r} must be a whole number (or absent)")
    kept = [_checked_cell(path, k, cell, random) for k, cell in enumerate(cells)]
    keys = [(c["task"], c["degree"]) for c in kept]
    twice = [f"{t} at d = {d}" for t, d in dict.fromkeys(keys) if keys.count((t, d)) > 1]
    if twice:
        raise ValueError(f"{path}: the cell {', '.join(twice)} appears more than once")
    return {"random": random, "seed": seed, "cells": kept}


def _whole(value: object) -> bool:
    return type(value) is int  # bool is an int to isinstance, never a count


def _checked_cell(path: str | os.PathLike[str], k: int, cell: object, random: int | None) -> Any:
    """One cell of a tiers JSON, each of its random-share fields checked (see above)."""
    if not isinstance(cell, dict):
        raise ValueError(f"{path}: cell {k} is {type(cell).__name__}, not an object of fields")
    missing = [f for f in _RANDOM_FIELDS if f not in cell]
    if missing:
        raise ValueError(f"{path}: cell {k} has no {', '.join(missing)}")
    task, degree = cell["task"], cell["degree"]
    if task not in BUILTIN_TASKS:
        raise ValueError(
            f"{path}: cell {k} has task {task!r}; the study's tasks are {', '.join(BUILTIN_TASKS)}"
        )
    if not _whole(degree) or degree not in DEGREES:
        raise ValueError(
            f"{path}: cell {k} ({task}) has degree {degree!r}; the protocol's degrees are "
            f"{', '.join(map(str, DEGREES))}"
        )
    where = f"{path}: cell {k} ({task}, d = {degree})"

    def bad(field: str, wanted: str) -> ValueError:
        return ValueError(f"{where} has {field} {cell[field]!r}; it must be {wanted}")

    n, successes, usable = cell["n"], cell["successes"], cell["usable"]
    if not (_whole(n) and n >= 1):
        raise bad("n", "a whole number >= 1")
    if random is not None and n != random:
        raise bad("n", f"the file's random designs per cell, {random}")
    if not (_whole(usable) and 0 <= usable <= n):
        raise bad("usable", f"a whole number in [0, n = {n}]")
    if not (_whole(successes) and 0 <= successes <= usable):
        # An unusable design never succeeds (ToolDesignEnv's info["success"]).
        raise bad("successes", f"a whole number in [0, usable = {usable}]")
    rate = cell["success_rate"]
    if not (_number(rate) and rate == successes / n):
        raise bad("success_rate", f"successes / n = {successes}/{n}")
    interval = cell["success_95"]
    wilson = wilson_interval(successes, n)
    pair = isinstance(interval, list) and len(interval) == 2 and all(map(_number, interval))
    if not (
        pair
        and all(math.isclose(a, b, abs_tol=1e-12) for a, b in zip(interval, wilson, strict=True))
    ):
        raise bad(
            "success_95",
            f"the 95 % Wilson interval of {successes} of {n}, [{wilson[0]:.6g}, {wilson[1]:.6g}]",
        )
    median = cell["free_energy_median"]
    if usable == 0 and median is not None:
        raise bad("free_energy_median", "null: no design is usable (usable 0)")
    if usable > 0 and not (_number(median) and math.isfinite(median)):
        raise bad("free_energy_median", f"a finite number (F's median over {usable} usable)")
    return {f: cell[f] for f in _RANDOM_FIELDS}


def _number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def label_cells(
    cells: Iterable[Mapping[str, Any]],
    baselines: Mapping[str, Any] | None = None,
    rule: TierRule | None = None,
) -> list[dict[str, Any]]:
    """The cells with both tiers and the label.

    Args:
        cells: Random-share cells (:func:`measure_cell`, :func:`read_random_cells`).
        baselines: From :func:`protocol_baselines`, or None (no regret tier anywhere).
        rule: The thresholds; the defaults if None.

    Returns:
        Per cell its random figures, ``random_tier``, ``baseline`` (the protocol's figures of
        the cell, None where the protocol did not run it), ``regret_tier`` (None likewise, or
        where no run has a regret), ``tier``, the harder of the two, and how sure each is:
        ``random_uncertain`` (the share's Wilson interval reaches another random tier),
        ``regret_uncertain`` (the regret's bootstrap interval reaches another regret tier;
        None without a regret or without an interval, e.g. one instance), ``tier_range`` (the
        easiest and the hardest label within both intervals, :meth:`TierRule.label_tiers`)
        and ``uncertain`` (they differ: the label may move with another draw).
    """
    rule = rule or TierRule()
    found = baselines["cells"] if baselines is not None else {}
    labelled = []
    for cell in cells:
        random = {f: cell[f] for f in _RANDOM_FIELDS}
        share, share_95 = cell["success_rate"], cell["success_95"]
        baseline = found.get((cell["task"], cell["degree"]))
        regret = None if baseline is None else baseline["regret_median"]
        regret_95 = None if baseline is None else baseline["regret_95"]
        shares = rule.share_tiers(share, share_95)
        regrets = rule.regret_tiers(regret, regret_95)
        span = rule.label_tiers(share, share_95, regret, regret_95)
        labelled.append(
            {
                **random,
                "random_tier": rule.share_tier(share),
                "baseline": baseline,
                "regret_tier": rule.regret_tier(regret),
                "tier": rule.label(share, regret),
                "random_uncertain": shares[0] != shares[1],
                "regret_uncertain": (
                    None if regrets is None or regret_95 is None else regrets[0] != regrets[1]
                ),
                "tier_range": list(span),
                "uncertain": span[0] != span[1],
            }
        )
    return labelled


def tiers_record(
    cells: list[dict[str, Any]],
    *,
    random: int | None,
    seed: int | None,
    rule: TierRule,
    baselines: Mapping[str, Any] | None = None,
    random_from: str | None = None,
) -> dict[str, Any]:
    """The JSON record of labelled cells: how the random part was made, the rule, the protocol."""
    protocol = None
    if baselines is not None:
        protocol = {k: v for k, v in baselines.items() if k != "cells"}
        protocol["budgets"] = {str(d): b for d, b in protocol["budgets"].items()}
    return {
        "random": random,
        "seed": seed,
        "random_from": random_from,
        "rule": dataclasses.asdict(rule),
        "protocol": protocol,
        "cells": cells,
    }


def _line(cell: dict[str, Any]) -> str:
    low, high = cell["success_95"]
    median = cell["free_energy_median"]  # None when no design was usable
    return (
        f"{cell['task']:<9} d = {cell['degree']}: {cell['successes']:>2}/{cell['n']} succeed "
        f"({100 * cell['success_rate']:.1f} %, 95 % [{100 * low:.1f}, {100 * high:.1f}] %), "
        f"{cell['usable']}/{cell['n']} usable, median F "
        f"{'n/a' if median is None else f'{median:.0f}'}: "
        + _marked(cell.get("random_tier", cell["tier"]), cell.get("random_uncertain"))
    )


#: What the marker of a label that its intervals leave open means, printed under the cells.
UNCERTAIN_NOTE = (
    "?: the 95 % interval (Wilson for the share, bootstrap for the regret) reaches another "
    "tier, so the label may move with another draw"
)


def _marked(tier_: str | None, uncertain: bool | None) -> str:
    """A tier, with ``?`` if its interval reaches another tier."""
    return "n/a" if tier_ is None else tier_ + ("?" if uncertain else "")


def _tier_words(cell: Mapping[str, Any]) -> str:
    """The label, marked, and the tiers it spans if its intervals leave it open."""
    words = _marked(cell["tier"], cell["uncertain"])
    if cell["uncertain"]:
        easiest, hardest = cell["tier_range"]
        words += f" ({easiest} to {hardest} within the intervals)"
    return words


def _baseline_line(cell: dict[str, Any], optimizer: str) -> str:
    base = cell["baseline"]
    if base is None:
        return f"{'':<9} no protocol run of this cell: the random share's tier, {_tier_words(cell)}"
    median, interval = base["regret_median"], base["regret_95"]
    regret = "n/a" if median is None else f"{median:.3f}"
    if interval is not None:
        regret += f" (95 % [{interval[0]:.3f}, {interval[1]:.3f}])"
    if base["regret_undefined"]:
        regret += f", {base['regret_undefined']} run(s) without a regret"
    if base["success_rate"] is None:
        success = "success n/a (not stored)"
    else:
        low, high = base["success_95"]
        success = (
            f"{base['successes']}/{base['success_known']} succeed "
            f"({100 * base['success_rate']:.1f} %, 95 % [{100 * low:.1f}, {100 * high:.1f}] %)"
        )
    return (
        f"{'':<9} {optimizer}, {base['runs']} runs on {base['instances']} instances of "
        f"{base['budget']} evaluations: median final regret {regret}, {success}: regret "
        f"{_marked(cell['regret_tier'], cell['regret_uncertain'])} -> tier {_tier_words(cell)}"
    )


def markdown_table(cells: Sequence[Mapping[str, Any]]) -> str:
    """The labels as a table of tasks x degrees, as docs/tasks.md shows them.

    A tier whose interval reaches another tier is marked ``?`` (:data:`UNCERTAIN_NOTE`).
    """
    tasks = list(dict.fromkeys(c["task"] for c in cells))
    degrees = sorted({c["degree"] for c in cells})
    by = {(c["task"], c["degree"]): c for c in cells}
    lines = [
        "| task | " + " | ".join(f"d = {d}" for d in degrees) + " |",
        "|---|" + "---|" * len(degrees),
    ]
    for task in tasks:
        row = []
        for d in degrees:
            c = by.get((task, d))
            if c is None:
                row.append("")
                continue
            base = c["baseline"]
            if base is None:
                regret = "not run by the protocol"
            elif base["regret_median"] is None:
                regret = "CMA-ES: no regret"
            else:
                regret = f"CMA-ES regret {base['regret_median']:.2f}"
                if base["regret_95"] is not None:
                    low, high = base["regret_95"]
                    regret += f" [{low:.2f}, {high:.2f}]"
                regret += f": {_marked(c['regret_tier'], c['regret_uncertain'])}"
            row.append(
                f"**{_marked(c['tier'], c['uncertain'])}** (random "
                f"{_marked(c['random_tier'], c['random_uncertain'])}; {regret})"
            )
        lines.append(f"| {task} | " + " | ".join(row) + " |")
    return "\n".join(lines)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The study's command line."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--task",
        action="append",
        choices=BUILTIN_TASKS,
        default=None,
        help="a task to label (repeat for more; each of them if not given)",
    )
    parser.add_argument(
        "--degrees", type=int, nargs="+", default=None, help="degrees (3 5 8 if not given)"
    )
    parser.add_argument("--random", type=int, default=None, help="random designs per cell (64)")
    parser.add_argument("--seed", type=int, default=None, help="seed of the random draw (0)")
    parser.add_argument("--workers", type=int, default=None, help="processes (2)")
    parser.add_argument("--json", default=None, help="also write the figures to this JSON file")
    parser.add_argument(
        "--from",
        dest="from_file",
        default=None,
        metavar="FILE",
        help="take the random-share figures from this tiers JSON instead of simulating",
    )
    parser.add_argument(
        "--protocol",
        default=None,
        metavar="DIR",
        help="add CMA-ES's final regret and success from this protocol run folder's report",
    )
    parser.add_argument("--easy-share", type=float, default=EASY_SHARE)
    parser.add_argument("--hard-share", type=float, default=HARD_SHARE)
    parser.add_argument("--easy-regret", type=float, default=EASY_REGRET)
    parser.add_argument("--hard-regret", type=float, default=HARD_REGRET)
    args = parser.parse_args(argv)
    # A task or degree given twice means it once (it would otherwise be measured and printed
    # twice).
    if args.task is not None:
        args.task = list(dict.fromkeys(args.task))
    if args.degrees is not None:
        args.degrees = list(dict.fromkeys(args.degrees))
    for degree in args.degrees or ():
        if degree not in DEGREES:
            parser.error(f"--degrees: {degree} is not a degree of the protocol ({DEGREES})")
    if args.from_file is not None:
        given = [o for o in ("random", "seed", "workers") if getattr(args, o) is not None]
        if given:
            parser.error(
                f"--{', --'.join(given)}: these describe a simulation; --from FILE takes the "
                "file's figures"
            )
    else:
        args.random = 64 if args.random is None else args.random
        args.seed = 0 if args.seed is None else args.seed
        args.workers = 2 if args.workers is None else args.workers
        if args.random < 1 or args.workers < 1:
            parser.error(f"--random and --workers must be >= 1, got {args.random}, {args.workers}")
    try:
        args.rule = TierRule(
            easy_share=args.easy_share,
            hard_share=args.hard_share,
            easy_regret=args.easy_regret,
            hard_regret=args.hard_regret,
        )
    except ValueError as err:
        parser.error(str(err).replace("easy_", "--easy-").replace("hard_", "--hard-"))
    return args


def _select(
    cells: list[dict[str, Any]], tasks: list[str] | None, degrees: list[int] | None, source: str
) -> list[dict[str, Any]]:
    """The cells of ``--task`` x ``--degrees`` (each of the file's where not given)."""
    if tasks is None and degrees is None:
        return cells
    have = {(c["task"], c["degree"]): c for c in cells}
    tasks = tasks or list(dict.fromkeys(c["task"] for c in cells))
    degrees = degrees or sorted({c["degree"] for c in cells})
    absent = [f"{t} at d = {d}" for t in tasks for d in degrees if (t, d) not in have]
    if absent:
        raise ValueError(f"{source} has no cell {', '.join(absent)}")
    return [have[(t, d)] for t in tasks for d in degrees]


def _draw_words(random: int | None, seed: int | None, from_file: str | None) -> str:
    """How the random share was drawn, saying so where a ``--from`` file does not record it."""
    if from_file is None:
        return f"{random} random designs per cell (seed {seed}), at the task's default goal"
    if random is None and seed is None:
        words = f"random designs per cell and seed: not recorded in {from_file}"
    elif random is None:
        words = f"random designs per cell: not recorded in {from_file} (seed {seed})"
    elif seed is None:
        words = f"{random} random designs per cell (seed: not recorded in {from_file})"
    else:
        words = f"{random} random designs per cell (seed {seed})"
    return f"{words}, from {from_file}"


def main(argv: list[str] | None = None) -> int:
    """Measure (or read ``--from``) and print every (task, d); label; write ``--json``."""
    args = parse_args(argv)
    try:
        baselines = None if args.protocol is None else protocol_baselines(args.protocol)
        if args.from_file is not None:
            record = read_random_cells(args.from_file)
            random_cells = _select(record["cells"], args.task, args.degrees, args.from_file)
            random, seed = record["random"], record["seed"]
        else:
            tasks = args.task or list(BUILTIN_TASKS)
            for task in tasks:
                get_task(task)  # an unknown one is refused before anything runs
            degrees = args.degrees or list(DEGREES)
            pairs = [(t, d) for t in tasks for d in degrees]
            with ProcessPoolExecutor(args.workers) as pool:
                futures = [
                    pool.submit(measure_cell, t, d, args.random, args.seed) for t, d in pairs
                ]
                random_cells = [f.result() for f in futures]
            random, seed = args.random, args.seed
    except ValueError as err:
        print(f"task_tiers: error: {err}", file=sys.stderr)
        return 2
    cells = label_cells(random_cells, baselines, args.rule)
    print(
        f"Tiers per (task, d): {_draw_words(random, seed, args.from_file)}; "
        + args.rule.describe(regret=baselines is not None)
    )
    if baselines is not None:
        budgets = ", ".join(f"d = {d}: {b}" for d, b in baselines["budgets"].items())
        print(
            f"CMA-ES baseline: {baselines['folder']} (size {baselines['size']}, budgets "
            f"{budgets} evaluations); regret median over runs, {baselines['interval']}"
        )
    for cell in cells:
        print(_line(cell))
        if baselines is not None:
            print(_baseline_line(cell, baselines["optimizer"]))
    if any(c["uncertain"] or c["random_uncertain"] or c["regret_uncertain"] for c in cells):
        print(UNCERTAIN_NOTE)
    if baselines is not None:
        absent = [f"{c['task']} d = {c['degree']}" for c in cells if c["baseline"] is None]
        if absent:
            print(
                f"Not run by the protocol, labelled by the random share alone: {', '.join(absent)}"
            )
        print()
        print(markdown_table(cells))
    if args.json:
        record = tiers_record(
            cells,
            random=random,
            seed=seed,
            rule=args.rule,
            baselines=baselines,
            random_from=args.from_file,
        )
        atomic_write_text(args.json, json.dumps(record, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
