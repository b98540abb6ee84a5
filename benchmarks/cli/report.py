"""``tooldesign report``: rebuild the figures and tables of a run folder from its stored results."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, cast


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``tooldesign report`` on the dispatcher's subparsers."""
    parser = subparsers.add_parser(
        "report",
        help="rebuild the figures and tables of a run folder from its stored results",
        description=(
            "Rebuild every report of a run folder (convergence, summary, pairwise tests and the "
            "suite's own figures and tables) from its stored results alone; nothing is "
            "simulated. A report.html in the run folder (tooldesign html) is rebuilt too, so it "
            "shows the new figures (not with --out, whose figures it does not embed). See "
            "docs/benchmarks.md."
        ),
    )
    parser.add_argument("run_folder", type=Path, metavar="RUN_FOLDER", help="the run folder")
    parser.add_argument(
        "--out", type=Path, default=None, metavar="DIR", help="where to write (RUN_FOLDER/report)"
    )
    parser.set_defaults(run=_run)
    return cast("argparse.ArgumentParser", parser)


def _run(args: argparse.Namespace) -> int:
    from benchmarks.reports import make_suite_report, write_html_report
    from benchmarks.reports.html import REPORT_FILE

    files = make_suite_report(args.run_folder, out_dir=args.out)
    folder = files[0].parent if files else args.run_folder
    print(f"{len(files)} report files written to {folder}")
    page = Path(args.run_folder) / REPORT_FILE
    if page.is_file() and args.out is None:
        # It embeds the figures just replaced: left as it was, it would show the old ones.
        print(f"{write_html_report(args.run_folder)} rebuilt")
    return 0
