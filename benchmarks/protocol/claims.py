"""Claim (a) of the paper, "CMA-ES lowers F fastest", judged under the benchmark protocol.

The reproduction page (``tooldesign reproduce``, :mod:`benchmarks.reports.reproduction`) judges
the claim twice: from the 10 seeds of the ``optimizers`` suite (one goal, d = 3), and here from
a protocol run folder, per dimension and pooled, with the tables its report wrote
(:func:`benchmarks.protocol.report.make_protocol_report`)::

    report/comparisons.csv   per pair of optimizers, per d and pooled ("all"): the paired
                             Wilcoxon signed-rank test over instances, Holm-corrected, the
                             mean difference of score with its 95 % t interval, d_z; the
                             paired difference of final best F (f_diff [f_diff_low,
                             f_diff_high], a - b), the median noise floor of its blocks
                             (floor) and whether the interval clears it (beyond_floor)
    report/ranks.csv         the ranking by mean score, and P(rank k) under resampling
    report/power.csv         per pair, the smallest difference detectable at 80 % power, of
                             score ("score") and of final F ("final F"), and the instances
                             and seeds the observed difference would need
    report/references.csv    per cell, the noise floor of F

**The speed measure** is the protocol's score of a run: the area under the ECDF of its
runtimes to its instance's targets, from the median F of a random design down to the reference
plus its noise floor (0 to 1, higher is sooner). **Told apart**
(:func:`benchmarks.protocol.effects.told_apart`): two optimizers are told apart only when their
comparison of score is significant (Holm p < :data:`PROTOCOL_ALPHA`) AND the 95 % t interval of
their paired final-F difference lies wholly beyond +-the noise floor (the median floor of the
blocks) on one side, the higher score with the lower F: a score gap alone can come from
reaching the same targets a few evaluations apart. **The rule**, per group (a dimension, or all
of them pooled, whose units are the instances, each with its d blocks averaged and its floor
the mean of theirs), with random sampling (:data:`BASELINE`) as the baseline every method is
expected to beat: CMA-ES is *faster* than another optimizer when they are told apart and
CMA-ES's mean score is the higher. The claim **holds** where CMA-ES is faster than every other
non-random optimizer (and slower than none; random sampling counts against it only when told
apart as faster, so the claim can hold while CMA-ES is not told apart from random sampling,
and the group's sentence then says so), **holds in part** where it
is faster than at least one non-random optimizer and slower than none, is **not shown (faster
than random sampling only)** where it is faster than random sampling alone, **does not hold**
where any optimizer (random sampling included) is faster than CMA-ES, is **not shown** where
CMA-ES is told apart from none (the group's verdict sentence then says, per pair, whether that
is a property of the problem or of the run's size), and is **not tested** where the run has no
CMA-ES or no other optimizer. Over the dimensions (the summary table's row): it holds if it
holds at every dimension; does not hold if it does not at one; holds in part if it holds or
holds in part at one; is not shown (faster than random sampling only) if that is the best at
every dimension where anything is shown, naming them; and is not shown otherwise. The pooled
verdict is evidence beside it, not part of it.

**Trust.** The protocol records no checksums of its report's files (the cells' results are
checked against their manifests). So the tables are read through the run folder's gate
(:func:`benchmarks.storage.read_run_file`: regular files inside the folder, no link followed),
checked against the folder's ``protocol.json`` (its optimizers and dimensions), and, unless the
report was just written from the cells (``check=False``), against the report computed again
from the cells and the folder's references into a temporary folder: a table that differs is
refused, naming the file, the row and the column.
"""

from __future__ import annotations

import dataclasses
import io
import math
import os
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from benchmarks.protocol.effects import (
    instance_floors,
    section_floor,
    separation_sentence,
    told_apart,
)
from benchmarks.protocol.suite import ProtocolConfig, read_protocol
from benchmarks.reports.reproduction import (
    PROTOCOL_HEADING,
    ClaimSection,
    protocol_not_tested,
)

__all__ = [
    "BASELINE",
    "CLAIM_OPTIMIZER",
    "CLAIM_TABLES",
    "PROTOCOL_ALPHA",
    "GroupJudgement",
    "check_claim_tables",
    "check_own_report",
    "judge_claim_a",
    "merged_report",
    "protocol_claim",
    "read_claim_tables",
]

#: The family-wise level of the report's comparisons (``make_protocol_report``'s ``alpha``; a
#: test keeps them equal).
PROTOCOL_ALPHA = 0.01

#: The optimizer claim (a) is about.
CLAIM_OPTIMIZER = "cmaes"

#: The baseline: beating it alone does not make CMA-ES the fastest (every method beats it).
BASELINE = "random"

#: The report tables the judgement reads, with the columns it needs of each.
CLAIM_TABLES: dict[str, tuple[str, ...]] = {
    "comparisons.csv": ("a", "b", "n", "mean_diff", "ci_low", "ci_high", "d_z", "p_holm",
                        "significant", "f_diff", "f_diff_low", "f_diff_high", "floor",
                        "beyond_floor", "d"),
    "ranks.csv": ("optimizer", "P(rank 1)", "mean", "rank", "d"),
    "power.csv": ("a", "b", "n", "min_n", "separable", "detectable", "instances_needed",
                  "seeds_needed", "d", "measure"),
    "references.csv": ("d", "instance", "noise floor"),
}  # fmt: skip

#: Verdicts, strongest first (the words the page opens a verdict with).
HOLDS, IN_PART, RANDOM_ONLY, DOES_NOT_HOLD, NOT_SHOWN, NOT_TESTED = (
    "holds",
    "holds in part",
    "not shown (faster than random sampling only)",
    "does not hold",
    "not shown",
    "not tested",
)

_POOLED = "all"
_BOOLEAN = {"True": True, "False": False, "true": True, "false": False}


def _fmt(value: float, digits: int = 4) -> str:
    return "n/a" if value is None or not math.isfinite(value) else f"{value:.{digits}g}"


def _signed(value: float) -> str:
    return ("+" if value > 0 else "") + _fmt(value, 3)


def _group_name(group: str) -> str:
    return "pooled" if group == _POOLED else f"d = {group}"


@dataclasses.dataclass(frozen=True, kw_only=True)
class Versus:
    """CMA-ES against one other optimizer in one group: CMA-ES's score minus the other's.

    ``diff``, ``low`` and ``high`` are the mean difference of score over instances (blocks) and
    its 95 % t interval, signed so that positive is CMA-ES sooner; ``f_diff``, ``f_low`` and
    ``f_high`` the paired difference of final best F, CMA-ES's minus the other's (negative:
    CMA-ES ends lower) and ``floor`` the noise floor it is compared with; ``significant`` is the
    report's (Holm p < alpha), ``beyond_floor`` its F interval clear of +-floor, ``told_apart``
    the two together in the same direction (:func:`benchmarks.protocol.effects.told_apart`);
    ``detectable`` the smallest difference of mean score the run detects at 80 % power (inf
    when it cannot separate any pair) and ``needed`` the instances the observed difference
    would need (NaN where the report gives none).
    """

    other: str
    n: int
    diff: float
    low: float
    high: float
    d_z: float
    p_holm: float
    significant: bool
    f_diff: float
    f_low: float
    f_high: float
    floor: float
    beyond_floor: bool
    told_apart: bool
    detectable: float
    needed: float

    @property
    def outcome(self) -> str:
        """``"faster"`` or ``"slower"`` (CMA-ES, where told apart), or ``"none"``."""
        if not self.told_apart or self.diff == 0:
            return "none"
        return "faster" if self.diff > 0 else "slower"

    def evidence(self) -> str:
        """``"+0.052 [0.021, 0.083], p 0.0012, F -120 [-160, -80] (floor 35) against bo"``."""
        interval = f"[{_fmt(self.low, 3)}, {_fmt(self.high, 3)}]" if self.n >= 2 else "[n/a]"
        return (
            f"{_signed(self.diff)} {interval}, p {_fmt(self.p_holm, 2)}, F {self.f_evidence()} "
            f"against {self.other}"
        )

    def f_evidence(self) -> str:
        """``"-120 [-160, -80] (floor 35)"``: the F difference, CMA-ES minus the other."""
        interval = f"[{_fmt(self.f_low, 3)}, {_fmt(self.f_high, 3)}]" if self.n >= 2 else "[n/a]"
        return f"{_signed(self.f_diff)} {interval} (floor {_fmt(self.floor, 3)})"


@dataclasses.dataclass(frozen=True, kw_only=True)
class GroupJudgement:
    """Claim (a) in one group of the report: a dimension (``"3"``) or pooled (``"all"``).

    Attributes:
        group: The report's ``d`` label.
        instances: Instances compared (pooled too: each with its d blocks averaged).
        min_instances: The fewest with which any pair can pass Holm's first step.
        pairs: Pairs in the Holm family.
        ranking: ``(optimizer, mean score, P(rank 1))`` by rank.
        versus: CMA-ES against each other optimizer.
        told_apart: ``(sooner, later)`` pairs the run tells apart (Holm p < alpha and the
            final-F difference beyond the noise floor).
        not_told_apart: Pairs it does not.
        detectable: The smallest and largest detectable difference of mean score over the
            pairs (inf when it cannot separate any); ``detectable_f`` the same in F, and
            ``noise_floor`` the group's noise floor of F, the one the rule uses: the median
            over instances of their references' floors (pooled, an instance's floor is the
            mean of its d blocks').
        verdict: One of holds, holds in part, not shown (faster than random sampling only),
            does not hold, not shown, not tested.
        text: The verdict in the page's words, with its evidence.
        sentence: The group's verdict over all its pairs, as the report's section gives it
            (:func:`benchmarks.protocol.effects.separation_sentence`): which pairs are told
            apart, and for each other whether that is a property of the problem or of the
            run's size.
    """

    group: str
    instances: int
    min_instances: int
    pairs: int
    ranking: tuple[tuple[str, float, float], ...]
    versus: tuple[Versus, ...]
    told_apart: tuple[tuple[str, str], ...]
    not_told_apart: tuple[tuple[str, str], ...]
    detectable: tuple[float, float]
    detectable_f: tuple[float, float]
    noise_floor: float
    verdict: str
    text: str
    sentence: str = ""

    @property
    def separable(self) -> bool:
        """Whether the run has enough instances in this group for any pair to be told apart."""
        return self.instances >= self.min_instances


def _check_columns(name: str, frame: pd.DataFrame, where: str) -> None:
    missing = [c for c in CLAIM_TABLES[name] if c not in frame.columns]
    if missing:
        raise ValueError(
            f"{where} lacks the columns {missing}: it is not a table of the protocol's report "
            "(tooldesign bench protocol writes it)"
        )


def _booleans(frame: pd.DataFrame, column: str, where: str) -> pd.Series:
    text = frame[column].astype(str)
    bad = ~text.isin(list(_BOOLEAN))
    if bad.any():
        raise ValueError(
            f"{where}: column {column!r} holds {text[bad].iloc[0]!r}; it must be True or False"
        )
    return text.map(_BOOLEAN).astype(bool)


def _parse_table(name: str, data: bytes, where: str) -> pd.DataFrame:
    try:
        frame = pd.read_csv(io.BytesIO(data), dtype={"d": str, "instance": str})
    except (ValueError, UnicodeDecodeError) as err:
        raise ValueError(f"{where} is not a CSV table: {err}") from None
    _check_columns(name, frame, where)
    numeric = [
        c
        for c in CLAIM_TABLES[name]
        if c
        not in (
            "a", "b", "optimizer", "d", "instance", "measure", "significant", "separable",
            "beyond_floor",
        )
    ]  # fmt: skip
    for column in numeric:
        try:
            frame[column] = frame[column].astype(np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"{where}: column {column!r} must hold numbers") from None
    for column in ("significant", "separable", "beyond_floor"):
        if column in CLAIM_TABLES[name]:
            frame[column] = _booleans(frame, column, where)
    return frame


def _read_tables(folder: Path, *, gate: bool) -> dict[str, pd.DataFrame]:
    from benchmarks.storage import read_run_file

    tables = {}
    for name in CLAIM_TABLES:
        relative = f"report/{name}"
        where = str(folder / relative)
        if not os.path.lexists(folder / relative):
            raise FileNotFoundError(
                f"{where} is missing: the protocol run's report is written by `tooldesign bench "
                f"protocol` (run the command that made {folder} again: it resumes and reports) "
                "or by `tooldesign reproduce` without --skip-reports"
            )
        data = read_run_file(folder, relative) if gate else (folder / relative).read_bytes()
        tables[name] = _parse_table(name, data, where)
    return tables


def _merged_message(root: Path, extra: Sequence[str]) -> str:
    return (
        f"{root / 'report'} is the report of this run merged with other run folders' "
        f"({', '.join(extra)}: tooldesign bench protocol --baseline); claim (a) is judged from a "
        "run's own report, which would replace it: point --protocol at the built-ins' run "
        "folder instead"
    )


def merged_report(folder: str | os.PathLike[str]) -> tuple[str, ...]:
    """The optimizers a protocol folder's report ranks beyond the folder's own run.

    ``tooldesign bench protocol --optimizer NAME --baseline DIR`` writes into the user's folder
    a report that merges its run with DIR's; writing that folder's own report again (as
    ``tooldesign reproduce`` does) would replace it. Empty when the report is the run's own,
    absent or unreadable, or does not rank every optimizer of the run (an edit, which writing
    the report again repairs).

    Raises:
        ValueError: ``folder`` is not a protocol run folder.
    """
    from benchmarks.storage import read_run_file

    root = Path(folder)
    own = {o.column for o in read_protocol(root).optimizers}
    relative = "report/ranks.csv"
    if not os.path.lexists(root / relative):
        return ()
    try:
        frame = _parse_table("ranks.csv", read_run_file(root, relative), str(root / relative))
    except (OSError, ValueError):
        return ()
    named = set(frame["optimizer"].astype(str))
    return tuple(sorted(named - own)) if named > own else ()  # else an edit: written again


def check_own_report(folder: str | os.PathLike[str]) -> None:
    """Refuse a folder whose report is merged with other folders' (:func:`merged_report`).

    Raises:
        ValueError: The report ranks optimizers the folder did not run, named in the message.
    """
    extra = merged_report(folder)
    if extra:
        raise ValueError(_merged_message(Path(folder), extra))


def read_claim_tables(
    folder: str | os.PathLike[str],
) -> tuple[ProtocolConfig, dict[str, pd.DataFrame]]:
    """The config of a protocol run folder and the report tables claim (a) is judged from.

    Read through the run folder's gate (regular files inside the folder, no link followed)
    and checked against the config: the tables must name the run's optimizers and dimensions.

    Returns:
        The config, and the tables of :data:`CLAIM_TABLES` by file name (``d`` as str).

    Raises:
        FileNotFoundError: A table is missing (the message names the command that writes it).
        ValueError: The folder is not a protocol run folder, a table is a link or lacks a
            column, or the tables are of another run than ``protocol.json`` records.
    """
    root = Path(folder)
    config = read_protocol(root)
    tables = _read_tables(root, gate=True)
    optimizers = {o.column for o in config.optimizers}
    groups = {str(d) for d in config.degrees} | {_POOLED}
    ranks = tables["ranks.csv"]
    named = set(ranks["optimizer"].astype(str))
    if named > optimizers:
        raise ValueError(_merged_message(root, sorted(named - optimizers)))
    if named != optimizers:
        raise ValueError(
            f"{root / 'report' / 'ranks.csv'} ranks {sorted(named)}, but "
            f"{root / 'protocol.json'} records the optimizers {sorted(optimizers)}: the report is "
            "of another run; write it again with `tooldesign reproduce` (without --skip-reports)"
        )
    for name in ("comparisons.csv", "ranks.csv", "power.csv"):
        found = set(tables[name]["d"].astype(str))
        if not found <= groups:
            raise ValueError(
                f"{root / 'report' / name} has the groups d = {sorted(found - groups)}, which "
                f"{root / 'protocol.json'} does not (its degrees are {list(config.degrees)}): "
                "the report is of another run"
            )
    return config, tables


def _differences(file: pd.DataFrame, fresh: pd.DataFrame) -> str | None:
    """Where two tables differ (row, column and both values), or None if they agree."""
    if list(file.columns) != list(fresh.columns) or len(file) != len(fresh):
        return (
            f"its columns or rows differ ({len(file)} rows of {list(file.columns)}; the cells "
            f"give {len(fresh)} of {list(fresh.columns)})"
        )
    for column in file.columns:
        x, y = file[column].to_numpy(), fresh[column].to_numpy()
        if x.dtype.kind in "fiu" and y.dtype.kind in "fiu":
            x, y = x.astype(np.float64), y.astype(np.float64)
            # Another CPU may round the statistics' last bits differently: not a change.
            same = np.isclose(x, y, rtol=1e-9, atol=1e-12, equal_nan=True) | (x == y)
        else:
            same = np.array([str(a) == str(b) for a, b in zip(x, y, strict=True)])
        if not same.all():
            row = int(np.flatnonzero(~same)[0])
            mine, theirs = (v.item() if isinstance(v, np.generic) else v for v in (x[row], y[row]))
            return (
                f"row {row + 1}, column {column!r}: {mine!r} in the file, {theirs!r} from the cells"
            )
    return None


def check_claim_tables(folder: str | os.PathLike[str], tables: Mapping[str, pd.DataFrame]) -> None:
    """Refuse report tables that are not what the folder's cells and references give.

    The report is computed again (:func:`~benchmarks.protocol.report.make_protocol_report`,
    reading the cells through their manifests' checksums and the references the folder
    records) into a temporary folder, and every table of :data:`CLAIM_TABLES` compared with
    ``tables``, numbers to 1e-9 relative.

    Raises:
        ValueError: A table differs (the message names the file, the row and the column), or
            the cells or references are refused (their own messages).
    """
    from benchmarks.protocol.report import make_protocol_report

    root = Path(folder)
    with tempfile.TemporaryDirectory(prefix="tooldesign-claims-") as tmp:
        out = Path(tmp) / "report"
        make_protocol_report([root], out, alpha=PROTOCOL_ALPHA)
        fresh = _read_tables(Path(tmp), gate=False)
    for name in CLAIM_TABLES:
        where = _differences(tables[name], fresh[name])
        if where is not None:
            raise ValueError(
                f"{root / 'report' / name} is not what the run's cells and references give "
                f"({where}): it was edited, written by other code or against other references "
                "than the folder records; write the report again with `tooldesign reproduce` "
                "(without --skip-reports)"
            )


def _versus(
    comparisons: pd.DataFrame, power: pd.DataFrame, optimizer: str, other: str
) -> Versus | None:
    first, second = sorted((optimizer, other))
    row = comparisons[(comparisons["a"] == first) & (comparisons["b"] == second)]
    if row.empty:
        return None
    r = row.iloc[0]
    sign = 1.0 if first == optimizer else -1.0
    low, high = sign * float(r["ci_low"]), sign * float(r["ci_high"])
    f_low, f_high = sign * float(r["f_diff_low"]), sign * float(r["f_diff_high"])
    pw = power[(power["a"] == first) & (power["b"] == second)]
    return Versus(
        other=other,
        n=int(r["n"]),
        diff=sign * float(r["mean_diff"]),
        low=min(low, high),
        high=max(low, high),
        d_z=sign * float(r["d_z"]),
        p_holm=float(r["p_holm"]),
        significant=bool(r["significant"]),
        f_diff=sign * float(r["f_diff"]),
        f_low=min(f_low, f_high),
        f_high=max(f_low, f_high),
        floor=float(r["floor"]),
        beyond_floor=bool(r["beyond_floor"]),
        told_apart=bool(told_apart(row).iloc[0]),
        detectable=float(pw["detectable"].iloc[0]) if len(pw) else math.inf,
        needed=float(pw["instances_needed"].iloc[0]) if len(pw) else math.nan,
    )


def _span(values: pd.Series) -> tuple[float, float]:
    finite = values[np.isfinite(values.to_numpy(dtype=np.float64))]
    if finite.empty:
        return (math.inf, math.inf) if len(values) else (math.nan, math.nan)
    return float(finite.min()), float(finite.max())


@dataclasses.dataclass(frozen=True)
class _Counts:
    """What the verdict of a group needs besides the comparisons."""

    instances: int
    min_instances: int
    pairs: int
    best: str


def _verdict(group: str, versus: Sequence[Versus], judged: _Counts) -> tuple[str, str]:
    """The verdict of one group and its sentence (the module doc's rule).

    Random sampling (:data:`BASELINE`) is the baseline: beating it shows CMA-ES faster than
    random sampling, not the fastest optimizer.
    """
    faster = [v for v in versus if v.outcome == "faster"]
    slower = [v for v in versus if v.outcome == "slower"]
    rest = [v.other for v in versus if v.outcome == "none"]
    rivals = [v for v in versus if v.other != BASELINE]
    beaten = [v for v in faster if v.other != BASELINE]
    baseline = [v for v in faster if v.other == BASELINE]
    if baseline:
        also = f"; faster than random sampling too ({baseline[0].evidence()})"
    elif any(v.other == BASELINE for v in versus):
        also = "; not told apart from random sampling either"
    else:
        also = ""
    if slower:
        text = (
            f"**{DOES_NOT_HOLD}**: {', '.join(v.other for v in slower)} "
            f"{'reaches' if len(slower) == 1 else 'reach'} the targets significantly sooner "
            "and ends lower, beyond the noise floor (CMA-ES minus the other: "
            f"{'; '.join(v.evidence() for v in slower)})"
        )
        if faster:
            text += f"; CMA-ES is sooner than {', '.join(v.other for v in faster)}"
        return DOES_NOT_HOLD, text
    untold = [v.other for v in rivals if v.outcome == "none"]
    if rivals and not untold:
        return HOLDS, (
            f"**{HOLDS}**: CMA-ES is told apart as faster than every other non-random optimizer "
            f"({'; '.join(v.evidence() for v in beaten)}){also}"
        )
    if beaten:
        return IN_PART, (
            f"**{IN_PART}**: CMA-ES is told apart as faster than "
            f"{', '.join(v.other for v in beaten)} ({'; '.join(v.evidence() for v in beaten)}), "
            f"not from {', '.join(untold)}{also}"
        )
    if baseline:
        return RANDOM_ONLY, (
            f"**{NOT_SHOWN}** (faster than random sampling only): CMA-ES is told apart as "
            f"faster than random sampling ({baseline[0].evidence()}), the baseline every method "
            f"is expected to beat, and from none of {', '.join(untold) or 'the others'}"
        )
    if judged.instances < judged.min_instances:
        unit = "instances (d blocks averaged)" if group == _POOLED else "instances"
        return NOT_SHOWN, (
            f"**{NOT_SHOWN}**: with {judged.instances} {unit} no pair can be told apart (the "
            f"exact signed-rank test needs at least {judged.min_instances} at Holm alpha "
            f"{PROTOCOL_ALPHA:g} over {judged.pairs} pair(s))"
        )
    return NOT_SHOWN, (
        f"**{NOT_SHOWN}**: CMA-ES is not told apart from {', '.join(rest)} (highest mean ECDF "
        f"area: {judged.best})"
    )


def judge_claim_a(
    tables: Mapping[str, pd.DataFrame],
    groups: Sequence[str],
    *,
    optimizer: str = CLAIM_OPTIMIZER,
) -> list[GroupJudgement]:
    """Claim (a) in each group of a protocol report (the module doc's rule).

    Args:
        tables: The report's tables of :data:`CLAIM_TABLES` by file name, as
            :func:`read_claim_tables` returns them (``d`` as str, ``significant`` and
            ``separable`` as bool).
        groups: The report's ``d`` labels to judge, in order (``["3", "5", "8", "all"]``).
        optimizer: The optimizer the claim is about.

    Returns:
        One judgement per group; ``not tested`` where the group ranks fewer than two
        optimizers or not ``optimizer``.

    Raises:
        ValueError: A table lacks a column, or ``groups`` is empty.
    """
    for name in CLAIM_TABLES:
        _check_columns(name, tables[name], name)
    if not groups:
        raise ValueError("groups must name at least one group of the report (a d, or 'all')")
    comparisons_all, ranks_all = tables["comparisons.csv"], tables["ranks.csv"]
    power_all, references = tables["power.csv"], tables["references.csv"]
    if "task" in references.columns and len(references):
        # comparisons.csv, ranks.csv and power.csv are the first task's sections (push's when
        # it runs); references.csv lists every task's cells, in the run's task order. The floor
        # is over the first task's instances alone, as its report sections' floors are.
        references = references[references["task"] == references["task"].iloc[0]]
    out = []
    for group in groups:
        ranks = ranks_all[ranks_all["d"].astype(str) == group].sort_values("rank", kind="stable")
        comparisons = comparisons_all[comparisons_all["d"].astype(str) == group]
        power = power_all[power_all["d"].astype(str) == group]
        score_power = power[power["measure"] == "score"]
        f_power = power[power["measure"] == "final F"]
        ranking = tuple(
            (str(r["optimizer"]), float(r["mean"]), float(r["P(rank 1)"]))
            for _, r in ranks.iterrows()
        )
        # The group's one floor, as its report section's: pooled, the median of the instances'
        # floors, each the mean of its d blocks' (the floor the told-apart rule uses).
        at = references if group == _POOLED else references[references["d"].astype(str) == group]
        group_floor = section_floor(instance_floors(at)) if len(at) else math.nan
        instances = int(comparisons["n"].max()) if len(comparisons) else 0
        min_n = int(score_power["min_n"].max()) if len(score_power) else 0
        told: list[tuple[str, str]] = []
        untold: list[tuple[str, str]] = []
        rule = told_apart(comparisons)
        for k, r in comparisons.iterrows():
            a, b = str(r["a"]), str(r["b"])
            if bool(rule.loc[k]):
                told.append((a, b) if float(r["mean_diff"]) > 0 else (b, a))
            else:
                untold.append((a, b))
        unit = "instances (d blocks averaged)" if group == _POOLED else "instances"
        sentence = separation_sentence(
            comparisons, f_power, group=_group_name(group), alpha=PROTOCOL_ALPHA, unit=unit
        )
        names = [name for name, _, _ in ranking]
        others = [name for name in names if name != optimizer]
        versus = [v for o in others if (v := _versus(comparisons, score_power, optimizer, o))]
        parts = _Counts(
            instances=instances,
            min_instances=min_n,
            pairs=len(comparisons),
            best=names[0] if names else "n/a",
        )
        if optimizer not in names:
            verdict, text = NOT_TESTED, f"**{NOT_TESTED}**: the run has no {optimizer}"
        elif not others or not versus:
            verdict = NOT_TESTED
            text = (
                f"**{NOT_TESTED}**: the report compares {optimizer} with no other optimizer "
                "here (fewer than two optimizers or instances)"
            )
        else:
            verdict, text = _verdict(group, versus, parts)
        out.append(
            GroupJudgement(
                group=group,
                instances=instances,
                min_instances=min_n,
                pairs=len(comparisons),
                ranking=ranking,
                versus=tuple(versus),
                told_apart=tuple(told),
                not_told_apart=tuple(untold),
                detectable=_span(score_power["detectable"]),
                detectable_f=_span(f_power["detectable"]),
                noise_floor=group_floor,
                verdict=verdict,
                text=text,
                sentence=sentence,
            )
        )
    return out


def _overall(judged: Sequence[GroupJudgement]) -> str:
    """The summary row's verdict over the dimensions (the pooled group is evidence beside it).

    Holds if it holds at every dimension; does not hold if it does not at one; holds in part
    if it holds or holds in part at one; not shown (faster than random sampling only) if that
    is the most any dimension shows, naming where; not shown otherwise.
    """
    per_d = [j for j in judged if j.group != _POOLED]
    verdicts = [j.verdict for j in per_d]

    def at(verdict: str) -> str:
        return ", ".join(j.group for j in per_d if j.verdict == verdict)

    if not per_d or all(v == NOT_TESTED for v in verdicts):
        head = f"**{NOT_TESTED}**"
    elif all(v == HOLDS for v in verdicts):
        head = f"**{HOLDS}** at every dimension"
    elif DOES_NOT_HOLD in verdicts:
        head = f"**{DOES_NOT_HOLD}** at d = {at(DOES_NOT_HOLD)}"
    elif HOLDS in verdicts or IN_PART in verdicts:
        head = f"**{IN_PART}**"
    elif RANDOM_ONLY in verdicts:
        head = f"**{NOT_SHOWN}** (faster than random sampling only, at d = {at(RANDOM_ONLY)})"
    else:
        head = f"**{NOT_SHOWN}** at any dimension"
    detail = "; ".join(f"{_group_name(j.group)}: {j.verdict}" for j in judged)
    return f"{head} ({detail})"


def _range(span: tuple[float, float], digits: int = 3) -> str:
    low, high = span
    if math.isnan(low):
        return "n/a"
    if math.isinf(low):
        return "none (inf)"
    return _fmt(low, digits) if low == high else f"{_fmt(low, digits)} to {_fmt(high, digits)}"


def _pair(pair: tuple[str, str], sooner: bool) -> str:
    return f"{pair[0]} > {pair[1]}" if sooner else f"{pair[0]} ~ {pair[1]}"


def _where(folder: Path, results: Path | None) -> str:
    """The folder as the page names it: ``docs/results/NAME`` under the results, else as given."""
    if results is not None and folder.parent.resolve() == results.resolve():
        return f"docs/results/{folder.name}"
    text = str(folder)
    return text if text.isprintable() else repr(text)


def _section(
    config: ProtocolConfig, judged: Sequence[GroupJudgement], where: str
) -> tuple[str, ...]:
    from benchmarks.protocol.instances import select_instances

    budgets = ", ".join(str(config.budget(d)) for d in config.degrees)
    chosen = select_instances(config.instance_set(), config.instances)
    public = sum(1 for i in chosen if i.set == "public")
    held = len(chosen) - public
    names = ", ".join(o.column for o in config.optimizers)
    pairs = max((j.pairs for j in judged), default=0)
    lines = [
        PROTOCOL_HEADING,
        "",
        f"The claim again, from the benchmark protocol's run in `{where}/` (size "
        f"`{config.size}`: {len(config.instances)} instances ({public} public, {held} held out) "
        f"x d = {', '.join(map(str, config.degrees))}; {config.n_seeds} seed(s) per optimizer "
        f"and instance, budgets {budgets} evaluations; {names}; its report "
        f"`{where}/report/report.md`, with `comparisons.csv`, `ranks.csv` and `power.csv`; "
        "[The benchmark protocol](protocol.md)). The 10-seed judgement above, on the "
        "`optimizers` suite's one goal at d = 3, stays beside it.",
        "",
        "**How it is judged.** The speed measure is the protocol's score of a run, its *ECDF "
        "area*: the area under the ECDF of its runtimes to its instance's targets, from the "
        "median F of a random design down to the reference plus its noise floor (0 to 1, higher"
        " is sooner; not the 10-seed table's AUC, the area under the best-so-far F curve, where"
        " lower is better). An optimizer's score on an instance is the mean over its seeds, and "
        "so is its final best F. Two optimizers are **told apart** only when both hold: the "
        "Wilcoxon signed-rank test of their score differences paired by instance (pooled: each "
        f"instance's d blocks averaged), Holm-corrected over the report's {pairs} pair(s), "
        f"gives p < {PROTOCOL_ALPHA:g}; and the 95 % t interval of their paired final-F "
        "difference lies "
        "wholly beyond +-the noise floor (the median over instances of their references' "
        "floors; pooled, an instance's floor is the mean of its d blocks') on one "
        "side, the higher score with the lower F. A significant score gap alone is not enough: "
        "two optimizers can reach the same targets a few evaluations apart and end with designs "
        "that differ by less than the measurement's noise. Random sampling is the baseline "
        "every method is expected to beat. At a dimension the claim **holds** where CMA-ES is "
        "told apart as faster than every other non-random optimizer (and slower than none), "
        "**holds in part** where it is faster than at least one non-random optimizer and slower "
        "than none, is **not shown (faster than random sampling only)** where it beats random "
        "sampling alone, **does not hold** where any optimizer is told apart as faster than "
        "CMA-ES, and is **not shown** where CMA-ES is told apart from none. Random sampling "
        "counts against CMA-ES only when told apart as faster: the claim can hold where CMA-ES "
        "is not told apart from random sampling (the group's sentence below then says so). The "
        "summary row: "
        "holds if it holds at every dimension, does not hold if it does not at one, holds in "
        "part if it holds or holds in part at one, not shown (faster than random sampling only)"
        " if that is the most a dimension shows, not shown otherwise; the pooled verdict is "
        "given beside it.",
        "",
        "| d | instances | ranking by mean ECDF area (P(rank 1)) | verdict |",
        "|---|---|---|---|",
    ]
    for j in judged:
        ranking = ", ".join(f"{o} {_fmt(m, 3)} ({_fmt(p, 2)})" for o, m, p in j.ranking)
        unit = " (d blocks averaged)" if j.group == _POOLED else ""
        lines.append(f"| {j.group} | {j.instances}{unit} | {ranking or 'n/a'} | {j.text} |")
    lines += [
        "",
        "The verdict per group, over all its pairs, as the report's statistics sections give "
        "it: which pairs are told apart, and for each other pair whether its final-F "
        "difference lies within +-the noise floor (a property of the problem) or the run is "
        "too small to resolve it (a property of the run's size, with the F-unit power):",
        "",
        *(f"- {j.sentence}" for j in judged if j.sentence),
        "",
        "CMA-ES minus each other optimizer: the mean difference of ECDF area over instances "
        "(pooled: instances, d blocks averaged) with its 95 % t interval, positive where "
        "CMA-ES is sooner; d_z = mean / SD of the differences; p Holm-corrected; the paired "
        "difference of final best F with its 95 % t interval, negative where CMA-ES ends "
        "lower, and the noise floor it must clear; the smallest score difference the run "
        "detects at 80 % power, and the instances the observed difference would need "
        "(`comparisons.csv`, `power.csv`):",
        "",
        "| d | CMA-ES vs | difference [95 % CI] | d_z | p (Holm) | F difference [95 % CI] "
        "(floor) | beyond floor | told apart | detectable | instances needed |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for j in judged:
        for v in j.versus:
            interval = f"[{_fmt(v.low, 3)}, {_fmt(v.high, 3)}]" if v.n >= 2 else "[n/a]"
            outcome = {"faster": "yes, CMA-ES sooner", "slower": "yes, CMA-ES later"}
            detectable = "inf" if math.isinf(v.detectable) else _fmt(v.detectable, 3)
            needed = "inf" if math.isinf(v.needed) else _fmt(v.needed, 4)  # NaN: n/a
            lines.append(
                f"| {j.group} | {v.other} | {_signed(v.diff)} {interval} | {_fmt(v.d_z, 3)} | "
                f"{_fmt(v.p_holm, 3)} | {v.f_evidence()} | {'yes' if v.beyond_floor else 'no'} | "
                f"{outcome.get(v.outcome, 'no')} | {detectable} | {needed} |"
            )
    lines += [
        "",
        "Which optimizers the run tells apart (`a > b`: a reaches the targets significantly "
        "sooner and ends lower beyond the noise floor) and which it does not (`a ~ b`), among "
        "all its pairs:",
        "",
        "| d | told apart | not told apart |",
        "|---|---|---|",
    ]
    for j in judged:
        told = ", ".join(_pair(p, True) for p in j.told_apart) or "none"
        untold = ", ".join(_pair(p, False) for p in j.not_told_apart) or "none"
        lines.append(f"| {j.group} | {told} | {untold} |")
    lines += [
        "",
        "Power (`power.csv`): the smallest difference of mean ECDF area each pair's test detects "
        "with 80 % power at Holm's first-step level, over the pairs; the same in F (each run's "
        "final best F), beside the group's noise floor (the rule's). `inf`: fewer "
        "instances than the test needs for any pair to be significant, whatever the "
        "difference; more instances help there, more seeds do not.",
        "",
        "| d | instances (fewest for any pair) | detectable ECDF-area difference | detectable F "
        "difference | noise floor of F |",
        "|---|---|---|---|---|",
    ]
    for j in judged:
        lines.append(
            f"| {j.group} | {j.instances} ({j.min_instances}) | {_range(j.detectable)} | "
            f"{_range(j.detectable_f, 4)} | {_fmt(j.noise_floor)} |"
        )
    return tuple(lines)


def protocol_claim(
    folder: str | os.PathLike[str],
    *,
    results: str | os.PathLike[str] | None = None,
    check: bool = True,
    optimizer: str = CLAIM_OPTIMIZER,
) -> ClaimSection:
    """Claim (a) judged under the protocol run in ``folder``: the page's row and section.

    Args:
        folder: A protocol run folder with its report (``tooldesign bench protocol`` writes
            it; ``make_protocol_report`` writes it again).
        results: The page's results folder: a protocol folder inside it is named
            ``docs/results/NAME`` on the page, as the suites are; else as given.
        check: Check the tables against the report computed again from the cells
            (:func:`check_claim_tables`); ``False`` only right after the report was written
            from them.
        optimizer: The optimizer the claim is about.

    Raises:
        FileNotFoundError: ``folder`` is not a folder, or its report lacks a table.
        ValueError: Not a protocol run folder, a table refused (a link, a missing column,
            another run's, not what the cells give), or cells refused by their checksums.
    """
    root = Path(folder)
    if not root.is_dir():
        raise FileNotFoundError(
            f"{_where(root, None)} is not a folder: give a protocol run folder (tooldesign bench "
            "protocol --out DIR makes one)"
        )
    config, tables = read_claim_tables(root)
    if check:
        check_claim_tables(root, tables)
    groups = [str(d) for d in config.degrees] + [_POOLED]
    judged = judge_claim_a(tables, groups, optimizer=optimizer)
    where = _where(root, Path(results) if results is not None else None)
    if all(j.verdict == NOT_TESTED for j in judged):
        reason = judged[0].text.removeprefix(f"**{NOT_TESTED}**: ") if judged else "no groups"
        untested = protocol_not_tested(f"{reason} (the protocol run in `{where}`)")
        return dataclasses.replace(untested, cell=f"protocol run `{where}`: {reason}")
    best = "; ".join(f"{_group_name(j.group)} {j.ranking[0][0]}" for j in judged if j.ranking)
    faster = "; ".join(
        f"{_group_name(j.group)} "
        + (", ".join(v.other for v in j.versus if v.outcome == "faster") or "none")
        for j in judged
    )
    cell = (
        f"{len(config.instances)} instances x d = {', '.join(map(str, config.degrees))}; "
        f"{config.n_seeds} seed(s); highest mean ECDF area: {best}; CMA-ES told apart as faster "
        f"than: {faster}"
    )
    command = f"tooldesign bench protocol --size {config.size} --with-references --out {where}"
    return ClaimSection(
        cell=cell,
        verdict=_overall(judged),
        lines=_section(config, judged, where),
        made_by=(command,),
    )
