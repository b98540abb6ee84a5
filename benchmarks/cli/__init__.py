"""The ``tooldesign`` command line: the one place where arguments are parsed.

Each subcommand lives in its own module and adds its own arguments through ``add_parser``; this
file only dispatches. Those modules import PyBullet, SciPy, pandas and Matplotlib, which take
seconds, so only the module of the command being run is imported: ``tooldesign --help`` and
``tooldesign --version`` import none of them.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import pickle
import signal
import sys
import threading
from collections.abc import Iterator, Sequence
from typing import NoReturn

from benchmarks.cli._warnings import warnings_as_lines

__all__ = ["COMMANDS", "build_parser", "main"]

#: Every subcommand: its module (which defines ``add_parser``) and its one-line help. The help is
#: repeated here so that the top-level ``--help`` need not import the module.
COMMANDS: dict[str, tuple[str, str]] = {
    "evaluate": (
        "benchmarks.cli.evaluate",
        "evaluate given coefficients: terms, trajectories, mesh and plots",
    ),
    "design": (
        "benchmarks.cli.design",
        "design a tool: ask/evaluate/tell for K iterations (Algorithm 1)",
    ),
    "bench": (
        "benchmarks.cli.bench",
        "run a benchmark suite (optimizers, precision-sweep, robustness, ...)",
    ),
    "retest": (
        "benchmarks.cli.retest",
        "measure the noise floor (and robustness over ranges) of a suite's final designs",
    ),
    "report": (
        "benchmarks.cli.report",
        "rebuild the figures and tables of a run folder from its stored results",
    ),
    "html": (
        "benchmarks.cli.html",
        "write a self-contained HTML report (figures, tables, card, video) of a run folder",
    ),
    "dense-search": (
        "benchmarks.cli.dense_search",
        "evaluate a regular grid of designs (the yardstick for the optimizers)",
    ),
    "reproduce": (
        "benchmarks.cli.reproduce",
        "rebuild the committed suites' reports and write docs/reproduction.md",
    ),
    "rl": (
        "benchmarks.cli.rl",
        "RL baselines on ToolDesignRL-v0: the rl suite, tuning probes, saved policies",
    ),
    "equivalence": (
        "benchmarks.cli.equivalence",
        "accept or reject a change to the simulation or F by the equivalence rule",
    ),
    "readme": (
        "benchmarks.cli.readme",
        "regenerate the README's pictures and numbers (a design run of minutes)",
    ),
}


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("tooldesign")
    except PackageNotFoundError:  # run from a source tree that was never pip-installed
        return "unknown (not installed)"


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser.

    Args:
        command: build the full arguments of this subcommand only (the others get a stub that
            carries their help line); None builds every subcommand in full.

    Raises:
        ValueError: ``command`` is not a subcommand.
    """
    if command is not None and command not in COMMANDS:
        raise ValueError(f"unknown command {command!r}; choose from {', '.join(COMMANDS)}")
    return _parser(set(COMMANDS) if command is None else {command})


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (exit code 2), as the command's own are."""

    def error(self, message: str) -> NoReturn:
        """Print ``PROG: error: MESSAGE`` and where the usage is on one line; exit with 2."""
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _parser(full: set[str]) -> argparse.ArgumentParser:
    # Subparsers are made with the class of their parent, so every command's errors are one line.
    parser = _Parser(
        prog="tooldesign",
        description="Design robot hand tools with control confidence (ToolDesign-v0).",
    )
    parser.add_argument("--version", action="version", version=f"tooldesign {_version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, (module, help_line) in COMMANDS.items():
        if name in full:
            importlib.import_module(module).add_parser(sub)
        else:
            sub.add_parser(name, help=help_line)
    return parser


def _command_in(argv: Sequence[str]) -> str | None:
    """The subcommand named in ``argv``: its first word that does not start with '-'."""
    for word in argv:
        if not word.startswith("-"):
            return word if word in COMMANDS else None
    return None


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code.

    A warning is shown as one ``tooldesign COMMAND: warning: MESSAGE`` line on stderr, not in
    Python's format (the file, the line number, the category and a line of source).
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    command = _command_in(argv)
    with warnings_as_lines(f"tooldesign {command}" if command else "tooldesign"):
        return _main(argv, command)


#: How to go on with a command that was stopped, after what it stored.
_RESUME = {
    "design": "; continue with the same command and --resume",
    "bench": "; run the same command again: it resumes",
    "retest": "; run the same command again: it resumes",
}


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread as Ctrl-C is, so that a run stops the same way."""


@contextlib.contextmanager
def _terminate_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM (``kill``, a batch system's time limit) stops as Ctrl-C does.

    The run then shuts its workers down and closes its folder as on Ctrl-C, and the command
    says how to go on (its exit code is still 143). Without this, SIGTERM ended the process
    at once, without a word, and left the pool's semaphores to the resource tracker. Only in
    the main thread of this process, and only where SIGTERM has its default action.
    """
    main_thread = threading.current_thread() is threading.main_thread()
    if not main_thread or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        yield
        return
    pid = os.getpid()

    def terminate(signum: int, frame: object) -> None:
        if os.getpid() != pid:  # a child forked while this was set: the default action
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
            os.kill(os.getpid(), signal.SIGTERM)
            return
        raise Terminated

    signal.signal(signal.SIGTERM, terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _main(argv: list[str], command: str | None) -> int:
    # With no known command, the stubs are enough: argparse prints the help, the version or the
    # "invalid choice" error without importing any subcommand module.
    parser = _parser(set() if command is None else {command})
    args = parser.parse_args(argv)
    try:
        with _terminate_as_interrupt():
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
    except KeyboardInterrupt as exc:
        # What is stored stays: say how to go on from it.
        resume = _RESUME
        stopped = "terminated (SIGTERM)" if isinstance(exc, Terminated) else "interrupted"
        print(f"{stopped}{resume.get(args.command, '')}", file=sys.stderr)
        return 128 + signal.SIGTERM if isinstance(exc, Terminated) else 130
    except RuntimeError as exc:
        from benchmarks.design.stepper import NothingEvaluated
        from benchmarks.execution.errors import ClusterMismatch
        from optimizers import PluginError

        # A third-party optimizer failed (its message names the plugin and the hook), a worker
        # of the Dask cluster runs other code (the message names it and the difference), or no
        # evaluation of a run succeeded (the message points to the log, which says why).
        if not isinstance(exc, (PluginError, ClusterMismatch, NothingEvaluated)):
            raise
        parser.exit(1, f"tooldesign {args.command}: error: {exc}\n")
    except BaseException as exc:
        from benchmarks.execution.errors import ClusterLost

        if not isinstance(exc, ClusterLost):
            raise
        stored = (
            f"nothing of the unfinished batches was stored{_RESUME[args.command]} on a working "
            "cluster"
            if args.command in _RESUME
            else "nothing was stored: run the command again on a working cluster"
        )
        parser.exit(
            1, f"tooldesign {args.command}: error: the Dask cluster went away ({exc}); {stored}\n"
        )
