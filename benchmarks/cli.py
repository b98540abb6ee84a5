"""The ``tooldesign`` command line: evaluate a design, design a tool, run benchmark suites.

Each subcommand lives in its own module and adds its own arguments through ``add_parser``; this
file only dispatches.
"""

from __future__ import annotations

import argparse
import pickle
import sys
from collections.abc import Sequence

__all__ = ["main"]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand."""
    from benchmarks import evaluate  # noqa: I001  (one import per subcommand)
    from benchmarks import design
    from benchmarks import runner
    from benchmarks import retest
    from benchmarks import suite_reports

    parser = argparse.ArgumentParser(
        prog="tooldesign",
        description="Design robot hand tools with control confidence (ToolDesign-v0).",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    evaluate.add_parser(sub)
    design.add_parser(sub)
    runner.add_parser(sub)
    retest.add_parser(sub)
    suite_reports.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except (
        ValueError,
        TypeError,
        OverflowError,
        OSError,
        ImportError,
        pickle.UnpicklingError,
    ) as exc:
        # Bad input, a path that is a file where a folder is wanted (or the reverse), a
        # scheduler that does not answer, a corrupted state file or a missing optional backend
        # (whose message names the pip extra): one clear line instead of a traceback.
        parser.exit(2, f"tooldesign {args.command}: error: {exc}\n")
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
