"""``tooldesign report``: rebuild the figures and tables of a run folder from its stored results."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, cast

from benchmarks.cli._common import shown


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``tooldesign report`` on the dispatcher's subparsers."""
    parser = subparsers.add_parser(
        "report",
        help="rebuild the figures and tables of a run folder from its stored results",
        description=(
            "Rebuild every report of a run folder (convergence, summary, pairwise tests and the "
            "suite's own figures and tables, or a design run's Figure 3 and robustness plot) "
            "from its stored results alone; nothing is simulated. A report.html in the run "
            "folder (tooldesign html) is rebuilt too, so it shows the new figures (not with "
            "--out, whose figures it does not embed). A protocol run folder gets its protocol "
            "report (docs/protocol.md). See docs/benchmarks.md."
        ),
    )
    parser.add_argument("run_folder", type=Path, metavar="RUN_FOLDER", help="the run folder")
    parser.add_argument(
        "--out", type=Path, default=None, metavar="DIR", help="where to write (RUN_FOLDER/report)"
    )
    parser.set_defaults(run=_run)
    return cast("argparse.ArgumentParser", parser)


def _run(args: argparse.Namespace) -> int:
    if not Path(args.run_folder).is_dir():  # before the imports (seconds)
        raise FileNotFoundError(f"run folder {shown(args.run_folder)} does not exist")
    from benchmarks.protocol.suite import PROTOCOL_FILE

    if (Path(args.run_folder) / PROTOCOL_FILE).is_file():
        return _protocol_report(args)
    from benchmarks.reports import make_suite_report, write_design_report, write_html_report
    from benchmarks.reports.design_figures import read_design_run
    from benchmarks.reports.html import REPORT_FILE

    design = _is_design_folder(args.run_folder)
    checked = None
    if design and args.out is None:
        # Every file the design figures read is checked before the first report file is
        # written: a damaged design.json must not leave the generic report rebuilt and the
        # figures stale beside it.
        checked = read_design_run(args.run_folder)
    files = make_suite_report(args.run_folder, out_dir=args.out)
    folder = files[0].parent if files else args.run_folder
    print(f"{len(files)} report files written to {folder}")
    if design:
        if args.out is None:
            # Figure 3 and the robustness plot live in the run folder itself; drawn again, with
            # report.html embedding them.
            drawn = write_design_report(args.run_folder, checked=checked)
            print(f"{len(drawn)} design figures and report.html rebuilt in {args.run_folder}")
            return 0
        print(
            f"the design figures (figure3.png, robustness.png, ...) live in {args.run_folder} "
            "and were left as they were: run without --out to redraw them"
        )
    page = Path(args.run_folder) / REPORT_FILE
    if page.is_file() and args.out is None:
        # It embeds the figures just replaced: left as it was, it would show the old ones.
        from benchmarks.storage import UnsafeRunFileError

        try:
            print(f"{write_html_report(args.run_folder)} rebuilt")
        except UnsafeRunFileError as error:  # a page of the user's own: theirs, kept
            print(f"{page} left as it is: {error}")
    return 0


def _protocol_report(args: argparse.Namespace) -> int:
    """A protocol run folder's report, from its cells' stored evaluations.

    A finished run's folder kept without its cells' part files, as committed results are,
    cannot be resumed, but its report can be rebuilt, with the references it would use (its
    own recorded ``references.json``, else the committed ones of its size).
    """
    from benchmarks.protocol import make_protocol_report
    from benchmarks.reports import write_html_report
    from benchmarks.reports.html import REPORT_FILE

    files = make_protocol_report([args.run_folder], args.out)
    folder = files[0].parent if files else args.run_folder
    print(f"{len(files)} protocol report files written to {folder}")
    if args.out is None and (Path(args.run_folder) / REPORT_FILE).is_file():
        print(f"{write_html_report(args.run_folder)} rebuilt")
    return 0


def _is_design_folder(run_folder: Path) -> bool:
    """Whether ``run_folder`` holds a ``tooldesign design`` run (its manifest says so)."""
    from benchmarks.design.config import DESIGN_SUITE
    from benchmarks.storage import read_manifest

    try:
        extra = read_manifest(run_folder).get("extra")
    except (FileNotFoundError, ValueError):
        return False  # a bare store: make_suite_report read it without a manifest
    return isinstance(extra, dict) and extra.get("kind") == DESIGN_SUITE
