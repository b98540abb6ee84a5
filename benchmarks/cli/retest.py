"""``tooldesign retest``: a suite's final designs in nudged scenes (noise floor) and stressed."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path
from typing import Any, cast

from benchmarks.cli._common import RETEST_NUDGES, RETEST_REPEATS, shown
from benchmarks.execution import WORKERS_MAX

#: Scenes per design of the noise floor (RetestConfig's range).
NUDGES_MIN, NUDGES_MAX = 2, 100


def _positive_floats(text: str) -> tuple[float, ...]:
    """One or more comma-separated numbers; an empty field (``""``, ``0.2,,0.3``) is refused."""
    fields = text.split(",")
    try:
        if any(not v.strip() for v in fields):
            raise ValueError
        return tuple(float(v) for v in fields)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected one or more comma-separated numbers, e.g. 0.2,0.5, got {text!r}"
        ) from None


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``tooldesign retest`` on the dispatcher's subparsers."""
    parser = subparsers.add_parser(
        "retest",
        help="measure the noise floor (and robustness over ranges) of a suite's final designs",
        description=(
            "Re-evaluate every final design of a suite run folder in nudged scenes (its noise "
            "floor) and, for suites that test robustness, over a range of box masses and "
            "frictions; resumes an interrupted retest. Then run `tooldesign report`. See "
            "docs/benchmarks.md."
        ),
    )
    parser.add_argument("run_folder", type=Path, metavar="RUN_FOLDER", help="the run folder")
    parser.add_argument(
        "--nudges",
        type=int,
        default=RETEST_NUDGES,
        help=f"scenes per design, {NUDGES_MIN} to {NUDGES_MAX} (default: %(default)s)",
    )
    parser.add_argument(
        "--masses",
        type=_positive_floats,
        default=None,
        metavar="M1,M2,...",
        help="box masses of the stress test in kg (default: 0.2,0.4,0.6,0.8,1.0 for suites "
        "that test robustness, else none)",
    )
    parser.add_argument(
        "--frictions",
        type=_positive_floats,
        default=None,
        metavar="MU1,MU2,...",
        help="box frictions of the stress test (default: 0.2,0.6 for suites that test "
        "robustness, else none)",
    )
    parser.add_argument(
        "--repeats",
        type=int,
        default=None,
        help=f"scenes of the stress test, 1 to --nudges (default: {RETEST_REPEATS}, or "
        "--nudges if fewer)",
    )
    parser.add_argument(
        "--workers", type=int, default=None, help=f"worker processes, 1 to {WORKERS_MAX}"
    )
    parser.set_defaults(run=_run)
    return cast("argparse.ArgumentParser", parser)


def _check_counts(args: argparse.Namespace) -> int:
    """The stress test's repeats; ValueError naming a flag out of its range."""
    if not NUDGES_MIN <= args.nudges <= NUDGES_MAX:
        raise ValueError(f"--nudges must be from {NUDGES_MIN} to {NUDGES_MAX}, got {args.nudges}")
    if args.repeats is None:
        repeats = min(RETEST_REPEATS, args.nudges)
    elif not 1 <= args.repeats <= args.nudges:
        raise ValueError(
            f"--repeats must be from 1 to --nudges ({args.nudges}), got {args.repeats}"
        )
    else:
        repeats = args.repeats
    if args.workers is not None and not 1 <= args.workers <= WORKERS_MAX:
        raise ValueError(f"--workers must be from 1 to {WORKERS_MAX}, got {args.workers}")
    return int(repeats)


def _run(args: argparse.Namespace) -> int:
    repeats = _check_counts(args)  # before the folder is read: a bad flag is named first
    if not Path(args.run_folder).is_dir():  # before the imports (seconds)
        raise FileNotFoundError(
            f"run folder {shown(args.run_folder)} does not exist or is not a folder"
        )
    from benchmarks.reports.retest import noise_floor
    from benchmarks.storage import RETEST_DIR, read_retests
    from benchmarks.suites.config import suite_of_manifest
    from benchmarks.suites.retest import default_config, retest_suite

    suite = suite_of_manifest(_suite_manifest(args.run_folder))
    base = default_config(suite)
    config = dataclasses.replace(
        base,
        nudges=args.nudges,
        repeats=repeats,
        masses=base.masses if args.masses is None else args.masses,
        frictions=base.frictions if args.frictions is None else args.frictions,
    )
    files = retest_suite(args.run_folder, config, workers=args.workers)
    floor = noise_floor(read_retests(args.run_folder))
    print(
        f"{len(files)} designs retested in {Path(args.run_folder) / RETEST_DIR}; noise floor of "
        f"F over {int(floor['designs'])} designs: {floor['free_energy']:.4g} "
        f"({100 * floor['free_energy_relative']:.2f} % median range over {config.nudges} nudges)"
    )
    return 0


#: What applies to a run folder of each other kind, for the message refusing it.
_OTHER_KINDS = {
    "design": "its figures and report are redrawn by `tooldesign report`",
    "rl-suite": "its report is rebuilt by `tooldesign report`",
}


def _suite_manifest(folder: Path) -> dict[str, Any]:
    """The manifest of a suite run folder; ValueError naming the folder and its kind if not."""
    from benchmarks.storage import read_manifest
    from benchmarks.suites.config import SUITE_KIND

    if not folder.is_dir():
        raise FileNotFoundError(f"run folder {shown(folder)} does not exist or is not a folder")
    what = "retest re-evaluates the final designs of a suite run folder (`tooldesign bench`)"
    try:
        manifest: dict[str, Any] = read_manifest(folder)
    except FileNotFoundError:
        raise ValueError(
            f"{folder} has no manifest.json, so it is not a suite run folder (a folder of "
            f"`tooldesign evaluate`, say); {what}"
        ) from None
    extra = manifest.get("extra")
    kind = extra.get("kind") if isinstance(extra, dict) else None
    if kind != SUITE_KIND:
        where = f"a {kind} run folder" if isinstance(kind, str) else "not a run folder we know"
        then = f"; {_OTHER_KINDS[kind]}" if kind in _OTHER_KINDS else ""
        raise ValueError(f"{folder} is {where}, not a suite run folder: {what}{then}")
    return manifest
