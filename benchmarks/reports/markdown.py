"""Markdown that the reports and the docs' generated blocks share (text in, text out).

- :func:`markdown_table`: a table's lines, its cells escaped so that a ``|`` or a line break in
  a value cannot break the table.
- :func:`block_markers`, :func:`current_block` and :func:`replace_block`: the part of a page
  between ``<!-- NAME:start -->`` and ``<!-- NAME:end -->`` that a command writes from
  measured numbers (``tooldesign readme`` into ``README.md`` and ``docs/index.md``,
  ``python -m benchmarks.cli.rl_page`` into ``docs/rl.md``); the rest of the page is prose.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

__all__ = ["block_markers", "current_block", "markdown_table", "replace_block"]


def markdown_table(header: Sequence[Any], rows: Iterable[Sequence[Any]]) -> list[str]:
    """The lines of a Markdown table: the header, the rule, a line per row.

    Args:
        header: The column names.
        rows: The cells of each row, in the header's order (any value; shown with ``str``).

    Returns:
        The table's lines, without newlines.
    """

    def cell(value: Any) -> str:
        return str(value).replace("|", "\\|").replace("\n", " ")

    lines = ["| " + " | ".join(cell(h) for h in header) + " |"]
    lines.append("|" + "|".join("---" for _ in header) + "|")
    lines += ["| " + " | ".join(cell(c) for c in row) + " |" for row in rows]
    return lines


def block_markers(name: str) -> tuple[str, str]:
    """The start and end markers of the generated block ``name`` (HTML comments)."""
    return f"<!-- {name}:start -->", f"<!-- {name}:end -->"


def _split(text: str, name: str) -> tuple[str, str, str]:
    start, end = block_markers(name)
    if text.count(start) != 1 or text.count(end) != 1:
        raise ValueError(f"expected exactly one {start} and one {end}")
    head, rest = text.split(start)
    if end not in rest:
        raise ValueError(f"{end} comes before {start}")
    body, tail = rest.split(end)
    return head, body, tail


def current_block(text: str, name: str) -> str:
    """The text between block ``name``'s markers (exclusive, without the newline after start).

    Raises:
        ValueError: The markers are missing, repeated or out of order.
    """
    return _split(text, name)[1].removeprefix("\n")


def replace_block(text: str, name: str, block: str) -> str:
    """``text`` with the part between block ``name``'s markers replaced by ``block``.

    Raises:
        ValueError: The markers are missing, repeated or out of order.
    """
    head, _, tail = _split(text, name)
    start, end = block_markers(name)
    return f"{head}{start}\n{block}{end}{tail}"
