"""The results blocks of ``docs/rl.md``, written from the committed run folders alone.

``docs/rl.md`` quotes the numbers of two long runs, committed as run folders:

* ``docs/results/rl/``: ``tooldesign bench rl --size full``, the rl suite at today's defaults
  (the round section and the merged hand); the block between ``<!-- rl-suite:start -->`` and
  ``<!-- rl-suite:end -->``;
* ``docs/results/breakeven/``: ``tooldesign rl breakeven --size full``, the break-even study;
  the block between ``<!-- breakeven:start -->`` and ``<!-- breakeven:end -->``;

and the page's "What is not done" list says which of them is still missing (the block between
``<!-- rl-not-done:start -->`` and ``<!-- rl-not-done:end -->``).

Each block is rendered from the folder's ``report/`` (``summary.json`` and the CSV tables that
:func:`benchmarks.reports.rl.make_rl_report` and
:func:`benchmarks.reports.breakeven.make_breakeven_report` write); a folder without its report
gets one rebuilt into a temporary folder from its stored evaluations (nothing is simulated; the
folder is removed once the block is written). A folder that does not exist gets a short
paragraph saying that its run is not committed yet, with no number; a folder that exists must
be the run the page quotes, a ``full`` run at today's tool section and hand as its manifest
records them (:func:`committed`), or the command stops with one line naming it and what
differs. The verdict's words, its table and the description of its test are
:mod:`benchmarks.reports.breakeven`'s, the ones ``breakeven.md`` prints. Every sentence that
judges (which budgets warm beats cold at, how often a zero-shot design is better than CMA-ES)
is worded from the numbers, never written by hand.
``tests/test_rl_page.py`` checks that the committed page holds what the committed folders
render to.

Run: ``python -m benchmarks.cli.rl_page [--root DIR] [--check]``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, cast

from benchmarks.reports import markdown
from benchmarks.reports.markdown import markdown_table

__all__ = [
    "BLOCKS",
    "PAGE",
    "committed",
    "current_block",
    "main",
    "markers",
    "parse_args",
    "render_blocks",
    "render_breakeven_block",
    "render_not_done_block",
    "render_page",
    "render_suite_block",
    "replace_block",
    "round_section_floors",
]

#: The page, relative to the repository.
PAGE = Path("docs") / "rl.md"
#: The committed run folders, relative to the repository.
SUITE_FOLDER = Path("docs") / "results" / "rl"
BREAKEVEN_FOLDER = Path("docs") / "results" / "breakeven"
#: The names of the page's generated blocks, in the order they appear.
BLOCKS: tuple[str, ...] = ("rl-suite", "breakeven", "rl-not-done")

#: ``manifest.json`` ``extra.kind`` of the two folders (``benchmarks.rl.suite.RL_SUITE_KIND``
#: and ``benchmarks.rl.breakeven.BREAKEVEN_KIND``, spelled out so that a pending page needs no
#: import of the simulation; a test checks that they agree).
SUITE_KIND = "rl-suite"
BREAKEVEN_KIND = "rl-breakeven"
#: The size of a committed run (the page's results are the `full` runs').
COMMITTED_SIZE = "full"
#: What a run folder's config without the fields means (``benchmarks.rl.suite.ADDED_FIELDS``,
#: spelled out like the kinds; a test checks that they agree).
ADDED_FIELDS: dict[str, Any] = {"section_shape": "square", "merge_fixed_links": False}

_LABELS = {
    "random": "random sampling",
    "cmaes": "CMA-ES",
    "ppo": "PPO",
    "sac": "SAC",
    "contextual": "contextual",
    "straight": "straight tool",
}
_POLICIES = ("contextual", "ppo", "sac")
_ORDER = ("random", "cmaes", "ppo", "sac", "contextual", "straight")


# --- blocks ---------------------------------------------------------------------------------


def markers(name: str) -> tuple[str, str]:
    """The start and end markers of block ``name``.

    Raises:
        ValueError: ``name`` is not one of :data:`BLOCKS`.
    """
    if name not in BLOCKS:
        raise ValueError(f"unknown block {name!r}; choose from {', '.join(BLOCKS)}")
    return markdown.block_markers(name)


def current_block(text: str, name: str) -> str:
    """The text between block ``name``'s markers (exclusive, without the newline after start).

    Raises:
        ValueError: ``name`` is not a block of the page, or its markers are missing, repeated
            or out of order.
    """
    markers(name)
    return markdown.current_block(text, name)


def replace_block(text: str, name: str, block: str) -> str:
    """``text`` with the part between block ``name``'s markers replaced by ``block``.

    Raises:
        ValueError: ``name`` is not a block of the page, or its markers are missing, repeated
            or out of order.
    """
    markers(name)
    return markdown.replace_block(text, name, block)


# --- reading the folders --------------------------------------------------------------------


def _manifest(folder: Path, kind: str, what: str) -> dict[str, Any]:
    """The folder's manifest, if it is a run folder of ``kind``; else a one-line ValueError."""
    if not folder.is_dir():
        raise ValueError(f"{folder} is not a folder: expected {what}")
    path = folder / "manifest.json"
    if not path.is_file():
        raise ValueError(f"{folder} is not {what}: it has no manifest.json")
    manifest = _read_json(path)
    extra = manifest.get("extra")
    found = extra.get("kind") if isinstance(extra, dict) else None
    if found != kind or not isinstance(manifest.get("config"), dict):
        raise ValueError(f"{folder} is not {what} (manifest kind {found!r}, expected {kind!r})")
    return manifest


@contextmanager
def _tables(
    folder: Path, names: Sequence[str], rebuild: Callable[[Path, Path], object]
) -> Iterator[Path]:
    """The folder's report folder, or one rebuilt into a temporary folder if a table is missing.

    The temporary folder is removed when the block is rendered.
    """
    report = folder / "report"
    if all((report / name).is_file() for name in names):
        yield report
        return
    with tempfile.TemporaryDirectory(prefix="rl-page-report-") as out:
        rebuild(folder, Path(out))
        yield Path(out)


def _read_json(path: Path) -> dict[str, Any]:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ValueError(f"{path} is not UTF-8 JSON ({err})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path} does not hold a JSON object")
    return cast("dict[str, Any]", data)


def _need(data: Mapping[str, Any], key: str, source: Path) -> Any:
    if key not in data:
        raise ValueError(f"{source} has no {key!r}: a report of another version? rebuild it")
    return data[key]


def _absolute(path: Path) -> Path:
    """The absolute path, links kept (a link to a folder is named where it is, not its target)."""
    return Path(os.path.abspath(path))


def _link(folder: Path, page: Path) -> str:
    """The folder relative to the page's folder, as a Markdown link target."""
    return Path(os.path.relpath(_absolute(folder), _absolute(page).parent)).as_posix()


def _shown(folder: Path, root: Path) -> str:
    """The folder as the page names it: relative to the repository where it lies inside."""
    try:
        return _absolute(folder).relative_to(_absolute(root)).as_posix()
    except ValueError:
        return folder.as_posix()


def _percent(fraction: float, digits: int = 1) -> str:
    """A fraction as prose writes it: ``0.015`` -> ``"1.5 %"``."""
    return f"{fraction * 100:.{digits}f} %"


def _report_words(folder: Path, page: Path, shown: str, name: str, tables: Path) -> str:
    """Where the block's numbers come from, and a link to the report's page if it is there."""
    report = folder / "report"
    if _absolute(tables) != _absolute(report):
        where = "from its report rebuilt from its stored evaluations"
        if not (report / name).is_file():
            return (
                f"It has no `report/`; the numbers below are {where} "
                f"(`tooldesign report {shown}` writes it)."
            )
    else:
        where = "from its `report/`"
    return (
        f"Its page is [`report/{name}`]({_link(folder, page)}/report/{name}); `tooldesign report "
        f"{shown}` rebuilds it from the stored files. The numbers below are read {where}."
    )


def _figure(folder: Path, page: Path, name: str, alt: str) -> list[str]:
    """A figure of the folder's report, if the folder holds it (a link must not dangle)."""
    if not (folder / "report" / name).is_file():
        return []
    return [f"![{alt}]({_link(folder, page)}/report/{name})", ""]


def _setting(config: Mapping[str, Any]) -> tuple[str, bool]:
    """The tool's section and whether the hand is merged, as a run recorded them.

    Folders from before the fields read as the old defaults, as the suite reads them
    (``benchmarks.rl.suite.ADDED_FIELDS``: a test checks that they agree).
    """
    section = config.get("section_shape", ADDED_FIELDS["section_shape"])
    merged = config.get("merge_fixed_links", ADDED_FIELDS["merge_fixed_links"])
    return str(section), bool(merged)


def _setting_words(config: Mapping[str, Any]) -> str:
    """The tool's section and the arm a run recorded (folders from before the fields: old)."""
    section, merged = _setting(config)
    arm = "the merged hand" if merged else "the 13-link arm"
    return f"the {section} section and {arm}"


def _duration(seconds: float) -> str:
    if seconds < 60:
        return f"{seconds:.0f} s"
    minutes = round(seconds / 60)
    return f"{minutes // 60} h {minutes % 60:02d} min" if minutes >= 60 else f"{minutes} min"


def _provenance(manifest: Mapping[str, Any]) -> str:
    commit = str(manifest.get("git_commit") or "unknown")[:7]
    dirty = " (with uncommitted changes)" if manifest.get("git_dirty") else ""
    wall = manifest.get("wall_time")
    sessions = manifest.get("extra", {}).get("sessions") or []
    took = ""
    if isinstance(wall, (int, float)) and math.isfinite(wall):
        took = f", {_duration(float(wall))} of wall time"
        if len(sessions) > 1:
            took += f" in {len(sessions)} sessions"
    return f"commit {commit}{dirty}{took}"


def _finite(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _counted(items: Sequence[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    if len(items) <= 1:
        return "".join(items)
    return f"{', '.join(items[:-1])} and {items[-1]}"


# --- the rl suite ---------------------------------------------------------------------------


def _pending_suite(shown: str) -> str:
    return (
        "**Pending:** the rerun of the rl suite at today's defaults (the round section and the "
        "merged hand; `tooldesign bench rl --size full`) is not committed yet (its folder: "
        f"`{shown}/`). This section has no numbers until it is; the square section's results "
        "are below.\n"
    )


def _rebuild_suite(folder: Path, out: Path) -> None:
    from benchmarks.reports.rl import make_rl_report

    make_rl_report(folder, out_dir=out)


def _method_key(method: str) -> tuple[int, str]:
    return (_ORDER.index(method) if method in _ORDER else len(_ORDER), method)


def _fixed_lines(fixed: Mapping[str, Any], floor: float, folder: Path, page: Path) -> list[str]:
    records = [r for r in fixed["best_so_far"]]
    methods = sorted({str(r["method"]) for r in records}, key=_method_key)
    episodes = sorted({int(r["episodes"]) for r in records})
    at = {(str(r["method"]), int(r["episodes"])): r for r in records}
    seeds = max(int(r["seeds"]) for r in records)
    goal = ", ".join(f"{v:g}" for v in fixed["goal"])
    lines = [
        f"**Fixed goal** ({goal}): best F so far, median over {seeds} seed(s) (min-max), and the "
        "relative difference to random sampling's median at the same number of episodes (bold: "
        f'better by more than the noise floor, {_percent(floor)}; "noise": within it):',
        "",
    ]
    body = []
    for n in episodes:
        cells: list[str] = [str(n)]
        for method in methods:
            r = at.get((method, n))
            if r is None:
                cells.append("")
                continue
            cell = f"{r['median_best_F']:.0f}"
            if int(r["seeds"]) > 1:
                cell += f" ({r['min_best_F']:.0f}-{r['max_best_F']:.0f})"
            if r.get("verdict") and _finite(r.get("relative_to_random")):
                change = f"{r['relative_to_random']:+.1%}"
                if r["verdict"] == "better":
                    cell += f": **{change}**"
                elif r["verdict"] == "within the noise floor":
                    cell += f": {change}, noise"
                else:
                    cell += f": {change}"
            cells.append(cell)
        body.append(cells)
    lines += markdown_table(["episodes", *(_LABELS.get(m, m) for m in methods)], body)
    tested = [r for r in records if _finite(r.get("p_holm"))]
    if tested:
        others = [m for m in methods if any(str(r["method"]) == m for r in tested)]
        lines += [
            "",
            "Over seeds, against random sampling's at the same number of episodes (A12 below "
            "0.5: the method tends to end lower; two-sided Mann-Whitney U, Holm-corrected over "
            "the methods; bold: significant at 0.05):",
            "",
        ]
        rows = []
        for n in sorted({int(r["episodes"]) for r in tested}):
            cells = [str(n)]
            for method in others:
                r = at.get((method, n))
                if r is None or not _finite(r.get("p_holm")):
                    cells.append("")
                    continue
                text = f"A12 {r['a12']:.2f}, p {r['p_holm']:.3g}"
                cells.append(f"**{text}**" if r.get("significant") else text)
            rows.append(cells)
        lines += markdown_table(["episodes", *(_LABELS.get(m, m) for m in others)], rows)
    last = episodes[-1]
    words = []
    for method in methods:
        r = at.get((method, last))
        if r is None or method == "random" or not r.get("verdict"):
            continue
        verdict = {
            "better": "better than random sampling beyond the noise floor",
            "worse": "worse than random sampling beyond the noise floor",
        }.get(str(r["verdict"]), "within the noise floor of random sampling")
        text = f"{_LABELS.get(method, method)} {r['relative_to_random']:+.1%} ({verdict}"
        if _finite(r.get("p_holm")):
            significant = "significant" if r.get("significant") else "not significant"
            text += f"; over seeds {significant}, Holm p {r['p_holm']:.3g}"
        words.append(text + ")")
    if words:
        lines += [
            "",
            f"After {last} episodes, against random sampling's median: {'; '.join(words)}.",
        ]
    finals = fixed.get("final_policy_F") or {}
    if finals:
        parts = []
        for method in sorted(finals, key=_method_key):
            values = [float(v) for v in finals[method]]
            if method == "straight":
                parts.append(f"the straight tool {values[0]:.0f}")
            elif len(values) > 1:
                parts.append(
                    f"{_LABELS.get(method, method)}'s final deterministic policy median "
                    f"{_median(values):.0f} ({min(values):.0f}-{max(values):.0f}, "
                    f"{len(values)} seeds)"
                )
            else:
                parts.append(
                    f"{_LABELS.get(method, method)}'s final deterministic policy {values[0]:.0f}"
                )
        lines += ["", f"F at the fixed goal: {'; '.join(parts)}."]
    lines.append("")
    lines += _figure(folder, page, "fixed-goal.png", "Best F so far at the fixed goal")
    return lines


def _median(values: Sequence[float]) -> float:
    ordered = sorted(values)
    mid = len(ordered) // 2
    return ordered[mid] if len(ordered) % 2 else (ordered[mid - 1] + ordered[mid]) / 2


def _approach_label(approach: str) -> str:
    method, _, budget = approach.partition("@")
    label = _LABELS.get(method, method) + (f"@{budget}" if budget else "")
    return label + (" (zero-shot)" if method in _POLICIES else "")


def _counts(text: Any) -> tuple[int, int, int] | None:
    """``"better/within/worse"`` counts, or None for an empty cell."""
    if not isinstance(text, str) or text.count("/") != 2:
        return None
    better, within, worse = (int(v) for v in text.split("/"))
    return better, within, worse


def _success(r: Mapping[str, Any]) -> str:
    from benchmarks.reports.success import SuccessRate, success_cell

    n = int(r["success_tasks"])
    return success_cell(
        SuccessRate(
            successes=int(r["successes"]),
            n=n,
            unknown=int(r["tasks"]) - n,
            rate=float(r["success_rate"]) if _finite(r.get("success_rate")) else math.nan,
            low=float(r["success_low"]) if _finite(r.get("success_low")) else math.nan,
            high=float(r["success_high"]) if _finite(r.get("success_high")) else math.nan,
        )
    )


def _held_out_lines(
    part: str,
    data: Mapping[str, Any],
    size: Mapping[str, Any],
    floor: float,
    folder: Path,
    page: Path,
) -> list[str]:
    equal = int(data["equal_budget"])
    n_goals = int(size["held_out_goals"])
    approaches = list(data["approaches"])
    task = "(goal, box mass) task" if part == "mass" else "goal"
    title = (
        "**Held-out goals and box masses** (`mass` part)"
        if part == "mass"
        else "**Held-out goals** (`task` part)"
    )
    lines = [
        f"{title}: {n_goals} held-out {task}s. F of each approach, its median over tasks and the "
        "median of F / the straight tool's F at the same task, with the episodes spent in total "
        "(training included); each zero-shot design against random sampling and CMA-ES afresh "
        f"at the equal total of {equal} episodes per task, per ({task}, training seed): better / "
        f"within the noise floor ({_percent(floor)}) / worse:",
        "",
    ]
    body = []
    for r in approaches:
        method = str(r["approach"]).partition("@")[0]
        total = str(r["total_episodes"])
        if int(r["train_episodes"]):
            total = f"{r['train_episodes']} + {n_goals} = {r['total_episodes']}"
        if method in _POLICIES and int(r["seeds"]) > 1:
            total += f", {r['seeds']} training seeds"
        body.append(
            [
                _approach_label(str(r["approach"])),
                total,
                f"{r['median_F']:.0f}",
                f"{r['median_F_over_straight']:.2f}",
                f"{r['better_than_straight']} of {r['tasks']}",
                _success(r),
                r.get(f"vs_random_{equal}") or "",
                r.get(f"vs_cmaes_{equal}") or "",
            ]
        )
    lines += markdown_table(
        [
            "approach",
            "episodes in total",
            "median F",
            "median F / straight",
            "better than straight",
            "success",
            f"vs random@{equal}",
            f"vs CMA-ES@{equal}",
        ],
        body,
    )
    for reference in ("cmaes", "random"):
        words = []
        for r in approaches:
            method = str(r["approach"]).partition("@")[0]
            counts = _counts(r.get(f"vs_{reference}_{equal}"))
            if method not in _POLICIES or counts is None:
                continue
            words.append(
                f"{_LABELS[method]} better on {counts[0]}, within the noise floor on "
                f"{counts[1]}, worse on {counts[2]} of {sum(counts)}"
            )
        if words:
            lines += [
                "",
                f"The zero-shot designs against {_LABELS[reference]} afresh at {equal} episodes "
                f"per task (the equal total), over ({task}, training seed) pairs: "
                f"{'; '.join(words)}.",
            ]
    lines.append("")
    stem = "held-out-mass" if part == "mass" else "held-out"
    lines += _figure(folder, page, f"{stem}.png", f"F / straight, held-out {task}s")
    return lines


def render_suite_block(folder: Path, *, page: Path, root: Path, tables: Path | None = None) -> str:
    """The rl suite's block: its fixed-goal and held-out tables, or "pending" without a folder.

    Args:
        folder: the rl suite's committed run folder (``docs/results/rl``).
        page: the page the block goes into (figure links are relative to it).
        root: the repository (the folder is named relative to it).
        tables: where the report's ``summary.json`` is (default: the folder's ``report/``, or
            one rebuilt from the folder's evaluations if it has none).

    Returns:
        Markdown, ending with a newline.

    Raises:
        ValueError: the folder exists but is not an rl suite run folder, or its report lacks a
            number the block needs.
    """
    shown = _shown(folder, root)
    if not folder.exists():
        return _pending_suite(shown)
    manifest = _manifest(folder, SUITE_KIND, "an rl suite run folder")
    if tables is not None:
        return _suite_block(folder, manifest, tables, page=page, shown=shown)
    with _tables(folder, ["summary.json"], _rebuild_suite) as report:
        return _suite_block(folder, manifest, report, page=page, shown=shown)


def _suite_block(
    folder: Path, manifest: Mapping[str, Any], report: Path, *, page: Path, shown: str
) -> str:
    config = manifest["config"]
    source = report / "summary.json"
    summary = _read_json(source)
    size = _need(summary, "size", source)
    floor = float(_need(summary, "noise_floor", source))
    counts = manifest.get("extra", {}).get("evaluation_counts", {})
    unusable = counts.get("invalid")
    failed = counts.get("failed")
    tally = ""
    if isinstance(unusable, int) and isinstance(failed, int):
        tally = f" ({unusable:,} unusable designs, {failed:,} failed evaluations)"
    lines = [
        f"`{shown}/` is the run folder of `tooldesign bench rl --size {size['name']}`, made "
        f"with {_setting_words(config)} ({_provenance(manifest)}): "
        f"{int(_need(summary, 'episodes', source)):,} episodes{tally}. "
        f"{_report_words(folder, page, shown, 'rl.md', report)}",
        "",
        _suite_floor_words(floor, _setting(config)[0]),
        "",
    ]
    if "fixed_goal" in summary:
        lines += _fixed_lines(summary["fixed_goal"], floor, folder, page)
    for part in ("task", "mass"):
        if part in summary:
            lines += _held_out_lines(part, summary[part], size, floor, folder, page)
    return "\n".join(lines).rstrip("\n") + "\n"


def round_section_floors() -> tuple[float, dict[int, float]]:
    """The round section's measured relative noise floors of F, as fractions of |F|.

    Returns:
        The project's median relative floor (the equivalence reference's,
        :func:`benchmarks.suites.equivalence.median_relative_floor`), and the median over the
        committed full protocol references' push cells of noise floor / |F_ref|, per degree d.

    Raises:
        ValueError: a reference is missing or holds no floor.
    """
    from benchmarks.protocol.references import load_references, packaged_references
    from benchmarks.suites.equivalence import median_relative_floor

    path = packaged_references("full")
    if path is None:
        raise ValueError("the full protocol references are not packaged: no floor to quote")
    by_degree: dict[int, list[float]] = {}
    for (_, degree), cell in load_references(path).items():
        if cell.get("task", "push") != "push":
            continue  # the RL benchmark is push's: the other tasks' cells are not its floors
        by_degree.setdefault(int(degree), []).append(
            float(cell["noise_floor"]) / abs(float(cell["f_ref"]))
        )
    medians = {d: _median(values) for d, values in sorted(by_degree.items())}
    return median_relative_floor(), medians


def _suite_floor_words(floor: float, section: str) -> str:
    """What the suite's noise floor is, and whose: the square section's, also at the round one."""
    words = (
        f'Differences of F below {_percent(floor)} of F are "within the noise floor" '
        "(`NOISE_FLOOR` of `benchmarks/rl/suite.py`): the square section's floor, where a "
        "0.1 mm nudge of the box moves F by a median 1.4-1.6 % ([the "
        "model](model.md#the-objective-objectivespec))"
    )
    if section != "round":
        return words + "."
    project, protocol = round_section_floors()
    measured = (
        f"the project's median relative floor, {_percent(project, 2)} of |F| (the equivalence "
        "reference's), and the full protocol references' median floors, "
        + _counted([_percent(v, 2) for v in protocol.values()])
        + f" of F_ref at d = {_counted([str(d) for d in protocol])}"
    )
    if max([project, *protocol.values()]) < floor:
        return (
            f"{words}. This run is of the round section, whose measured floors are smaller "
            f"({measured}); the square section's floor is kept as a conservative bound, so "
            "fewer differences are called beyond the noise floor than a round-section floor "
            "would call."
        )
    return f"{words}. This run is of the round section, whose measured floors are {measured}."


# --- the break-even study -------------------------------------------------------------------

_BREAKEVEN_TABLES = (
    "summary.json",
    "regret.csv",
    "warm_vs_cold.csv",
    "amortization.csv",
    "noise_floors.csv",
)


def _pending_breakeven(shown: str) -> str:
    return (
        "**Pending:** the break-even study's `full` run (`tooldesign rl breakeven --size full`) "
        f"is not committed yet (its folder: `{shown}/`). Until it is, this page "
        "has no result of the study: whether a warm-started designer beats cold CMA-ES on "
        "held-out goals, and after how many goals a learned designer's training pays for "
        "itself, are open.\n"
    )


def _rebuild_breakeven(folder: Path, out: Path) -> None:
    from benchmarks.reports.breakeven import make_breakeven_report

    make_breakeven_report(folder, out_dir=out)


def _read_csv(path: Path, columns: Sequence[str]) -> Any:
    import pandas as pd

    try:
        frame = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as err:
        raise ValueError(f"{path} is not a CSV table ({err})") from None
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise ValueError(f"{path} lacks the columns {', '.join(missing)}")
    return frame


def _budgets_words(budgets: Sequence[int]) -> str:
    return _counted([str(b) for b in budgets])


def _amortization_lines(amortization: Any, popsize: int) -> list[str]:
    from benchmarks.reports.breakeven import amortization_cell, amortization_sentence

    if len(amortization) == 0:
        return [amortization_sentence(amortization, popsize=popsize)]
    budgets = sorted({int(b) for b in amortization["reference_budget"]})
    methods = list(dict.fromkeys(str(m) for m in amortization["method"]))
    at = {
        (str(r["method"]), int(r["reference_budget"])): r for r in amortization.to_dict("records")
    }
    body = []
    for method in methods:
        cells = [method, _training(amortization, method)]
        for budget in budgets:
            r = at.get((method, budget))
            cells.append("" if r is None else amortization_cell(r))
        body.append(cells)
    lines = markdown_table(
        ["method", "training episodes", *(f"B = {b}" for b in budgets)],
        body,
    )
    return [*lines, "", amortization_sentence(amortization, popsize=popsize)]


def _training(amortization: Any, method: str) -> str:
    values = amortization[amortization["method"] == method]["training_episodes"]
    return f"{float(values.iloc[0]):,.0f}"


def _floor_words(floors: Any, fraction: float) -> str:
    import numpy as np

    f_ref = floors["f_ref"].to_numpy(dtype=np.float64)
    floor = floors["floor"].to_numpy(dtype=np.float64)
    relative = floor / np.abs(f_ref)
    above = int((floors["noise_range"] > floors["least_floor"]).sum())
    return (
        f"**Noise floors** (`noise_floors.csv`): median {np.median(floor):.1f} over the "
        f"{len(floors)} tasks ({_percent(float(np.median(relative)), 2)} of |F_ref|; from "
        f"{_percent(float(relative.min()), 2)} to {_percent(float(relative.max()), 2)}); the "
        "range of F measured over nudged scenes exceeded the least floor "
        f"({_percent(fraction, 2)} of |F_ref|) at {above} of {len(floors)} tasks."
    )


def _failed_words(failed: Mapping[str, Any]) -> str:
    if not failed:
        return "No evaluation failed."
    total = sum(int(n) for n in failed.values())
    where = ", ".join(f"{name} {int(n)}" for name, n in sorted(failed.items()))
    return (
        f"**{total} evaluation(s) failed** (an error in the simulation; each counts as an "
        f"unusable design at its task, against its method; messages in `failures/`): {where}."
    )


def render_breakeven_block(
    folder: Path, *, page: Path, root: Path, tables: Path | None = None
) -> str:
    """The break-even study's block: regret, verdict, amortization, or "pending" without it.

    Args:
        folder: the study's committed run folder (``docs/results/breakeven``).
        page: the page the block goes into (figure links are relative to it).
        root: the repository (the folder is named relative to it).
        tables: where the report's tables are (default: the folder's ``report/``, or one
            rebuilt from the folder's evaluations if a table is missing).

    Returns:
        Markdown, ending with a newline.

    Raises:
        ValueError: the folder exists but is not a break-even run folder, or a table of its
            report is malformed.
    """
    shown = _shown(folder, root)
    if not folder.exists():
        return _pending_breakeven(shown)
    manifest = _manifest(folder, BREAKEVEN_KIND, "a break-even run folder")
    if tables is not None:
        return _breakeven_block(folder, manifest, tables, page=page, shown=shown)
    with _tables(folder, _BREAKEVEN_TABLES, _rebuild_breakeven) as report:
        return _breakeven_block(folder, manifest, report, page=page, shown=shown)


def _breakeven_block(
    folder: Path, manifest: Mapping[str, Any], report: Path, *, page: Path, shown: str
) -> str:
    from benchmarks.reports.breakeven import (
        AMORTIZATION_COLUMNS,
        WARM_COLD_COLUMNS,
        results_rows,
        study_popsize,
        verdict_markdown,
        verdict_sentence,
        verdict_test_text,
    )

    config = manifest["config"]
    popsize = study_popsize(config)
    summary = _read_json(report / "summary.json")
    regret = _read_csv(report / "regret.csv", ["method", "budget", "mean", "ci_low", "ci_high"])
    verdict = _read_csv(report / "warm_vs_cold.csv", WARM_COLD_COLUMNS)
    amortization = _read_csv(report / "amortization.csv", AMORTIZATION_COLUMNS)
    floors = _read_csv(
        report / "noise_floors.csv", ["task", "f_ref", "noise_range", "least_floor", "floor"]
    )
    source = report / "summary.json"
    fraction = float(_need(summary, "noise_floor_fraction", source))
    failed = _need(summary, "failed", source)
    evaluations = int(_need(summary, "evaluations", source))
    size = config["size"]
    tasks = config.get("tasks", [])
    held_out = sum(1 for t in tasks if t.get("set") == "held-out")
    budgets = sorted({int(b) for b in regret["budget"]})
    study_budgets = [int(b) for b in size.get("budgets", budgets)]
    tests = int(sum(_finite(p) for p in verdict["p_holm"]))
    lines = [
        f"`{shown}/` is the run folder of `tooldesign rl breakeven --size {size['name']}`, "
        f"made with {_setting_words(config)} ({_provenance(manifest)}): "
        f"{len(tasks)} tasks ({held_out} held-out instances of the protocol, "
        f"{len(tasks) - held_out} fresh), "
        f"{size['replicates']} replicate(s), budgets {_budgets_words(budgets)}; "
        f"{evaluations:,} evaluations in `evaluations.parquet`. "
        + _report_words(folder, page, shown, "breakeven.md", report),
        "",
        _failed_words(failed),
        "",
        _floor_words(floors, fraction),
        "",
        "**Normalized regret** (`regret.csv`): mean over tasks [95 % t interval over tasks]; 0 "
        "is the best design the study found at the task, 1 random sampling's expected best at "
        "the same budget.",
        "",
        *markdown_table(["method", *(str(b) for b in budgets)], results_rows(regret)),
        "",
        *_figure(folder, page, "regret.png", "Normalized regret per budget"),
        "**Warm-started against cold CMA-ES** (`warm_vs_cold.csv`). "
        + verdict_test_text(int(size["replicates"]), tests, popsize=popsize),
        "",
        *verdict_markdown(verdict),
        "",
        verdict_sentence(
            verdict, budgets=study_budgets, methods=config.get("methods", []), popsize=popsize
        ),
        "",
        "**Amortization** (`amortization.csv`): against cold CMA-ES at budget B per goal, after "
        "how many goals the method's training episodes pay for themselves (with the per-goal "
        "budget it needs to reach cold CMA-ES's mean regret at B over all its replicates; "
        "never: it needs B or more, or does not reach it at any budget of the study), from the "
        "method's mean over its training seeds; then the range of each training seed's own "
        "(its mean over the same tasks against the same target).",
        "",
        *_amortization_lines(amortization, popsize),
        "",
        *_figure(folder, page, "amortization.png", "Total episodes against goals"),
    ]
    return "\n".join(lines).rstrip("\n") + "\n"


# --- what is not done -----------------------------------------------------------------------


def committed(folder: Path, *, kind: str, what: str) -> bool:
    """Whether the page's run is committed at ``folder``: False if there is no folder.

    A folder that is there must be the run the page quotes: a run folder of ``kind`` made at
    size :data:`COMMITTED_SIZE` with today's tool section and hand (``ToolSpec().section_shape``,
    ``SceneSpec().merge_fixed_links``), as its manifest's config records them (a config without
    the fields reads as :data:`ADDED_FIELDS`). A smoke run or a square-section run committed in
    its place would otherwise be quoted as the results at today's defaults.

    Raises:
        ValueError: the folder is not a run folder of ``kind``, or its size or setting differs
            (one line naming the folder and what differs).
    """
    if not folder.exists():
        return False
    config = _manifest(folder, kind, what)["config"]
    from tooldesign_env.geometry import ToolSpec
    from tooldesign_env.specs import SceneSpec

    size = config.get("size")
    section, merged = _setting(config)
    found = {
        "size": size.get("name") if isinstance(size, dict) else size,
        "section_shape": section,
        "merge_fixed_links": merged,
    }
    expected = {
        "size": COMMITTED_SIZE,
        "section_shape": ToolSpec().section_shape,
        "merge_fixed_links": SceneSpec().merge_fixed_links,
    }
    differs = [f"{k} {found[k]!r}, expected {v!r}" for k, v in expected.items() if found[k] != v]
    if differs:
        raise ValueError(
            f"{folder} is not the committed run docs/rl.md quotes ({what} of size "
            f"{COMMITTED_SIZE} at today's defaults): {'; '.join(differs)}"
        )
    return True


def _committed_runs(suite: Path, breakeven: Path) -> tuple[bool, bool]:
    return (
        committed(suite, kind=SUITE_KIND, what="an rl suite run folder"),
        committed(breakeven, kind=BREAKEVEN_KIND, what="a break-even run folder"),
    )


def render_not_done_block(suite: Path, breakeven: Path, *, root: Path) -> str:
    """The "What is not done" items that say which committed run is still missing.

    Returns:
        Markdown list items (possibly none), with blank lines around them.

    Raises:
        ValueError: a folder is there but is not the committed run (:func:`committed`).
    """
    has_suite, has_breakeven = _committed_runs(suite, breakeven)
    items = []
    if not has_suite:
        items.append(
            "- The rl suite's rerun at today's defaults (the round section and the merged hand) "
            f"is not committed yet (`{_shown(suite, root)}/`): the rl suite's results on this "
            "page are the square section's and the 13-link arm's."
        )
    if not has_breakeven:
        items.append(
            "- The break-even study's `full` run is not committed yet "
            f"(`{_shown(breakeven, root)}/`): its results, the amortization curve and the answer "
            "to whether a warm-started designer beats cold CMA-ES on held-out goals are pending "
            "(the commands and the design are above)."
        )
    return "".join(f"{item}\n" for item in items)


# --- the page -------------------------------------------------------------------------------


def render_blocks(root: Path) -> dict[str, str]:
    """Every block of the page, as it goes between its markers, from the folders under ``root``.

    Raises:
        ValueError: a folder is not the committed run it should be (:func:`committed`), or its
            report is malformed.
    """
    page = root / PAGE
    suite, breakeven = root / SUITE_FOLDER, root / BREAKEVEN_FOLDER
    not_done = render_not_done_block(suite, breakeven, root=root)  # checks both folders first
    blocks = {
        "rl-suite": render_suite_block(suite, page=page, root=root),
        "breakeven": render_breakeven_block(breakeven, page=page, root=root),
        "rl-not-done": not_done,
    }
    return {name: _padded(block) for name, block in blocks.items()}


def render_page(text: str, *, root: Path) -> str:
    """``text`` (the page) with its blocks rendered from the folders under ``root``.

    Raises:
        ValueError: a block's markers are missing (the message names the page), or a folder
            is not the committed run it should be.
    """
    blocks = render_blocks(root)
    try:
        for name, block in blocks.items():
            text = replace_block(text, name, block)
    except ValueError as err:
        raise ValueError(f"{root / PAGE}: {err}") from None
    return text


def _padded(block: str) -> str:
    """A blank line either side, so that Markdown reads the block apart from the markers."""
    return f"\n{block}\n" if block else ""


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line: ``[--root DIR] [--check]``; a bad root is a one-line error (exit 2)."""
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.cli.rl_page",
        description=(
            "Write the results blocks of docs/rl.md from the committed run folders "
            "docs/results/rl and docs/results/breakeven (their report/ files; nothing is "
            "simulated). A folder not committed yet gets a paragraph saying so; a folder there "
            "must be a full run at today's tool section and hand."
        ),
    )
    parser.add_argument(
        "--root",
        type=Path,
        default=Path.cwd(),
        help="the repository (default: the current directory)",
    )
    parser.add_argument(
        "--check",
        action="store_true",
        help="write nothing; exit 1 if a block of the page differs from its rendering",
    )
    args = parser.parse_args(argv)
    if not (args.root / PAGE).is_file():
        parser.error(f"argument --root: {args.root} holds no {PAGE.as_posix()}")
    return args


def main(argv: Sequence[str] | None = None) -> int:
    """Render the blocks into docs/rl.md (or check them); returns the exit code."""
    args = parse_args(argv)
    root = args.root.resolve()
    page = root / PAGE
    try:
        text = page.read_text(encoding="utf-8")
    except UnicodeDecodeError as err:
        print(f"rl_page: error: {page} is not UTF-8 text ({err.reason})", file=sys.stderr)
        return 2
    try:
        new = render_page(text, root=root)
    except (ValueError, OSError) as exc:
        print(f"rl_page: error: {exc}", file=sys.stderr)
        return 2
    states = {
        "rl suite": (root / SUITE_FOLDER).exists(),
        "break-even": (root / BREAKEVEN_FOLDER).exists(),
    }
    said = ", ".join(f"{k}: {'from its folder' if v else 'pending'}" for k, v in states.items())
    if args.check:
        stale = [n for n in BLOCKS if current_block(new, n) != current_block(text, n)]
        if stale:
            print(f"{page}: stale blocks {', '.join(stale)} ({said}); run without --check")
            return 1
        print(f"{page}: every block is up to date ({said})")
        return 0
    if new != text:
        from benchmarks.storage import atomic_write_text

        atomic_write_text(page, new)
    print(f"wrote the {len(BLOCKS)} blocks of {page} ({said})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
