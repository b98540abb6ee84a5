"""``tooldesign reproduce``: every suite's report, then ``docs/reproduction.md``.

Claim (a) is judged again under the benchmark protocol from ``--protocol DIR`` (default
``RESULTS/protocol-full``, if present): its report is written again from its cells first
(unless ``--skip-reports``, when its tables are checked against them instead).
"""

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
        help="use the suites' and the protocol run's reports as they are instead of rebuilding "
        "them first (the protocol's tables are then checked against its cells)",
    )
    parser.add_argument(
        "--protocol",
        type=Path,
        default=None,
        metavar="DIR",
        help="the protocol run folder (tooldesign bench protocol) that claim (a) is judged "
        "under again, per dimension (default: RESULTS/protocol-full if it exists; without "
        "one the page says the claim is not tested there and how to make the run)",
    )
    parser.set_defaults(run=_run)
    return cast("argparse.ArgumentParser", parser)


def _protocol_folder(args: argparse.Namespace, default: Path) -> Path | None:
    """The protocol run folder to judge claim (a) under, or None (not tested)."""
    folder: Path = default if args.protocol is None else args.protocol
    if args.protocol is None and not os.path.lexists(default):
        return None
    if not folder.is_dir():
        given = "--protocol " if args.protocol is not None else "the default protocol folder "
        raise ValueError(
            f"{given}{shown(folder)} is not a folder: give a protocol run folder (tooldesign "
            "bench protocol --out DIR makes one)"
        )
    return folder


def _run(args: argparse.Namespace) -> int:
    if not args.results.is_dir():  # before the imports (seconds)
        raise ValueError(f"no results folder {shown(args.results)}")
    from benchmarks.protocol import make_protocol_report, read_protocol
    from benchmarks.protocol.claims import PROTOCOL_ALPHA, check_own_report, protocol_claim
    from benchmarks.reports import make_suite_report
    from benchmarks.reports.reproduction import (
        PROTOCOL_FOLDER,
        SQUARE,
        SUITES,
        reproduction_page,
    )
    from benchmarks.storage import atomic_write_text

    if not args.results.is_dir():
        raise ValueError(f"no results folder {shown(args.results)}")
    protocol = _protocol_folder(args, args.results / PROTOCOL_FOLDER)
    if protocol is not None:
        read_protocol(protocol)  # not a protocol run folder: refused before any report is built
        check_own_report(protocol)  # a user's report merged with --baseline is not overwritten
    if not args.skip_reports:
        for folder in (args.results, args.results / SQUARE):
            for suite in SUITES:
                if (folder / suite).is_dir():
                    make_suite_report(folder / suite)
        if protocol is not None:
            make_protocol_report([protocol], alpha=PROTOCOL_ALPHA)
    # A report just written from the cells needs no second computation to be trusted.
    claim = (
        None
        if protocol is None
        else protocol_claim(protocol, results=args.results, check=args.skip_reports)
    )
    atomic_write_text(args.out, reproduction_page(args.results, protocol=claim))
    print(f"wrote {os.fspath(args.out)}")
    return 0
