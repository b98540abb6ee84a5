"""The equivalence rule: when a change to the simulation or the objective is accepted.

Pushing is chaotic, so bit-for-bit identity is both too strict (another CPU gives other last
bits) and not what users need: results that do not move beyond the noise floor. The rule
(issue 31, ``docs/performance.md``, "The equivalence rule"):

A change is accepted when, on a fixed, committed set of designs (:data:`REFERENCE`):

1. at least 90 % of the designs have ``|F - F_ref|`` within that design's noise floor: the range
   (max - min) of its F over the standard nudged scenes (the nominal scene and ``scenes - 1``
   nudges of the box's start, within 0.1 mm and 1e-4 rad, as ``tooldesign retest`` draws them);
2. the mean over designs of the relative change ``(F - F_ref) / |F_ref|`` has a 95 % t interval
   inside plus or minus half the median relative noise floor;
3. the smoke suites' verdicts and rankings do not change
   (:mod:`benchmarks.reports.verdicts`).

This module does 1 and 2: :func:`record` draws the design set, evaluates every design in every
nudged scene through the project's process pool and returns the reference (written with
:func:`write_reference`); :func:`check` evaluates the designs once, in the nominal scene, with the
code as it is now and compares (:func:`compare`). Commands: ``tooldesign equivalence record``
and ``tooldesign equivalence check``.

A design that is invalid in one of its nudged scenes has no range to measure: its outcome
changed by more than any range, so its floor is unbounded (stored as ``null``), the worst case
that ``tooldesign retest`` documents, and it counts in the median as a floor above every
measured one.

Why 16 scenes and not retest's 5: the range of 5 draws covers a sixth, independent draw (what a
change as small as a nudge gives) for only 85-86 % of designs (normal or heavy-tailed spreads),
so a change of nudge size would pass test 1 only 15-21 % of the time on 64 designs. The range
of 16 covers it for 97-98 %, and such a change passes 1 more than 99 % of the time.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import json
import math
import os
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.execution import make_executor, map_robust
from benchmarks.storage import (
    atomic_write_text,
    finite_number,
    git_commit,
    git_dirty,
    json_text,
    package_versions,
    platform_id,
    short_repr,
)
from benchmarks.suites.retest import RetestConfig
from tooldesign_env.schema import (
    DEFAULT_BOX_MASS,
    DEFAULT_GOAL,
    DEFAULT_GOAL_PRECISION,
    METRICS,
)

__all__ = [
    "DESIGNS_MIN",
    "LEVEL",
    "REFERENCE",
    "REFERENCE_VERSION",
    "TASKS",
    "WITHIN_FRACTION",
    "Comparison",
    "DesignSetSpec",
    "EquivalenceTask",
    "calibration",
    "check",
    "compare",
    "evaluate",
    "format_comparison",
    "median_relative_floor",
    "read_reference",
    "record",
    "write_reference",
]

#: The committed reference: the design set, its nominal results and its noise floors.
REFERENCE = Path(__file__).with_name("equivalence-reference.json")
REFERENCE_VERSION = 1
#: The rule's constants (issue 31).
DESIGNS_MIN = 64
WITHIN_FRACTION = 0.9
LEVEL = 0.95
#: The bound on the mean relative change, as a fraction of the median relative noise floor.
MEAN_BOUND_FRACTION = 0.5

#: Named designs of the cubic: the straight tool, a hook, and three that touch the box in
#: different ways (those of ``tests/test_perf_bit_identical.py``).
NAMED_DESIGNS: tuple[tuple[str, tuple[float, ...]], ...] = (
    ("straight", (0.0, 0.0, 0.0)),
    ("hook", (0.0, 1.5, 0.0)),
    ("perf-3", (0.3, -0.7, 0.2)),
    ("perf-4", (-1.1, 0.4, -0.3)),
    ("perf-5", (0.9, 1.2, 0.45)),
)


@dataclasses.dataclass(frozen=True, kw_only=True)
class EquivalenceTask:
    """A task the designs are scored on: the env and its task settings.

    Only pushing exists today; a new task (another env id, goal or objective) joins the set by
    a new entry of :data:`TASKS` and a new reference.

    Attributes:
        name: The task's name in the reference file.
        env_id: The registered Gymnasium id of the env.
        goal: X^g, (x, y, z) in m.
        goal_precision: p^X, 1/m^2.
        box_mass: kg.
        estimator: How dX/dU is estimated (``ObjectiveSpec.estimator``).
    """

    name: str
    env_id: str = "ToolDesign-v0"
    goal: tuple[float, float, float] = DEFAULT_GOAL
    goal_precision: float = DEFAULT_GOAL_PRECISION
    box_mass: float = DEFAULT_BOX_MASS
    estimator: str = "contact"

    def to_json(self) -> dict[str, Any]:
        """The task as plain JSON types."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["goal"] = list(self.goal)
        return out


#: The tasks the rule knows, by name.
TASKS: dict[str, EquivalenceTask] = {"push": EquivalenceTask(name="push")}


@dataclasses.dataclass(frozen=True, kw_only=True)
class DesignSetSpec:
    """How the fixed design set is drawn and how its noise floors are measured.

    Attributes:
        seed: Root seed of the random designs (``SeedSequence(seed).spawn``, one per degree).
        random_designs: ``(degree, count)`` pairs: designs drawn uniformly in
            ``default_bounds(degree)``; one valid in the nominal scene is kept, an invalid one
            is replaced by the next draw.
        named: Whether the :data:`NAMED_DESIGNS` (cubic) are in the set.
        tasks: Names of :data:`TASKS` every design is scored on.
        scenes: Scenes per design for the noise floor: the nominal one and ``scenes - 1``
            nudges (2 to 100).
        shift: Largest change of the box's start position in a nudge, m.
        turn: Largest change of the box's start yaw in a nudge, rad.
        nudge_seed: Seed of the nudges (as ``RetestConfig.seed``).
    """

    seed: int = 31
    random_designs: tuple[tuple[int, int], ...] = ((3, 27), (5, 20), (8, 20))
    named: bool = True
    tasks: tuple[str, ...] = ("push",)
    scenes: int = 16
    shift: float = 1e-4
    turn: float = 1e-4
    nudge_seed: int = 0

    def __post_init__(self) -> None:
        from tooldesign_env.geometry.tool import DEGREE_MAX

        low, high = 1, DEGREE_MAX
        for name in ("seed", "scenes", "nudge_seed"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise ValueError(f"DesignSetSpec.{name} must be an int >= 0, got {value!r}")
        try:
            pairs = tuple(tuple(p) for p in self.random_designs)
        except TypeError:
            pairs = ((),)  # not pairs: refused below, naming the field
        for pair in pairs:
            ok = len(pair) == 2 and all(
                isinstance(v, int) and not isinstance(v, bool) for v in pair
            )
            if not ok or not low <= pair[0] <= high or pair[1] < 0:
                raise ValueError(
                    f"DesignSetSpec.random_designs must be (degree {low:g} to {high:g}, "
                    f"count >= 0) pairs, got {self.random_designs!r}"
                )
        object.__setattr__(self, "random_designs", pairs)
        unknown = [t for t in self.tasks if t not in TASKS]
        if not self.tasks or unknown:
            raise ValueError(
                f"DesignSetSpec.tasks must be one or more of {sorted(TASKS)}, got {self.tasks!r}"
            )
        object.__setattr__(self, "tasks", tuple(self.tasks))
        # RetestConfig checks scenes (its nudges), shift and turn, and names the field.
        self.nudges()

    def nudges(self) -> RetestConfig:
        """The nudges, as the retest draws them."""
        return RetestConfig(
            nudges=self.scenes, shift=self.shift, turn=self.turn, seed=self.nudge_seed
        )

    def to_json(self) -> dict[str, Any]:
        """The settings as plain JSON types."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["random_designs"] = [list(p) for p in self.random_designs]
        out["tasks"] = list(self.tasks)
        return out


@dataclasses.dataclass(frozen=True, kw_only=True)
class _Chunk:
    """Designs of one task and degree to evaluate in one scene, in a worker."""

    task: EquivalenceTask
    degree: int
    designs: tuple[tuple[float, ...], ...]
    scene_index: int
    config: RetestConfig | None
    changes: tuple[tuple[str, Any], ...] = ()


def _evaluate_chunk(chunk: _Chunk) -> list[dict[str, Any]]:
    """F, its terms and validity of each design of ``chunk``; runs in a worker.

    The env is made for the chunk and closed after it (not the evaluator's cache, which would
    keep one env per scene and degree alive in every worker).
    """
    import gymnasium as gym

    import tooldesign_env  # noqa: F401  (registers the envs)
    from tooldesign_env import ToolSpec
    from tooldesign_env.tasks import DEFAULT_TASK, get_task

    changes = dict(chunk.changes)
    # The nudges start from the scene of the task the id makes (push's default for ToolDesign-v0).
    own_task = changes.get("task", gym.spec(chunk.task.env_id).kwargs.get("task", DEFAULT_TASK))
    base = changes.pop("scene", None) or get_task(own_task).scene
    scene = base if chunk.config is None else chunk.config.scenes(base)[chunk.scene_index]
    tool = dataclasses.replace(changes.pop("tool", None) or ToolSpec(), degree=chunk.degree)
    kwargs: dict[str, Any] = {
        "goal_precision": chunk.task.goal_precision,
        "estimator": chunk.task.estimator,
        **changes,
    }
    env = gym.make(chunk.task.env_id, tool=tool, scene=scene, **kwargs)
    try:
        env.reset(options={"goal": chunk.task.goal, "box_mass": chunk.task.box_mass})
        rows = []
        for coeffs in chunk.designs:
            info = env.step(np.asarray(coeffs, dtype=np.float64))[4]
            row: dict[str, Any] = {name: float(info[name]) for name in METRICS}
            row["valid"] = bool(info["valid"])
            row["invalid_reason"] = str(info.get("invalid_reason", ""))
            rows.append(row)
        return rows
    finally:
        env.close()


def _check_changes(changes: Mapping[str, Any] | None) -> tuple[tuple[str, Any], ...]:
    if changes is None:
        return ()
    if not isinstance(changes, Mapping):
        raise TypeError(f"changes must be a mapping of env keyword arguments, got {changes!r}")
    clash = set(changes) & {"goal", "box_mass", "bounds"}
    if clash:
        raise ValueError(f"changes must not set {sorted(clash)}: they are the task's")
    return tuple(sorted((str(k), v) for k, v in changes.items()))


#: Designs per submitted chunk: small enough to spread a degree over the workers.
_CHUNK = 8


def evaluate(
    designs: Sequence[Mapping[str, Any]],
    *,
    scenes: Sequence[int] = (0,),
    config: RetestConfig | None = None,
    changes: Mapping[str, Any] | None = None,
    executor: Executor | None = None,
    workers: int | None = None,
) -> list[list[dict[str, Any]]]:
    """Evaluate designs in some of their nudged scenes.

    Args:
        designs: Each with ``task`` (a name of :data:`TASKS`), ``degree`` and
            ``coefficients``.
        scenes: Indices of the scenes of ``config.scenes(...)`` (0: the nominal scene).
        config: The nudges; None: the nominal scene only (``scenes`` must be ``(0,)``).
        changes: Keyword arguments of the env that replace the default (a ``scene`` is the
            nominal scene the nudges start from; a ``tool``'s degree is the design's): how a
            changed simulation or objective is tried without editing the code.
        executor: Where to run; a process pool of ``workers`` if None.
        workers: Worker processes of the default pool.

    Returns:
        Per design, one row per scene of ``scenes``: ``free_energy``, ``goal_error``,
        ``confidence``, ``final_distance``, ``valid`` and ``invalid_reason``.

    Raises:
        RuntimeError: If a worker failed (the message names the design and the error).
    """
    pairs = _check_changes(changes)
    if config is None and tuple(scenes) != (0,):
        raise ValueError(f"scenes other than the nominal one need a config, got {scenes!r}")
    groups: dict[tuple[str, int], list[int]] = {}
    for i, design in enumerate(designs):
        groups.setdefault((design["task"], int(design["degree"])), []).append(i)
    chunks: list[tuple[list[int], int, _Chunk]] = []
    for (task, degree), indices in groups.items():
        for begin in range(0, len(indices), _CHUNK):
            part = indices[begin : begin + _CHUNK]
            coeffs = tuple(tuple(float(c) for c in designs[i]["coefficients"]) for i in part)
            for k, scene in enumerate(scenes):
                chunk = _Chunk(
                    task=TASKS[task],
                    degree=degree,
                    designs=coeffs,
                    scene_index=scene,
                    config=config,
                    changes=pairs,
                )
                chunks.append((part, k, chunk))
    out: list[list[dict[str, Any]]] = [[{} for _ in scenes] for _ in designs]
    with contextlib.ExitStack() as stack:
        pool = executor or stack.enter_context(make_executor("process", workers=workers))
        outcomes = map_robust(pool, _evaluate_chunk, [c for _, _, c in chunks])
    for (part, k, chunk), (rows, exc, _) in zip(chunks, outcomes, strict=True):
        if exc is not None:
            raise RuntimeError(
                f"evaluating designs {part} (degree {chunk.degree}, scene {chunk.scene_index}) "
                f"failed: {type(exc).__name__}: {exc}"
            )
        for i, row in zip(part, rows, strict=True):
            out[i][k] = row
    return out


def _draw(spec: DesignSetSpec) -> dict[int, np.ndarray]:
    """Per degree, candidate designs in draw order (more than needed, for invalid ones)."""
    from tooldesign_env.env import default_bounds

    streams = np.random.SeedSequence(spec.seed).spawn(len(spec.random_designs))
    out: dict[int, np.ndarray] = {}
    for (degree, count), stream in zip(spec.random_designs, streams, strict=True):
        bounds = default_bounds(degree)
        rng = np.random.default_rng(stream)
        spare = max(4, count // 4)
        out[degree] = rng.uniform(bounds[:, 0], bounds[:, 1], size=(count + spare, degree))
    return out


def _floor(rows: Sequence[Mapping[str, Any]]) -> tuple[float | None, float | None]:
    """The range of F over a design's scenes and the range over |mean F|; None: unbounded."""
    if not all(r["valid"] for r in rows):
        return None, None
    values = np.array([r["free_energy"] for r in rows], dtype=np.float64)
    spread = float(np.ptp(values))
    mean = abs(float(values.mean()))
    return spread, (spread / mean if mean > 0 else None)


def record(
    spec: DesignSetSpec | None = None,
    *,
    executor: Executor | None = None,
    workers: int | None = None,
    note: str = "",
) -> dict[str, Any]:
    """Draw the design set and measure its nominal results and noise floors.

    Args:
        spec: How the set is drawn and the floors measured (the default: 72 designs).
        executor: Where to run; a process pool of ``workers`` if None.
        workers: Worker processes of the default pool.
        note: What physics the reference is of, stored with it.

    Returns:
        The reference (see :func:`write_reference` and ``docs/performance.md``).

    Raises:
        ValueError: If the set has fewer than :data:`DESIGNS_MIN` designs, or too few random
            draws of a degree are valid.
    """
    spec = spec or DesignSetSpec()
    total = (len(NAMED_DESIGNS) if spec.named else 0) + sum(c for _, c in spec.random_designs)
    if total * len(spec.tasks) < DESIGNS_MIN:
        raise ValueError(
            f"the design set must hold at least {DESIGNS_MIN} designs, the spec gives "
            f"{total * len(spec.tasks)}"
        )
    config = spec.nudges()
    with contextlib.ExitStack() as stack:
        pool = executor or stack.enter_context(make_executor("process", workers=workers))
        candidates: list[dict[str, Any]] = []
        for task in spec.tasks:
            if spec.named:
                for label, coeffs in NAMED_DESIGNS:
                    candidates.append(
                        {
                            "label": label,
                            "kind": "named",
                            "task": task,
                            "degree": len(coeffs),
                            "coefficients": coeffs,
                        }
                    )
            for degree, draws in _draw(spec).items():
                for j, coeffs in enumerate(draws):
                    candidates.append(
                        {
                            "label": f"d{degree}-{j:02d}",
                            "kind": "random",
                            "task": task,
                            "degree": degree,
                            "coefficients": tuple(coeffs.tolist()),
                        }
                    )
        nominal = evaluate(candidates, executor=pool)
        kept: list[dict[str, Any]] = []
        for task in spec.tasks:
            wanted = {d: c for d, c in spec.random_designs}
            for design, (row,) in zip(candidates, nominal, strict=True):
                # A design invalid in the nominal scene says nothing of the physics: left out
                # (a random one is replaced by the next draw of its degree).
                if design["task"] != task or not row["valid"]:
                    continue
                if design["kind"] == "random":
                    if wanted[design["degree"]] == 0:
                        continue
                    wanted[design["degree"]] -= 1
                kept.append({**design, "nominal": row})
            short = {d: c for d, c in wanted.items() if c}
            if short:
                raise ValueError(
                    f"too few valid random designs of task {task!r} (missing per degree: "
                    f"{short}); raise the spare draws or change the seed"
                )
        if len(kept) < DESIGNS_MIN:
            raise ValueError(
                f"only {len(kept)} designs are valid in the nominal scene; the set must hold at "
                f"least {DESIGNS_MIN}"
            )
        # The nominal scene is the first of the nudges' list: evaluated once, above.
        nudged = evaluate(kept, scenes=range(1, config.nudges), config=config, executor=pool)
    rows = [[design.pop("nominal"), *others] for design, others in zip(kept, nudged, strict=True)]
    designs = []
    for design, scenes in zip(kept, rows, strict=True):
        spread, relative = _floor(scenes)
        first = scenes[0]
        designs.append(
            {
                **design,
                "coefficients": list(design["coefficients"]),
                "valid": first["valid"],
                **{name: first[name] for name in METRICS},
                "floor": spread,
                "relative_floor": relative,
                "scene_free_energy": [r["free_energy"] for r in scenes],
                "invalid_scenes": [k for k, r in enumerate(scenes) if not r["valid"]],
            }
        )
    floors = [d["relative_floor"] for d in designs]
    return {
        "format_version": REFERENCE_VERSION,
        "note": note,
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "platform": platform_id(),
        "git_commit": git_commit(Path(__file__).resolve().parents[2]),
        "git_dirty": git_dirty(Path(__file__).resolve().parents[2]),
        "packages": package_versions(),
        "spec": spec.to_json(),
        "tasks": {name: TASKS[name].to_json() for name in spec.tasks},
        "median_relative_floor": _median_floor(floors),
        "median_floor": _median_floor([d["floor"] for d in designs]),
        "median_relative_floor_5": _median_floor(
            [_floor(r[:5])[1] for r in rows] if config.nudges >= 5 else floors
        ),
        "designs": designs,
    }


def _median_floor(floors: Sequence[float | None]) -> float | None:
    """The median of floors, an unbounded one (None) above every other; None if it lands there."""
    values = np.array([math.inf if f is None else f for f in floors], dtype=np.float64)
    if not len(values):
        return None
    ordered = np.sort(values)
    n = len(ordered)
    median = float(ordered[n // 2] if n % 2 else 0.5 * (ordered[n // 2 - 1] + ordered[n // 2]))
    return median if math.isfinite(median) else None


def write_reference(reference: Mapping[str, Any], path: str | os.PathLike[str]) -> Path:
    """Write a reference atomically, as sorted, indented JSON (checked as it is read)."""
    data = json.loads(json_text(reference))
    _check_reference(data, Path(path))
    return atomic_write_text(path, json.dumps(data, indent=1, sort_keys=True) + "\n")


def median_relative_floor() -> float:
    """The committed reference's median relative noise floor of F (a fraction of |F|).

    The range of F over 16 nudged scenes, median over the reference's 64+ designs: the smallest
    floor the benchmark protocol's targets and the break-even study's verdict allow.

    Raises:
        ValueError: If the reference has no measured median relative floor.
    """
    value = read_reference().get("median_relative_floor")
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not math.isfinite(value)
        or value <= 0
    ):
        raise ValueError(
            f"{REFERENCE} has no measured median_relative_floor (got {value!r}); record the "
            "equivalence reference (`tooldesign equivalence record`) first"
        )
    return float(value)


def read_reference(path: str | os.PathLike[str] = REFERENCE) -> dict[str, Any]:
    """The reference stored at ``path``.

    Raises:
        FileNotFoundError: If there is no file.
        ValueError: If it is not a reference of this format (the message names the field).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no equivalence reference at {path}")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise ValueError(f"{path} is not an equivalence reference: not JSON ({exc})") from None
    return _check_reference(data, path)


def _check_reference(data: Any, path: Path) -> dict[str, Any]:
    def bad(what: str, value: Any) -> ValueError:
        return ValueError(f"{path}: {what}, got {short_repr(value)}")

    if not isinstance(data, dict):
        raise bad("not an equivalence reference: it must hold a JSON object", data)
    if data.get("format_version") != REFERENCE_VERSION:
        raise bad(f"field 'format_version' must be {REFERENCE_VERSION}", data.get("format_version"))
    tasks = data.get("tasks")
    if not isinstance(tasks, dict) or not tasks:
        raise bad("field 'tasks' must be an object of tasks", tasks)
    for name, task in tasks.items():
        if name not in TASKS or task != TASKS[name].to_json():
            raise bad(
                f"task {name!r} must be one this code knows, with its settings "
                f"({sorted(TASKS)}); record a new reference",
                task,
            )
    designs = data.get("designs")
    if not isinstance(designs, list) or len(designs) < DESIGNS_MIN:
        raise bad(f"field 'designs' must be a list of at least {DESIGNS_MIN} designs", designs)
    for i, d in enumerate(designs):
        where = f"design {i}"
        if not isinstance(d, dict):
            raise bad(f"{where} must be an object", d)
        if d.get("task") not in tasks:
            raise bad(f"{where}: field 'task' must be one of {sorted(tasks)}", d.get("task"))
        coeffs = d.get("coefficients")
        if (
            not isinstance(coeffs, list)
            or len(coeffs) != d.get("degree")
            or not all(finite_number(c) for c in coeffs)
        ):
            raise bad(f"{where}: 'coefficients' must be 'degree' finite numbers", coeffs)
        for name in (*METRICS,):
            if not finite_number(d.get(name)):
                raise bad(f"{where}: field {name!r} must be a finite number", d.get(name))
        for name in ("floor", "relative_floor"):
            value = d.get(name)
            if value is not None and not (finite_number(value) and value >= 0):
                raise bad(f"{where}: field {name!r} must be a number >= 0 or null", value)
        if d.get("valid") is not True:
            raise bad(f"{where}: field 'valid' must be true (a design valid as recorded)", d)
    # The summary must be what the designs' floors give: the rule's bound is computed from
    # them (compare), and a file that says otherwise was edited.
    stored = data.get("median_relative_floor")
    median = _median_floor([d.get("relative_floor") for d in designs])
    if stored is not None and not finite_number(stored):
        raise bad("field 'median_relative_floor' must be a number or null", stored)
    agrees = (
        stored is None
        if median is None
        else stored is not None and math.isclose(float(stored), median, rel_tol=1e-9)
    )
    if not agrees:
        raise bad(
            f"field 'median_relative_floor' must be the median of the designs' relative floors "
            f"({median!r})",
            stored,
        )
    return data


@dataclasses.dataclass(frozen=True, kw_only=True)
class Comparison:
    """The rule's tests 1 and 2 on a build against a reference.

    Attributes:
        rows: Per design: ``label``, ``task``, ``degree``, ``reference`` and ``current`` F,
            ``dF``, ``relative`` (dF / |F_ref|, None if invalid now), ``floor`` (None:
            unbounded), ``within`` and ``current_valid``.
        within_fraction: Fraction of designs with |dF| within their floor.
        mean_relative: Mean of the relative changes over the designs valid in both builds.
        low: Lower end of its 95 % t interval.
        high: Upper end.
        median_relative_floor: The reference's median relative floor (None: unmeasured).
        bound: Half of it: the interval must lie inside plus or minus this.
        reasons: Why the change is rejected; empty if it is accepted.
    """

    rows: tuple[dict[str, Any], ...]
    within_fraction: float
    mean_relative: float
    low: float
    high: float
    median_relative_floor: float | None
    bound: float
    reasons: tuple[str, ...]

    @property
    def accepted(self) -> bool:
        """Whether tests 1 and 2 pass."""
        return not self.reasons


def _t_interval(values: np.ndarray, level: float) -> tuple[float, float, float]:
    from scipy import stats

    n = len(values)
    if n < 2:
        return math.nan, math.nan, math.nan
    mean = float(values.mean())
    half = float(stats.t.ppf(0.5 + level / 2, n - 1) * values.std(ddof=1) / math.sqrt(n))
    return mean, mean - half, mean + half


def compare(reference: Mapping[str, Any], current: Sequence[Mapping[str, Any]]) -> Comparison:
    """Tests 1 and 2 of the rule: the current nominal results against the reference's.

    Args:
        reference: From :func:`read_reference` (or :func:`record`).
        current: Per design of the reference, in order, a row of :func:`evaluate` (its
            ``free_energy`` and ``valid``).

    Returns:
        The comparison; ``accepted`` is its verdict.
    """
    designs = reference["designs"]
    if len(current) != len(designs):
        raise ValueError(
            f"current results must have one row per reference design ({len(designs)}), got "
            f"{len(current)}"
        )
    rows = []
    for design, now in zip(designs, current, strict=True):
        f_ref = float(design["free_energy"])
        f_now = float(now["free_energy"])
        floor = design["floor"]
        unbounded = floor is None
        diff = f_now - f_ref
        valid = bool(now["valid"])
        within = unbounded or (valid and abs(diff) <= floor)
        rows.append(
            {
                "label": design["label"],
                "task": design["task"],
                "degree": design["degree"],
                "reference": f_ref,
                "current": f_now,
                "dF": diff,
                "relative": diff / abs(f_ref) if valid and f_ref != 0 else None,
                "floor": floor,
                "within": within,
                "current_valid": valid,
            }
        )
    fraction = sum(r["within"] for r in rows) / len(rows)
    relative = np.array([r["relative"] for r in rows if r["relative"] is not None])
    mean, low, high = _t_interval(relative, LEVEL)
    # Derived from the designs' own floors, never taken from the file's summary of them.
    median = _median_floor([design["relative_floor"] for design in designs])
    bound = MEAN_BOUND_FRACTION * median if median is not None else math.nan
    reasons = []
    if fraction < WITHIN_FRACTION:
        reasons.append(
            f"{sum(r['within'] for r in rows)} of {len(rows)} designs ({100 * fraction:.1f} %) "
            f"have |dF| within their noise floor; at least {100 * WITHIN_FRACTION:.0f} % must"
        )
    if not math.isfinite(bound):
        reasons.append("the reference's median noise floor is not measured")
    elif not (math.isfinite(low) and -bound <= low and high <= bound):
        reasons.append(
            f"the mean relative dF {100 * mean:+.3f} % has a {100 * LEVEL:.0f} % interval "
            f"[{100 * low:+.3f}, {100 * high:+.3f}] % not inside +-{100 * bound:.3f} % (half "
            f"the median noise floor)"
        )
    return Comparison(
        rows=tuple(rows),
        within_fraction=fraction,
        mean_relative=mean,
        low=low,
        high=high,
        median_relative_floor=median,
        bound=bound,
        reasons=tuple(reasons),
    )


def check(
    reference: Mapping[str, Any],
    *,
    changes: Mapping[str, Any] | None = None,
    executor: Executor | None = None,
    workers: int | None = None,
) -> Comparison:
    """Evaluate the reference's designs with the code as it is now and compare.

    One nominal evaluation per design (the floors are the reference's).

    Args:
        reference: From :func:`read_reference`.
        changes: Env keyword arguments that replace the defaults (see :func:`evaluate`): a
            change tried without editing the code.
        executor: Where to run; a process pool of ``workers`` if None.
        workers: Worker processes of the default pool.
    """
    rows = evaluate(reference["designs"], changes=changes, executor=executor, workers=workers)
    return compare(reference, [r[0] for r in rows])


def calibration(reference: Mapping[str, Any]) -> dict[str, float]:
    """How often the rule passes a change of nudge size, from the reference alone.

    Test 1: each nudged scene k >= 1 of a design is held out in turn, as a change would be: it
    is within the floor when ``|F_k - F_0|`` is at most the range of F over the other scenes
    (one fewer than the rule's, so this is slightly pessimistic). A design with an unbounded
    floor is within, as in :func:`compare`. Test 2: each nudged scene k taken as the "current"
    results of every design at once (a nudge moves every design, as another CPU's rounding
    does), its mean relative change over the designs and that mean's interval, against the
    bound of :func:`compare`.

    Returns:
        ``held_out_within``: the fraction of (design, held-out scene) pairs within the floor;
        ``pass_probability``: the chance that at least 90 % of the reference's designs are
        within, for independent designs each within with that fraction (binomial);
        ``nudges_passing_test2``: the fraction of the recorded nudges whose mean relative
        change passes test 2 (NaN without F per scene).
    """
    from scipy import stats

    hits = total = 0
    designs = reference["designs"]
    for design in designs:
        values = design.get("scene_free_energy") or []
        for k in range(1, len(values)):
            total += 1
            if design["floor"] is None:
                hits += 1
                continue
            others = np.delete(np.asarray(values, dtype=np.float64), k)
            hits += abs(values[k] - values[0]) <= float(np.ptp(others))
    if not total:
        return {
            "held_out_within": math.nan,
            "pass_probability": math.nan,
            "nudges_passing_test2": math.nan,
        }
    fraction = hits / total
    n = len(designs)
    need = math.ceil(WITHIN_FRACTION * n - 1e-9)
    passing = math.nan
    scenes = {len(d.get("scene_free_energy") or []) for d in designs}
    if len(scenes) == 1 and (count := scenes.pop()) > 1:
        median = _median_floor([d["relative_floor"] for d in designs])
        bound = MEAN_BOUND_FRACTION * median if median is not None else math.nan
        # As compare counts them: designs valid in every scene (a bounded floor), F_0 != 0.
        values = np.array(
            [d["scene_free_energy"] for d in designs if d["floor"] is not None],
            dtype=np.float64,
        ).reshape(-1, count)
        values = values[values[:, 0] != 0.0]
        passed = []
        for k in range(1, count):
            relative = (values[:, k] - values[:, 0]) / np.abs(values[:, 0])
            _, low, high = _t_interval(relative, LEVEL)
            passed.append(bool(-bound <= low and high <= bound))
        passing = float(np.mean(passed))
    return {
        "held_out_within": fraction,
        "pass_probability": float(stats.binom.sf(need - 1, n, fraction)),
        "nudges_passing_test2": passing,
    }


def _cell(value: float | None, digits: int = 4) -> str:
    return "unbounded" if value is None else f"{value:.{digits}g}"


def format_comparison(result: Comparison, *, rows: str = "outside") -> str:
    """The comparison as a plain-text table and a verdict.

    Args:
        result: From :func:`compare`.
        rows: Which designs get a row: ``"all"``, ``"outside"`` (those outside their floor)
            or ``"none"``.
    """
    if rows not in ("all", "outside", "none"):
        raise ValueError(f"rows must be 'all', 'outside' or 'none', got {rows!r}")
    lines = []
    shown = [r for r in result.rows if rows == "all" or (rows == "outside" and not r["within"])]
    if shown:
        head = f"{'design':<10} {'task':<6} {'d':>2} {'F ref':>11} {'F now':>11} {'dF':>10} "
        head += f"{'floor':>10} {'within':>6}"
        lines += [head, "-" * len(head)]
        for r in shown:
            lines.append(
                f"{r['label']:<10} {r['task']:<6} {r['degree']:>2} {r['reference']:>11.2f} "
                f"{r['current']:>11.2f} {r['dF']:>+10.3g} {_cell(r['floor']):>10} "
                f"{'yes' if r['within'] else 'NO':>6}"
            )
        lines.append("")
    n = len(result.rows)
    inside = sum(r["within"] for r in result.rows)
    median = result.median_relative_floor
    lines += [
        f"within the noise floor:   {inside} of {n} designs ({100 * result.within_fraction:.1f} "
        f"%; at least {100 * WITHIN_FRACTION:.0f} % required)",
        f"mean relative dF:         {100 * result.mean_relative:+.4f} % "
        f"({100 * LEVEL:.0f} % t interval [{100 * result.low:+.4f}, {100 * result.high:+.4f}] %)",
        f"bound (half the median):  +-{100 * result.bound:.4f} % (median relative noise floor "
        f"{'unmeasured' if median is None else f'{100 * median:.4f} %'})",
        "verdict:                  "
        + ("ACCEPTED (tests 1 and 2 of the rule)" if result.accepted else "REJECTED"),
    ]
    lines += [f"  - {reason}" for reason in result.reasons]
    return "\n".join(lines)
