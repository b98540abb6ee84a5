"""How the command line shows warnings: one ``tooldesign COMMAND: warning: MESSAGE`` line each.

Python writes a warning as ``/path/to/file.py:352: UserWarning: MESSAGE`` followed by the line of
source that raised it: useful to a programmer, noise to someone who typed a command. The library
keeps raising real warnings (:func:`warnings.warn`); only the command line changes how a warning
it shows is written. This module imports nothing but the standard library, so that
``tooldesign --help`` stays fast.

Worker processes of a local process pool (forkserver or spawn) do not inherit the parent's
:data:`warnings.formatwarning`. The format installed here therefore carries its prefix as a
``line_prefix`` attribute, which :func:`benchmarks.execution.make_executor` reads without
importing this module and hands to each worker, which writes its warnings as the same one line.
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Iterator

__all__ = ["OneLineFormat", "warning_line", "warnings_as_lines"]


def warning_line(prog: str, message: Warning | str) -> str:
    """``PROG: warning: MESSAGE``, ending with a newline, as the command line prints a warning."""
    return f"{prog}: warning: {message}\n"


class OneLineFormat:
    """A :data:`warnings.formatwarning` that writes :func:`warning_line`'s line.

    Attributes:
        line_prefix: What starts the line (``"tooldesign design"``); process-pool workers read
            it from the parent's format (see the module's docstring).
    """

    def __init__(self, prog: str) -> None:
        self.line_prefix = prog

    def __call__(
        self,
        message: Warning | str,
        category: type[Warning],
        filename: str,
        lineno: int,
        line: str | None = None,
    ) -> str:
        return warning_line(self.line_prefix, message)


@contextlib.contextmanager
def warnings_as_lines(prog: str) -> Iterator[None]:
    """Within the block, write each warning shown as :func:`warning_line`'s line.

    Only the format changes (through :data:`warnings.formatwarning`): which warnings are shown
    (the filters, ``python -W``), where they go (stderr), ``warnings.catch_warnings(record=True)``
    and ``pytest.warns`` are as before, and the previous format is back after the block. The
    workers of a process pool made within the block (:func:`benchmarks.execution.make_executor`)
    write their warnings as the same line; Dask workers keep Python's format.

    Args:
        prog: what starts the line, e.g. ``"tooldesign design"``.
    """
    previous = warnings.formatwarning
    warnings.formatwarning = OneLineFormat(prog)
    try:
        yield
    finally:
        warnings.formatwarning = previous
