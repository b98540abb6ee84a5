"""Argument types and checks shared by the perf scripts: a bad value is an argparse error naming it.

A script imports them as ``from perf import _args`` (the scripts run as modules from the
repository's root: ``python -m perf.speed.SCRIPT``, see ``perf/__init__.py``). Each type
returns a function for ``add_argument(type=...)`` that raises ``argparse.ArgumentTypeError``, so
argparse prints ``SCRIPT.py: error: argument --NAME: must be ..., got 'VALUE'`` and exits with
code 2 before anything is measured. :func:`check_scene` checks ``--scene``'s fields together,
after parsing, the same way.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from tooldesign_env import SceneSpec


def count(low: int = 1, high: int | None = None, why: str = "") -> Callable[[str], int]:
    """An argparse type: an int from ``low`` to ``high`` (no upper bound for None).

    ``why`` is added to the message, e.g. ``" (a spread needs two scenes)"``.
    """
    allowed = f"an int >= {low}" if high is None else f"an int from {low} to {high}"

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {allowed}{why}, got {text!r}") from None
        if value < low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"must be {allowed}{why}, got {text!r}")
        return value

    return parse


#: An argparse type for a seed of NumPy's generators and of ``env.reset``: an int >= 0.
seed = count(0)


def number(
    low: float = -math.inf,
    high: float = math.inf,
    *,
    above: bool = False,
    unit: str = "",
) -> Callable[[str], float]:
    """An argparse type: a finite number from ``low`` to ``high``, in ``unit``.

    With ``above``, ``low`` itself is refused (a number > ``low``). NaN and infinities are
    always refused.
    """
    bounds: list[str] = []
    if not math.isinf(low):
        bounds.append(f"{'>' if above else '>='} {low:g}")
    if not math.isinf(high):
        bounds.append(f"<= {high:g}")
    allowed = " ".join(part for part in ("a finite number", " and ".join(bounds), unit) if part)

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        inside = low < value if above else low <= value
        if not (math.isfinite(value) and inside and value <= high):
            raise argparse.ArgumentTypeError(f"must be {allowed}, got {text!r}")
        return value

    return parse


def check_scene(
    parser: argparse.ArgumentParser,
    args: argparse.Namespace,
    fixed: Mapping[str, str] | None = None,
) -> SceneSpec:
    """The ``SceneSpec`` of ``--scene`` (``physics_options.add_scene_option``), checked.

    Exits through ``parser.error`` (code 2) with ``--scene FIELD=...: WHY`` for a field of
    ``fixed`` (a field the script sets itself, mapped to why), and with ``--scene: ERROR`` when
    ``SceneSpec`` refuses the values.
    """
    from tooldesign_env import SceneSpec  # not at import: the argument types load no simulator

    fields = dict(args.scene)
    for name, why in (fixed or {}).items():
        if name in fields:
            parser.error(f"--scene {name}=...: {why}")
    try:
        return SceneSpec(**fields)
    except (TypeError, ValueError) as error:
        parser.error(f"--scene: {error}")
