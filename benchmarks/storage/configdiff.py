"""The compact diff of two run configs: what a refused resume names, in a few short lines.

A run folder's manifest records the config it was made with (``manifest.json`` ``config``);
:class:`~benchmarks.storage.RunSession` refuses to continue it with another one. The configs
hold long values (a suite's held-out goals, an optimizer's settings, the method configs of the
rl suite), so the refusal names the differing *leaves* by their dotted name (``size.seeds``,
``scene.box_position``), recorded -> requested, shows the first few and counts the rest.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

__all__ = ["ABSENT", "FieldChange", "config_changes", "describe_changes"]

#: Differing fields listed one per line; the rest are only counted.
SHOWN = 4

#: Longest value shown whole, in characters.
BRIEF = 40


class _Absent:
    def __repr__(self) -> str:
        return "(none)"


ABSENT: Any = _Absent()
"""The value of a field one of the two configs does not have."""


@dataclasses.dataclass(frozen=True)
class FieldChange:
    """One leaf of a config that differs between the recorded run and the requested one.

    Attributes:
        field: Dotted name, e.g. ``"size.seeds"`` (``"iterations"`` for a top-level field).
        recorded: Its value in the run folder's manifest (:data:`ABSENT` if it has none).
        requested: Its value in the config asked for now (:data:`ABSENT` if it has none).
    """

    field: str
    recorded: Any
    requested: Any

    def __str__(self) -> str:
        return f"{self.field}: {_change(self.recorded, self.requested)}"


def config_changes(
    recorded: Mapping[str, Any],
    requested: Mapping[str, Any],
    *,
    ignore: Iterable[str] = (),
    allowed: Callable[[str, Any, Any], bool] | None = None,
) -> list[FieldChange]:
    """The leaves that differ between two JSON configs, sorted by dotted name.

    Args:
        recorded: The config the run folder records.
        requested: The config asked for now.
        ignore: Top-level fields that may differ (a run's worker count, say).
        allowed: ``allowed(field, recorded, requested)`` is true for a top-level change that is
            not a difference (a count a later session may raise).

    Returns:
        One :class:`FieldChange` per differing leaf; a leaf is a value that is not a JSON
        object (two lists are compared whole).

    Raises:
        TypeError: If ``recorded`` or ``requested`` is not a mapping, or ``ignore`` a string.
    """
    for name, value in (("recorded", recorded), ("requested", requested)):
        if not isinstance(value, Mapping):
            raise TypeError(f"{name} must be a config (a mapping), got {type(value).__name__}")
    if isinstance(ignore, str):
        raise TypeError(f"ignore must be a list of field names, got {ignore!r}")
    skip = frozenset(ignore)
    found: list[FieldChange] = []
    for key in sorted(recorded.keys() | requested.keys()):
        if key in skip:
            continue
        old, new = recorded.get(key, ABSENT), requested.get(key, ABSENT)
        if old == new or (allowed is not None and allowed(key, old, new)):
            continue
        found += _leaves(old, new, key)
    return found


def _leaves(old: Any, new: Any, name: str) -> list[FieldChange]:
    if isinstance(old, Mapping) and isinstance(new, Mapping):
        found: list[FieldChange] = []
        for key in sorted(old.keys() | new.keys(), key=str):
            found += _leaves(old.get(key, ABSENT), new.get(key, ABSENT), f"{name}.{key}")
        return found
    return [] if old == new else [FieldChange(name, old, new)]


def describe_changes(
    changes: Sequence[FieldChange], *, first: Sequence[str] = (), shown: int = SHOWN
) -> list[str]:
    """The changes as short lines: the first ``shown`` (``first`` fields ahead), then a count.

    Args:
        changes: From :func:`config_changes`.
        first: Dotted names listed before the others, in this order (those a command's options
            set, say); the others follow by name.
        shown: How many changes get a line of their own.

    Returns:
        ``"  field: recorded -> requested"`` lines, and ``"  and N more (a, b, c, ...)"`` if
        some were left out. Every value is JSON, a long one cut to :data:`BRIEF` characters
        or given by its length.

    Raises:
        ValueError: If ``shown`` is not an int >= 1.
    """
    if isinstance(shown, bool) or not isinstance(shown, int) or shown < 1:
        raise ValueError(f"shown must be an int >= 1, got {shown!r}")
    order = {name: i for i, name in enumerate(first)}
    ranked = sorted(changes, key=lambda c: (order.get(c.field, len(order)), c.field))
    lines = [f"  {change}" for change in ranked[:shown]]
    rest = [change.field for change in ranked[shown:]]
    if rest:
        named = ", ".join(rest[:3]) + (", ..." if len(rest) > 3 else "")
        lines.append(f"  and {len(rest)} more ({named})")
    return lines


def _change(before: Any, after: Any) -> str:
    """``before -> after`` in a few words; two lists, one of them long, by their lengths."""
    if isinstance(before, list) and isinstance(after, list):
        if max(len(_json(v)) for v in (before, after)) > BRIEF:
            if len(before) == len(after):
                return f"{len(before)} items, other values"
            return f"[{len(before)} items] -> [{len(after)} items]"
    return f"{_brief(before)} -> {_brief(after)}"


def _brief(value: Any) -> str:
    """A JSON value in at most :data:`BRIEF` characters: a long list by its length."""
    if value is ABSENT:
        return "(none)"
    text = _json(value)
    if len(text) <= BRIEF:
        return text
    if isinstance(value, list):
        return f"[{len(value)} items]"
    return text[: BRIEF - 3] + "..."


def _json(value: Any) -> str:
    try:
        return json.dumps(value)
    except (TypeError, ValueError):  # a manifest holds JSON; a caller's config may not
        return repr(value)
