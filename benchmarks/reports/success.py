"""Success rates: the share of runs whose final design leaves the box within the task's tolerance.

A design succeeds when it was usable (``status == "ok"``) and the box ended within the task's
tolerance of the goal (``final_distance <= TaskDefinition.tolerance``), as ``info["success"]``
says in the env. Nothing new is stored for it: a run folder's evaluation log already keeps each
evaluation's ``status`` and ``final_distance``, and its manifest names the task (a config
without ``task_name`` is the push task), so a report of any folder, old or new, shows success
without simulating anything. Where ``final_distance`` is missing the outcome is unknown and is
shown as ``n/a``, never as a failure.

A rate comes with a Wilson score interval: unlike the normal (Wald) interval it stays inside
[0, 1] and is not a point at 0 of n or n of n, which is where small benchmark rates often sit.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

__all__ = [
    "SuccessRate",
    "design_succeeded",
    "run_successes",
    "success_cell",
    "success_rate",
    "success_sentence",
    "task_of_manifest",
    "task_tolerance",
    "wilson_interval",
]


def wilson_interval(successes: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """The Wilson score interval of a binomial proportion.

    Args:
        successes: Successes k, ``0 <= k <= n``.
        n: Trials, >= 0.
        level: Coverage, in (0, 1).

    Returns:
        ``(low, high)`` in [0, 1]; ``low`` is exactly 0 when k = 0 and ``high`` exactly 1 when
        k = n. ``(nan, nan)`` when n = 0 (no trials, no rate).

    Raises:
        ValueError: ``n`` or ``successes`` is not a whole number in range, or ``level`` is not
            in (0, 1).
    """
    from scipy.stats import norm

    for name, value in (("successes", successes), ("n", n)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise ValueError(f"{name} must be a whole number, got {value!r}")
    if n < 0 or not 0 <= successes <= n:
        raise ValueError(f"successes must be in [0, n] with n >= 0, got {successes} of {n}")
    if not (isinstance(level, (int, float)) and 0.0 < level < 1.0):
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    if n == 0:
        return math.nan, math.nan
    z = float(norm.ppf(0.5 + level / 2.0))
    p = successes / n
    scale = 1.0 + z * z / n
    centre = (p + z * z / (2.0 * n)) / scale
    half = z / scale * math.sqrt(p * (1.0 - p) / n + z * z / (4.0 * n * n))
    low = 0.0 if successes == 0 else max(0.0, centre - half)
    high = 1.0 if successes == n else min(1.0, centre + half)
    return low, high


@dataclass(frozen=True)
class SuccessRate:
    """How many runs succeeded, out of those whose outcome is known, with a Wilson interval.

    Attributes:
        successes: Runs whose final design succeeded.
        n: Runs whose outcome is known (``final_distance`` stored, or the design unusable).
        unknown: Runs without a stored ``final_distance`` for their final design.
        rate: ``successes / n``; NaN when n = 0.
        low: Lower bound of the Wilson interval; NaN when n = 0.
        high: Upper bound; NaN when n = 0.
        level: Coverage of the interval.
    """

    successes: int
    n: int
    unknown: int
    rate: float
    low: float
    high: float
    level: float = 0.95


def design_succeeded(status: Any, final_distance: Any, tolerance: float) -> bool | None:
    """Whether one evaluated design succeeded: usable, and the box within ``tolerance`` m.

    Args:
        status: The stored status (``"ok"``, ``"invalid"``, ``"failed"``).
        final_distance: The box's final distance from the goal, m; None or NaN if not stored.
        tolerance: The task's success radius, m.

    Returns:
        False for an unusable or failed design (it never succeeds, as in the env), None when a
        usable design's ``final_distance`` is missing (unknown), else the comparison.
    """
    if status != "ok":
        return False
    if final_distance is None:
        return None
    distance = float(final_distance)
    if not math.isfinite(distance):
        return None
    return distance <= tolerance


def run_successes(evaluations: pd.DataFrame, tolerance: float) -> pd.DataFrame:
    """Whether each run's final design succeeded, from its evaluation rows alone.

    A run's final design is the one its final F is of: its lowest finite F among the rows
    with ``status == "ok"`` (the first such row on a tie, in the log's order). A run without
    one has no usable design and did not succeed.

    Args:
        evaluations: The evaluation log: ``optimizer``, ``seed``, ``free_energy`` (and
            optionally ``suite``, ``variant``, ``status``, ``final_distance``; without
            ``final_distance`` every usable run's outcome is unknown).
        tolerance: The task's success radius, m.

    Returns:
        One row per run with its key columns and ``success``: True, False, or None (unknown).
    """
    keys = [k for k in ("suite", "variant", "optimizer", "seed") if k in evaluations.columns]
    frame = evaluations.reset_index(drop=True)  # positions, whatever index the log came with
    energy = frame["free_energy"].to_numpy(dtype=np.float64)
    usable = np.isfinite(energy)
    if "status" in frame.columns:
        usable &= (frame["status"] == "ok").to_numpy()
    distance = (
        frame["final_distance"].to_numpy(dtype=np.float64)
        if "final_distance" in frame.columns
        else np.full(len(frame), np.nan)
    )
    rows = []
    for key, positions in frame.groupby(keys, sort=True).indices.items():
        key = key if isinstance(key, tuple) else (key,)
        ok = positions[usable[positions]]
        outcome: bool | None = False
        if ok.size:
            best = ok[np.argmin(energy[ok])]  # the first of equal lowest F, in the log's order
            outcome = design_succeeded("ok", distance[best], tolerance)
        rows.append({**dict(zip(keys, key, strict=True)), "success": outcome})
    return pd.DataFrame(rows, columns=[*keys, "success"])


def success_rate(outcomes: Any, level: float = 0.95) -> SuccessRate:
    """The success rate of some runs, with its Wilson interval.

    Args:
        outcomes: One outcome per run: True, False, or None/NaN (unknown, left out of n).
        level: Coverage of the interval.

    Returns:
        The :class:`SuccessRate`.
    """
    values = list(outcomes)
    known = [bool(v) for v in values if v is not None and not _is_nan(v)]
    k, n = sum(known), len(known)
    low, high = wilson_interval(k, n, level)
    rate = k / n if n else math.nan
    return SuccessRate(k, n, len(values) - n, rate, low, high, level)


def _is_nan(value: Any) -> bool:
    return value is pd.NA or (isinstance(value, (float, np.floating)) and math.isnan(value))


def _percent(value: float) -> str:
    return f"{100 * value:.0f} %"


def success_cell(rate: SuccessRate) -> str:
    """A rate as a table cell: ``"40 % (4/10) [17 %, 69 %]"``; ``"n/a"`` when no run is known.

    Runs of unknown outcome are said after it: ``"... (2 run(s) without a final distance)"``.
    """
    if rate.n == 0:
        text = "n/a"
    else:
        text = (
            f"{_percent(rate.rate)} ({rate.successes}/{rate.n}) "
            f"[{_percent(rate.low)}, {_percent(rate.high)}]"
        )
    if rate.unknown:
        text += f" ({rate.unknown} run(s) without a final distance)"
    return text


def success_sentence(task: str, tolerance: float, what: str = "run", level: float = 0.95) -> str:
    """What a report's success column means, in one sentence."""
    return (
        f"Success: the {what}'s final design was usable and left the box within "
        f"{tolerance:g} m of the goal (the {task} task's tolerance), from the stored status and "
        f"final distance; the share of {what}s with a {level:.0%} Wilson interval, n/a where "
        "no final distance was stored."
    )


def task_of_manifest(manifest: Mapping[str, Any] | None) -> str:
    """The task a run folder's runs were scored on, from its manifest's config.

    A config without ``task_name`` (every suite, and every design run of the push task or made
    before tasks existed) is the push task.
    """
    from tooldesign_env.tasks import DEFAULT_TASK

    config = manifest.get("config") if isinstance(manifest, Mapping) else None
    name = config.get("task_name") if isinstance(config, Mapping) else None
    return name if isinstance(name, str) and name else DEFAULT_TASK


def task_tolerance(task: str | None = None) -> float:
    """The success radius of a registered task in m (the push task's by default).

    Raises:
        ValueError: an unknown task (the message lists the known ones).
    """
    from tooldesign_env.tasks import DEFAULT_TASK, get_task

    return float(get_task(DEFAULT_TASK if task is None else task).tolerance)
