"""Success rates: the share of runs whose final design left the box standing at the goal.

A design succeeds when it was usable (``status == "ok"``) and the task's whole success test
holds for where the box ended, as ``info["success"]`` says in the env
(``TaskDefinition.succeeded``): within the task's tolerance of the goal (``final_distance <=
tolerance``), its centre's final height within ``height_tolerance`` of its resting height
(``final_height``) and its up axis at most ``max_tilt`` from the vertical (``final_tilt``), so a
box lying or tipped onto a curb within the radius is not a success. The run folder's evaluation
log keeps each evaluation's ``status``, ``final_distance``, ``final_height`` and
``final_tilt``, and its manifest names the task (a config without ``task_name`` is the push
task), so a report shows success without simulating anything.

Folders stored before ``final_height`` and ``final_tilt`` were (a row with neither) are judged
by the distance alone, as they always were: their reports do not change. A usable design whose
``final_distance`` is missing, or whose height and tilt are only half stored or not finite, has
an unknown outcome, shown as ``n/a``, never as a failure.

A rate comes with a Wilson score interval: unlike the normal (Wald) interval it stays inside
[0, 1] and is not a point at 0 of n or n of n, which is where small benchmark rates often sit.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

if TYPE_CHECKING:
    from tooldesign_env.specs import SceneSpec
    from tooldesign_env.tasks import TaskDefinition

__all__ = [
    "SUCCESS_COLUMN",
    "EvaluationSuccesses",
    "SuccessRate",
    "design_succeeded",
    "evaluation_successes",
    "evaluations_success",
    "evaluations_success_text",
    "has_standing",
    "run_successes",
    "scene_of_config",
    "scene_of_manifest",
    "success_cell",
    "success_rate",
    "success_sentence",
    "success_criterion",
    "task_of_manifest",
    "task_tolerance",
    "wilson_interval",
]


#: The evaluation log's column (a design run's, since 2026-11-27) that says whether each
#: evaluated design succeeded: 1.0, 0.0, or NaN (unknown). The results format's extra columns
#: are numbers, so it is not a bool.
SUCCESS_COLUMN = "success"


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


def _stored(value: Any) -> float:
    """A stored number as a float; None, ``pd.NA`` and NaN (not stored) as NaN."""
    if value is None or value is pd.NA:
        return math.nan
    return float(value)


def _radius(criterion: float | TaskDefinition) -> float:
    tolerance = getattr(criterion, "tolerance", criterion)
    if isinstance(tolerance, bool) or not isinstance(tolerance, (int, float, np.number)):
        raise TypeError(f"criterion must be a TaskDefinition or a radius in m, got {criterion!r}")
    return float(tolerance)


def design_succeeded(
    status: Any,
    final_distance: Any,
    criterion: float | TaskDefinition,
    final_height: Any = None,
    final_tilt: Any = None,
    *,
    scene: SceneSpec | None = None,
) -> bool | None:
    """Whether one evaluated design succeeded, as the env's ``info["success"]`` says.

    Args:
        status: The stored status (``"ok"``, ``"invalid"``, ``"failed"``).
        final_distance: The box's final distance from the goal, m; None or NaN if not stored.
        criterion: The task the run was made for (``TaskDefinition``), or a bare radius in m
            (the distance alone; then ``final_height`` and ``final_tilt`` must be None/NaN).
        final_height: The box centre's final height, m; None or NaN if not stored.
        final_tilt: The final angle of the box's up axis from the vertical, rad; None or NaN
            if not stored.
        scene: The run's scene (its box's resting height is half its height), as the env
            built it: the task's scene with the run's overrides (``DesignConfig.task_scene()``,
            :func:`scene_of_manifest`); None is the task's own scene. A run whose ``--scene``
            changed the box's height needs it, or a box standing at the goal reads as not.

    Returns:
        False for an unusable or failed design (it never succeeds, as in the env). For a
        usable one: None (unknown) when ``final_distance`` is missing; with neither height nor
        tilt stored (a row written before they were), ``final_distance <= tolerance``; with
        both finite, the task's whole test (``TaskDefinition.succeeded`` on ``scene``:
        within the radius, standing at its resting height, tilted at most ``max_tilt``); with
        one of them missing or either infinite, None (unknown: the test cannot be applied).

    Raises:
        TypeError: ``criterion`` is neither a task nor a number.
        ValueError: a height or tilt is given with a bare radius (no task to test it by).
    """
    tolerance = _radius(criterion)
    if status != "ok":
        return False
    distance = _stored(final_distance)
    if not math.isfinite(distance):
        return None
    height, tilt = _stored(final_height), _stored(final_tilt)
    if math.isnan(height) and math.isnan(tilt):
        return distance <= tolerance  # stored before the standing columns: as it always was
    if isinstance(criterion, (int, float, np.number)):
        raise ValueError(
            f"a final height ({height}) or tilt ({tilt}) needs the task's test: pass the "
            f"TaskDefinition, not the radius {criterion!r}"
        )
    if not (math.isfinite(height) and math.isfinite(tilt)):
        return None
    return bool(criterion.succeeded(distance, height, scene, final_tilt=tilt))


def has_standing(evaluations: pd.DataFrame) -> bool:
    """Whether an evaluation log stores the box's final height and tilt (any of its rows)."""
    from tooldesign_env.schema import STANDING_COLUMNS

    return all(c in evaluations.columns for c in STANDING_COLUMNS) and bool(
        evaluations[list(STANDING_COLUMNS)].notna().any(axis=None)
    )


def _column(frame: pd.DataFrame, name: str) -> np.ndarray:
    if name in frame.columns:
        return np.asarray(frame[name].to_numpy(dtype=np.float64, na_value=np.nan))
    return np.full(len(frame), np.nan)


def run_successes(
    evaluations: pd.DataFrame,
    criterion: float | TaskDefinition,
    *,
    scene: SceneSpec | None = None,
) -> pd.DataFrame:
    """Whether each run's final design succeeded, from its evaluation rows alone.

    A run's final design is the one its final F is of: its lowest finite F among the rows
    with ``status == "ok"`` (the first such row on a tie, in the log's order). A run without
    one has no usable design and did not succeed.

    Args:
        evaluations: The evaluation log: ``optimizer``, ``seed``, ``free_energy`` (and
            optionally ``suite``, ``variant``, ``status``, ``final_distance``,
            ``final_height``, ``final_tilt``; without ``final_distance`` every usable run's
            outcome is unknown, without the height and tilt the distance alone decides).
        criterion: The task the runs were made for, or a bare radius in m (see
            :func:`design_succeeded`).
        scene: The runs' scene (see :func:`design_succeeded`); None is the task's own.

    Returns:
        One row per run with its key columns and ``success``: True, False, or None (unknown).
    """
    keys = [k for k in ("suite", "variant", "optimizer", "seed") if k in evaluations.columns]
    frame = evaluations.reset_index(drop=True)  # positions, whatever index the log came with
    energy = frame["free_energy"].to_numpy(dtype=np.float64)
    usable = np.isfinite(energy)
    if "status" in frame.columns:
        usable &= (frame["status"] == "ok").to_numpy()
    distance = _column(frame, "final_distance")
    height, tilt = _column(frame, "final_height"), _column(frame, "final_tilt")
    rows = []
    for key, positions in frame.groupby(keys, sort=True).indices.items():
        key = key if isinstance(key, tuple) else (key,)
        ok = positions[usable[positions]]
        outcome: bool | None = False
        if ok.size:
            best = ok[np.argmin(energy[ok])]  # the first of equal lowest F, in the log's order
            outcome = design_succeeded(
                "ok", distance[best], criterion, height[best], tilt[best], scene=scene
            )
        rows.append({**dict(zip(keys, key, strict=True)), "success": outcome})
    return pd.DataFrame(rows, columns=[*keys, "success"])


def evaluation_successes(
    evaluations: pd.DataFrame,
    criterion: float | TaskDefinition,
    *,
    scene: SceneSpec | None = None,
) -> list[bool | None]:
    """Whether each evaluation's design succeeded, one outcome per row, in the log's order.

    A row's stored :data:`SUCCESS_COLUMN` (1 or 0) is its outcome where the log has one; a log
    written before the column existed (or a row of an older session of a resumed run) is judged
    from its stored ``status``, ``final_distance``, ``final_height`` and ``final_tilt`` by
    :func:`design_succeeded`, which is how the column is written.

    Args:
        evaluations: The evaluation log (``status`` and the final pose; see
            :func:`run_successes`).
        criterion: The task the designs were scored on, or a bare radius in m.
        scene: The run's scene (see :func:`design_succeeded`); None is the task's own.

    Returns:
        True, False or None (unknown) per row.

    Raises:
        TypeError: ``evaluations`` is not a DataFrame, or ``criterion`` neither a task nor a
            number.
    """
    if not isinstance(evaluations, pd.DataFrame):
        raise TypeError(
            f"evaluations must be a pandas DataFrame (an evaluation log), got "
            f"{type(evaluations).__name__}"
        )
    _radius(criterion)  # refused here, not only when a row is judged
    frame = evaluations.reset_index(drop=True)
    status = frame["status"].tolist() if "status" in frame.columns else ["ok"] * len(frame)
    distance = _column(frame, "final_distance")
    height, tilt = _column(frame, "final_height"), _column(frame, "final_tilt")
    stored = _column(frame, SUCCESS_COLUMN)
    out: list[bool | None] = []
    for i in range(len(frame)):
        if stored[i] in (0.0, 1.0):
            out.append(bool(stored[i]))
        else:
            out.append(
                design_succeeded(status[i], distance[i], criterion, height[i], tilt[i], scene=scene)
            )
    return out


@dataclass(frozen=True)
class EvaluationSuccesses:
    """How many evaluations of a run succeeded, and the lowest-F one that did.

    Attributes:
        successes: Evaluations whose design succeeded.
        n: Evaluations whose outcome is known.
        unknown: Evaluations whose outcome is not stored (no final distance, or half a pose).
        best: The succeeding row with the lowest F (the first in the log's order on a tie), or
            None when none succeeds.
    """

    successes: int
    n: int
    unknown: int
    best: pd.Series | None


def evaluations_success(
    evaluations: pd.DataFrame,
    criterion: float | TaskDefinition,
    *,
    scene: SceneSpec | None = None,
) -> EvaluationSuccesses:
    """The evaluations of a run that succeed (:func:`evaluation_successes`), counted.

    A lower F is not a success: in every built-in task but push the lowest-F design of a run
    leaves the box off the goal while many other evaluations succeed (docs/tasks.md), so a
    run's report names the lowest-F design that does succeed too.

    Raises:
        TypeError: as :func:`evaluation_successes`.
        ValueError: the log has no ``free_energy`` column.
    """
    outcomes = evaluation_successes(evaluations, criterion, scene=scene)
    if "free_energy" not in evaluations.columns:
        raise ValueError(
            "evaluations must have a 'free_energy' column (the evaluation log's F), got columns "
            f"{list(evaluations.columns)}"
        )
    frame = evaluations.reset_index(drop=True)
    known = [o for o in outcomes if o is not None]
    hits = np.array([o is True for o in outcomes], dtype=bool)
    best = None
    if hits.any():
        energy = frame["free_energy"].to_numpy(dtype=np.float64)
        candidates = np.flatnonzero(hits & np.isfinite(energy))
        if candidates.size:
            best = frame.iloc[int(candidates[np.argmin(energy[candidates])])]
    return EvaluationSuccesses(sum(known), len(known), len(outcomes) - len(known), best)


def evaluations_success_text(summary: EvaluationSuccesses, degree: int | None = None) -> str:
    """How many of a run's evaluations succeed, and its lowest-F succeeding design, in one line.

    ``"k of n evaluations succeed; the lowest-F succeeding design C = (...) (iteration i,
    candidate j), F = ..., ends ... m from the goal"``, or ``"k of n ...; none succeeds"``.

    Args:
        summary: :func:`evaluations_success` of the run.
        degree: The number of coefficients ``c1..cn`` to show; None reads every ``c<i>`` column
            of the row.

    Raises:
        TypeError: ``summary`` is not an :class:`EvaluationSuccesses`.
        ValueError: ``degree`` is not a whole number >= 1 or None.
    """
    from tooldesign_env.schema import COEFFICIENT_PATTERN

    if not isinstance(summary, EvaluationSuccesses):
        raise TypeError(
            f"summary must be an EvaluationSuccesses (evaluations_success's), got "
            f"{type(summary).__name__}"
        )
    if degree is not None and (
        isinstance(degree, bool) or not isinstance(degree, int) or degree < 1
    ):
        raise ValueError(f"degree must be a whole number >= 1 or None, got {degree!r}")
    text = f"{summary.successes} of {summary.n} evaluations succeed"
    if summary.unknown:
        text += f" ({summary.unknown} more with no stored outcome)"
    if summary.best is None:
        return text + ("; none succeeds" if summary.n else "")
    row = summary.best
    names = (
        [f"c{i + 1}" for i in range(degree)]
        if degree is not None
        else sorted(
            (c for c in row.index if isinstance(c, str) and COEFFICIENT_PATTERN.fullmatch(c)),
            key=lambda c: int(c[1:]),
        )
    )
    coeffs = ", ".join(f"{float(row[c]):.4g}" for c in names)
    where = ""
    if "iteration" in row.index and "candidate" in row.index:
        where = f" (iteration {int(row['iteration'])}, candidate {int(row['candidate'])})"
    return (
        f"{text}; the lowest-F succeeding design C = ({coeffs}){where}, "
        f"F = {float(row['free_energy']):.6g}, ends {float(row['final_distance']):.3f} m from "
        "the goal"
    )


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


def success_sentence(
    task: str,
    tolerance: float,
    what: str = "run",
    level: float = 0.95,
    *,
    standing: bool = False,
) -> str:
    """What a report's success column means, in one sentence.

    ``standing``: the evaluations store the box's final height and tilt, so success is the
    task's whole test; without them (folders stored before) it is the distance alone, and the
    sentence is the one those folders' reports always had.
    """
    if not standing:
        return (
            f"Success: the {what}'s final design was usable and left the box within "
            f"{tolerance:g} m of the goal (the {task} task's tolerance), from the stored status "
            f"and final distance; the share of {what}s with a {level:.0%} Wilson interval, n/a "
            "where no final distance was stored."
        )
    return (
        f"Success: the {what}'s final design was usable and left the box standing within "
        f"{tolerance:g} m of the goal (the {task} task's test: tolerance, resting height and "
        f"tilt), from the stored status, final distance, height and tilt (the distance alone "
        f"for rows stored without them); the share of {what}s with a {level:.0%} Wilson "
        "interval, n/a where the outcome was not stored."
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


def scene_of_config(config: Mapping[str, Any] | None) -> SceneSpec | None:
    """The scene a stored run config's designs were scored in, or None for the task's own.

    A design run's or a suite's config (its manifest's ``config``) stores ``task_name`` (none:
    push) and ``scene``, the ``SceneSpec`` fields it overrides; the env built the task's scene
    with them (``DesignConfig.task_scene()``). Reports pass it to :func:`design_succeeded`, so
    that a run whose scene changed the box's height is judged as its env judged it.

    Raises:
        ValueError: an unknown task (the message lists the known ones), or a stored scene the
            spec refuses.
    """
    import dataclasses

    from benchmarks.design.config import scene_overrides

    if not isinstance(config, Mapping):
        return None
    stored = config.get("scene")
    if not stored:
        return None
    overrides = dict(scene_overrides(stored))
    return dataclasses.replace(
        success_criterion(task_of_manifest({"config": config})).scene, **overrides
    )


def scene_of_manifest(manifest: Mapping[str, Any] | None) -> SceneSpec | None:
    """:func:`scene_of_config` of a run folder's manifest (its ``config``)."""
    config = manifest.get("config") if isinstance(manifest, Mapping) else None
    return scene_of_config(config if isinstance(config, Mapping) else None)


def success_criterion(task: str | None = None) -> TaskDefinition:
    """The registered task whose success test judges a run's design (push by default).

    Raises:
        ValueError: an unknown task (the message lists the known ones).
    """
    from tooldesign_env.tasks import DEFAULT_TASK, get_task

    return get_task(DEFAULT_TASK if task is None else task)


def task_tolerance(task: str | None = None) -> float:
    """The success radius of a registered task in m (the push task's by default).

    Raises:
        ValueError: an unknown task (the message lists the known ones).
    """
    from tooldesign_env.tasks import DEFAULT_TASK, get_task

    return float(get_task(DEFAULT_TASK if task is None else task).tolerance)
