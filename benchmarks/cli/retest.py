"""``tooldesign retest``: a suite's final designs in nudged scenes (noise floor) and stressed."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path
from typing import Any, cast

from benchmarks.reports.retest import noise_floor
from benchmarks.storage import RETEST_DIR, read_manifest, read_retests
from benchmarks.suites.config import suite_of_manifest
from benchmarks.suites.retest import RetestConfig, default_config, retest_suite


def _positive_floats(text: str) -> tuple[float, ...]:
    try:
        return tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated numbers, e.g. 0.2,0.5, got {text!r}"
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
    defaults = RetestConfig()
    parser.add_argument("run_folder", type=Path, metavar="RUN_FOLDER", help="the run folder")
    parser.add_argument(
        "--nudges", type=int, default=defaults.nudges, help="scenes per design (default: 5)"
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
        "--repeats", type=int, default=defaults.repeats, help="scenes of the stress test"
    )
    parser.add_argument("--workers", type=int, default=None, help="worker processes")
    parser.set_defaults(run=_run)
    return cast("argparse.ArgumentParser", parser)


def _run(args: argparse.Namespace) -> int:
    suite = suite_of_manifest(read_manifest(args.run_folder))
    base = default_config(suite)
    config = dataclasses.replace(
        base,
        nudges=args.nudges,
        repeats=min(args.repeats, args.nudges),
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
