"""How the command line shows warnings: one ``tooldesign COMMAND: warning: MESSAGE`` line each.

Python writes a warning as ``/path/to/file.py:352: UserWarning: MESSAGE`` followed by the line of
source that raised it: useful to a programmer, noise to someone who typed a command. The library
keeps raising real warnings (:func:`warnings.warn`); only the command line changes how a warning
it shows is written. This module imports nothing but the standard library, so that
``tooldesign --help`` stays fast.
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Iterator

__all__ = ["warning_line", "warnings_as_lines"]


def warning_line(prog: str, message: Warning | str) -> str:
    """``PROG: warning: MESSAGE``, ending with a newline, as the command line prints a warning."""
    return f"{prog}: warning: {message}\n"


@contextlib.contextmanager
def warnings_as_lines(prog: str) -> Iterator[None]:
    """Within the block, write each warning shown as :func:`warning_line`'s line.

    Only the format changes (through :data:`warnings.formatwarning`): which warnings are shown
    (the filters, ``python -W``), where they go (stderr), ``warnings.catch_warnings(record=True)``
    and ``pytest.warns`` are as before, and the previous format is back after the block.

    Args:
        prog: what starts the line, e.g. ``"tooldesign design"``.
    """
    previous = warnings.formatwarning

    def one_line(
        message: Warning | str,
        category: type[Warning],
        filename: str,
        lineno: int,
        line: str | None = None,
    ) -> str:
        return warning_line(prog, message)

    warnings.formatwarning = one_line
    try:
        yield
    finally:
        warnings.formatwarning = previous
