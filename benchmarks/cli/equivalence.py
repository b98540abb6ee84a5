"""``tooldesign equivalence``: the rule that accepts a change to the simulation or the objective.

``record`` measures a reference (a fixed design set's nominal F and noise floors), ``check``
compares the code as it is now with it (tests 1 and 2 of the rule), ``verdicts`` compares the
verdicts and rankings of two runs of the smoke suites (test 3). See docs/performance.md, "The
equivalence rule".
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, cast

from benchmarks.cli._common import shown
from benchmarks.execution import WORKERS_MAX

#: ``benchmarks.suites.equivalence.REFERENCE``, spelled out so that parsing the command line
#: does not import the simulation (a test checks that they agree).
DEFAULT_REFERENCE = Path(__file__).resolve().parents[1] / "suites" / "equivalence-reference.json"
#: ``DesignSetSpec()``'s scenes, and RetestConfig's range of them.
DEFAULT_SCENES, SCENES_MIN, SCENES_MAX = 16, 2, 100
ROWS = ("outside", "all", "none")


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``tooldesign equivalence`` and its three actions."""
    parser = subparsers.add_parser(
        "equivalence",
        help="accept or reject a change to the simulation or F by the equivalence rule",
        description=(
            "The equivalence rule (docs/performance.md): a change to the simulation or the "
            "objective is accepted when at least 90 % of a fixed set of designs move by less "
            "than their noise floor, the mean relative change of F has a 95 % interval inside "
            "plus or minus half the median noise floor, and the smoke suites' verdicts and "
            "rankings do not change."
        ),
    )
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    record = actions.add_parser(
        "record",
        help="evaluate the design set in nudged scenes and write a reference",
        description=(
            "Draw the fixed design set (degrees 3, 5 and 8 and the named cubic designs), "
            "evaluate every design in the nominal scene and the standard nudged ones with a "
            "process pool, and write the reference: per design its nominal F, terms and noise "
            "floor, with the platform and commit that made it."
        ),
    )
    record.add_argument(
        "--out", type=Path, required=True, metavar="FILE", help="the reference file to write"
    )
    record.add_argument(
        "--scenes",
        type=int,
        default=DEFAULT_SCENES,
        help=f"scenes per design, the nominal one and nudges, {SCENES_MIN} to {SCENES_MAX} "
        "(default: %(default)s)",
    )
    record.add_argument(
        "--note", default="", help="what physics the reference is of (stored in the file)"
    )
    _add_workers(record)
    record.set_defaults(run=_record)
    check = actions.add_parser(
        "check",
        help="evaluate the design set once and compare with a reference (tests 1 and 2)",
        description=(
            "Evaluate every design of the reference once, in the nominal scene, with the code "
            "as it is now, and print the rule's tests 1 and 2 and the verdict. Exit code 0 if "
            "accepted, 1 if rejected."
        ),
    )
    check.add_argument(
        "--reference",
        type=Path,
        default=DEFAULT_REFERENCE,
        metavar="FILE",
        help="the reference (default: the committed one, %(default)s)",
    )
    check.add_argument(
        "--rows",
        choices=ROWS,
        default="outside",
        help="designs shown in the table: those outside their floor (default), all, none",
    )
    _add_workers(check)
    check.set_defaults(run=_check)
    verdicts = actions.add_parser(
        "verdicts",
        help="compare the verdicts and rankings of two runs of the smoke suites (test 3)",
        description=(
            "Compare what the reports of two suite runs conclude (pairwise verdicts, rankings "
            "of optimizers, best marks, the designs the figures show), not their numbers. "
            "BEFORE and AFTER are suite run folders, or folders holding several (compared by "
            "name). Exit code 0 if nothing changed, 1 otherwise."
        ),
    )
    verdicts.add_argument("before", type=Path, metavar="BEFORE", help="run(s) before the change")
    verdicts.add_argument("after", type=Path, metavar="AFTER", help="run(s) after the change")
    verdicts.set_defaults(run=_verdicts)
    return cast("argparse.ArgumentParser", parser)


def _add_workers(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--workers", type=int, default=None, help=f"worker processes, 1 to {WORKERS_MAX}"
    )


def _check_workers(workers: int | None) -> None:
    if workers is not None and not 1 <= workers <= WORKERS_MAX:
        raise ValueError(f"--workers must be from 1 to {WORKERS_MAX}, got {workers}")


def _record(args: argparse.Namespace) -> int:
    _check_workers(args.workers)
    if not SCENES_MIN <= args.scenes <= SCENES_MAX:
        raise ValueError(f"--scenes must be from {SCENES_MIN} to {SCENES_MAX}, got {args.scenes}")
    if args.out.is_dir():
        raise IsADirectoryError(f"--out {args.out} is a folder; give the reference file's path")
    if not args.out.parent.is_dir():
        raise FileNotFoundError(f"--out {args.out}: its folder {args.out.parent} does not exist")
    from benchmarks.suites.equivalence import (
        DesignSetSpec,
        calibration,
        record,
        write_reference,
    )

    reference = record(DesignSetSpec(scenes=args.scenes), workers=args.workers, note=args.note)
    write_reference(reference, args.out)
    median = reference["median_relative_floor"]
    shown = "unmeasured" if median is None else f"{100 * median:.4f} %"
    print(
        f"{len(reference['designs'])} designs in {args.scenes} scenes each; median relative "
        f"noise floor of F {shown}; reference written to {args.out}"
    )
    print(_calibration_line(reference, calibration(reference)))
    return 0


def _check(args: argparse.Namespace) -> int:
    _check_workers(args.workers)
    from benchmarks.suites.equivalence import (
        calibration,
        check,
        format_comparison,
        read_reference,
    )

    reference = read_reference(args.reference)  # a bad file is named before anything runs
    result = check(reference, workers=args.workers)
    print(
        f"reference {args.reference}: {reference.get('note') or '(no note)'}; recorded on "
        f"{reference.get('platform')} at commit {reference.get('git_commit')}"
    )
    print(_calibration_line(reference, calibration(reference)))
    print(format_comparison(result, rows=args.rows))
    if result.accepted:
        print(
            "test 3: run the smoke suites before and after the change and compare them with "
            "`tooldesign equivalence verdicts BEFORE AFTER` (tests/test_smoke_reproduction.py "
            "compares them with the committed sets)"
        )
    return 0 if result.accepted else 1


def _calibration_line(reference: dict[str, Any], figures: dict[str, float]) -> str:
    scenes = reference.get("spec", {}).get("scenes")
    if figures["held_out_within"] != figures["held_out_within"]:  # NaN: no scene values
        return f"{len(reference['designs'])} designs; no F per scene recorded: not calibrated"
    return (
        f"{len(reference['designs'])} designs, {scenes} scenes each: a held-out nudge lies within "
        f"the floor of the other scenes for {100 * figures['held_out_within']:.1f} % of "
        f"(design, nudge) pairs, so a change of nudge size passes test 1 with probability "
        f"{figures['pass_probability']:.4f}; test 2 passes "
        f"{100 * figures['nudges_passing_test2']:.0f} % of the recorded nudges taken as a change"
    )


def _runs(folder: Path) -> dict[str, Path]:
    """The suite run folders in ``folder``: itself, or its subfolders that have a report."""
    if not folder.is_dir():
        raise FileNotFoundError(f"{shown(folder)} does not exist or is not a folder")
    if (folder / "report").is_dir():
        return {"": folder}
    runs = {p.name: p for p in sorted(folder.iterdir()) if (p / "report").is_dir()}
    if not runs:
        raise ValueError(
            f"{folder} is neither a suite run folder with a report/ nor a folder holding some"
        )
    return runs


def _verdicts(args: argparse.Namespace) -> int:
    before, after = _runs(args.before), _runs(args.after)
    if set(before) != set(after):
        raise ValueError(
            f"BEFORE and AFTER must hold the same runs, got {sorted(before)} and {sorted(after)}"
        )
    from benchmarks.reports.verdicts import compare_verdicts, read_report_tables, verdicts

    changed = 0
    for name in sorted(before):
        old = verdicts(read_report_tables(before[name]))
        new = verdicts(read_report_tables(after[name]))
        lines = compare_verdicts(old, new)
        counted = sum(len(v) for v in old.values())
        label = name or str(args.after)
        if lines:
            changed += 1
            print(f"{label}: {len(lines)} of {counted} verdicts and rankings CHANGED")
            print("\n".join(f"  {line}" for line in lines))
        else:
            print(f"{label}: the same {counted} verdicts and rankings")
    print("verdict: " + ("REJECTED (test 3 of the rule)" if changed else "unchanged (test 3)"))
    return 1 if changed else 0
