"""``tooldesign html``: one self-contained ``report.html`` of a run folder."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, cast

from benchmarks.cli._common import shown


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``tooldesign html``."""
    parser = subparsers.add_parser(
        "html",
        help="write a self-contained HTML report (figures, tables, card, video) of a run folder",
        description="Write DIR/report.html: every figure, video, card and small table of the "
        "folder, embedded in one file that opens without network.",
    )
    parser.add_argument(
        "folder", type=Path, metavar="DIR", help="a design, evaluate or suite run folder"
    )
    parser.add_argument(
        "--out", type=Path, default=None, help="the HTML file (default DIR/report.html)"
    )
    parser.set_defaults(run=_run)
    return cast("argparse.ArgumentParser", parser)


def _run(args: argparse.Namespace) -> int:
    if not args.folder.is_dir():  # before the imports (pandas: a second)
        raise FileNotFoundError(f"{shown(args.folder)} is not a folder")
    from benchmarks.reports import write_html_report

    path = write_html_report(args.folder, out=args.out)
    print(f"report: {path}")
    return 0
