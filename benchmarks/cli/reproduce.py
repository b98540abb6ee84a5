"""``tooldesign reproduce``: every suite's report, then ``docs/reproduction.md``."""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any, cast

from benchmarks.cli._common import shown


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``tooldesign reproduce``."""
    parser = subparsers.add_parser(
        "reproduce",
        help="rebuild the committed suites' reports and write docs/reproduction.md",
        description="Rebuild the report of every suite under --results and write the "
        "reproduction page, which states each claim of the paper with its noise floor.",
    )
    parser.add_argument(
        "--results",
        type=Path,
        default=Path("docs/results"),
        metavar="DIR",
        help="the folder of the suites' run folders (optimizers, precision-sweep, ..., and "
        "their square-section runs in DIR/square) (default: %(default)s)",
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("docs/reproduction.md"),
        metavar="FILE",
        help="the reproduction page to write (Markdown) (default: %(default)s)",
    )
    parser.add_argument(
        "--skip-reports",
        action="store_true",
        help="use the suites' reports as they are instead of rebuilding them first",
    )
    parser.set_defaults(run=_run)
    return cast("argparse.ArgumentParser", parser)


def _run(args: argparse.Namespace) -> int:
    if not args.results.is_dir():  # before the imports (seconds)
        raise ValueError(f"no results folder {shown(args.results)}")
    from benchmarks.reports import make_suite_report
    from benchmarks.reports.reproduction import SQUARE, SUITES, reproduction_page
    from benchmarks.storage import atomic_write_text

    if not args.results.is_dir():
        raise ValueError(f"no results folder {shown(args.results)}")
    if not args.skip_reports:
        for folder in (args.results, args.results / SQUARE):
            for suite in SUITES:
                if (folder / suite).is_dir():
                    make_suite_report(folder / suite)
    atomic_write_text(args.out, reproduction_page(args.results))
    print(f"wrote {os.fspath(args.out)}")
    return 0
