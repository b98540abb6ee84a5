"""References per (task, instance, d): the best F known, its noise floor, straight and random F.

A references file is JSON::

    {"format": "tooldesign-protocol-references", "version": 1, "size": "full",
     "instance_version": 1, "goal_precision": 20.0, "plan": {...how it was computed...},
     "platform": "x86_64 AMD EPYC ... numpy 2.x pybullet 3.x",  # where they reproduce to the bit
     "cells": [{"instance": "i01", "degree": 3,
                "f_ref": ..., "design": [...], "final_distance": ...,   # the best design known
                "method": "dense grid 11^3 + 240 random + straight", "evaluations": 1572,
                "noise_floor": ..., "noise_range": ..., "noise_nudges": 16,
                "floor_min_fraction": ...,               # range of F over nudged scenes
                "unstable_better": [...],                # only if any: F of better designs
                                                         # invalid in a nudged scene (their
                                                         # retests are not in "evaluations")
                "f_straight": ...,                       # C = 0
                "random_pool": [...]},                   # F of random designs, sorted
               {"task": "hook", "instance": "i01", "degree": 3, ...},
               ...]}

A cell of the push task has no ``task`` key (files written before the task axis existed are
read unchanged); a cell of another task names it. :func:`load_references` keys the cells by
(instance label, d): ``("i01", 3)`` for push, ``("hook/i01", 3)`` for another task
(``Instance.label``).

How each reference is found (:class:`ReferencePlan`): the best F among (a) the straight tool,
(b) a pool of random designs drawn uniformly in the bounds (also the source of ``F_random(t)``,
see :func:`benchmarks.protocol.measures.expected_best_of_random`), (c) at d = 3 a dense grid
(``benchmarks.suites.dense_search.grid``, the yardstick the project already uses) and at d > 3
``restarts`` CMA-ES runs from different seeds, each of ``restart_evaluations`` evaluations. The
reference is the best of them that is valid in every nudged scene: a design that a 0.1 mm nudge
makes unbuildable (it touches the box at the start of the sweep) is passed over and its F
recorded in ``unstable_better`` (at most :data:`MAX_REFERENCE_CANDIDATES` are tried). The
noise floor is the range (max - min) of F of that best design over ``nudges`` (16,
:data:`FLOOR_SCENES`) scenes whose box start is moved by at most 0.1 mm and 1e-4 rad
(:class:`benchmarks.suites.RetestConfig`'s nudges, the project's noise floor), at least
``floor_min_fraction`` x |F_ref|: the median relative floor the committed equivalence reference
measured (:func:`floor_min_fraction`), so that a design that happens to be stable in its own
nudges gets no floor below the typical design's.

The lowest F of thousands of noisy evaluations favours a chaotic design whose unnudged F is a
lucky low (its floor is then large and its cell's target ladder weak:
:func:`benchmarks.protocol.statistics.ladder_quality`). ``ReferencePlan(rule="median")``, an
opt-in, retests every one of the :data:`MAX_REFERENCE_CANDIDATES` best designs in the nudged
scenes and takes the valid one whose median F over the nudges is lowest (its F_ref is its F in
the cell's own scene, as before). The default ``rule="lowest"`` is the rule the committed
references were computed with; a file records a plan's rule only from when it existed, and one
without it is ``"lowest"``.

A references file records the size, instance-set version, p^X and plan; :func:`load_references`
with ``config`` refuses one of another run, naming the field, and reads the file without
following a link (with ``expected_sha256``, only if it has that SHA-256: a run folder records
the one of its ``references.json``).

``tooldesign bench protocol --references --size full --out FILE`` computes them, cell by cell:
each finished cell is written to ``FILE.cells/d<d>-<instance>.json`` (another task's to
``FILE.cells/<task>-d<d>-<instance>.json``) at once, so an interrupted
computation resumes at the next cell (the folder is removed once FILE is written; its
``plan.json`` records the plan, and cells of another plan are refused). The full
plan is about 189,000 evaluations (24 instances:
1331 grid + 240 random at d = 3, 5 x 400 CMA-ES + 400 random at d = 5, 5 x 640 + 640 at d = 8,
plus 16 nudges and the straight tool per cell): 188,688 evaluations; how long they take is in
docs/protocol.md's "Sizes" section (the one place that keeps the measured and estimated times).
The smoke size's small references are committed in
``benchmarks/protocol/data/references-smoke.json``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import shutil
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.protocol.dimensions import bounds_of
from benchmarks.protocol.instances import PUSH_TASK, Instance, task_key
from benchmarks.protocol.suite import ProtocolConfig
from benchmarks.suites.retest import FLOOR_CANDIDATES
from benchmarks.suites.retest import FLOOR_SCENES as _FLOOR_SCENES

__all__ = [
    "REFERENCE_FORMAT",
    "REFERENCE_RULES",
    "ReferencePlan",
    "compute_references",
    "load_references",
    "packaged_references",
    "reference_plan",
    "verify_references",
    "verify_verdict",
]

REFERENCE_FORMAT = "tooldesign-protocol-references"
REFERENCE_VERSION = 1

#: The plan a resumable computation's ``.cells`` folder was started with.
_PARTS_PLAN = "plan.json"

#: Scenes of a noise floor (:data:`benchmarks.suites.retest.FLOOR_SCENES`, 16).
FLOOR_SCENES = _FLOOR_SCENES


def floor_min_fraction() -> float:
    """The smallest noise floor, as a fraction of |F_ref|: the equivalence reference's median.

    The committed equivalence reference (``benchmarks/suites/equivalence-reference.json``,
    read through :func:`benchmarks.suites.equivalence.read_reference`) measures the relative
    range of F over 16 nudged scenes on 64+ designs; its median is the floor a design that
    happens to be stable in its own nudges is given, instead of a hard-coded constant.

    Raises:
        ValueError: If the reference has no measured median relative floor.
    """
    from benchmarks.suites.equivalence import median_relative_floor

    return median_relative_floor()


#: How :func:`compute_cell` picks the reference among the retested candidates
#: (:class:`ReferencePlan`'s ``rule``).
REFERENCE_RULES: tuple[str, ...] = ("lowest", "median")


@dataclasses.dataclass(frozen=True, kw_only=True)
class ReferencePlan:
    """How the references of a size are computed.

    Attributes:
        grid_points: Points per coefficient of the dense grid at d = 3 (0: no grid).
        restarts: CMA-ES runs per cell at d > 3.
        restart_evaluations_per_degree: Each CMA-ES run's budget per unit of d (rounded up to
            whole batches of 8).
        pool_per_degree: Random designs per unit of d (at least the protocol's budget plus one,
            so that ``F_random(t)`` is defined at every budget).
        nudges: Scenes of the noise floor (the first is the scene itself), :data:`FLOOR_SCENES`.
        seed: Root seed of the pools and restarts.
        floor_min_fraction: The smallest noise floor as a fraction of |F_ref|; ``None`` (the
            default) takes :func:`floor_min_fraction` when the references are computed.
        rule: Which retested candidate is the reference: ``"lowest"`` (the default), the
            lowest F valid in every nudged scene; ``"median"``, the lowest median F over the
            nudges among the valid ones of the :data:`MAX_REFERENCE_CANDIDATES` best (more
            evaluations: every candidate's nudges).
    """

    grid_points: int = 11
    restarts: int = 5
    restart_evaluations_per_degree: int = 80
    pool_per_degree: int = 80
    nudges: int = FLOOR_SCENES
    seed: int = 1
    floor_min_fraction: float | None = None
    rule: str = "lowest"

    def __post_init__(self) -> None:
        if self.rule not in REFERENCE_RULES:
            raise ValueError(
                f"ReferencePlan.rule must be one of {', '.join(REFERENCE_RULES)}, got {self.rule!r}"
            )
        for name, low in (
            ("grid_points", 0),
            ("restarts", 0),
            ("restart_evaluations_per_degree", 1),
            ("pool_per_degree", 1),
            ("nudges", 2),
            ("seed", 0),
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"ReferencePlan.{name} must be an int >= {low}, got {value!r}")
        fraction = self.floor_min_fraction
        if fraction is not None and (
            isinstance(fraction, bool)
            or not isinstance(fraction, (int, float))
            or not 0 < fraction < 1
        ):
            raise ValueError(
                f"ReferencePlan.floor_min_fraction must be None or a number in (0, 1), got "
                f"{fraction!r}"
            )
        if self.grid_points == 1 or self.nudges > 100:
            raise ValueError(
                "ReferencePlan.grid_points must be 0 (no grid) or >= 2 and nudges at most 100, "
                f"got {self.grid_points} and {self.nudges}"
            )

    def pool_size(self, degree: int, budget: int) -> int:
        """Random designs of a cell: ``pool_per_degree * d``, more than the run budget.

        More, so that ``F_random(budget)`` is an expectation over subsets of the pool, not the
        pool's own minimum (which may be the reference itself).
        """
        return max(self.pool_per_degree * degree, budget + 1)


def reference_plan(size: str) -> ReferencePlan:
    """The plan of a size: ``smoke`` is tiny (seconds), ``quick`` and ``full`` use full's."""
    if size == "smoke":
        return ReferencePlan(
            grid_points=3,
            restarts=1,
            restart_evaluations_per_degree=2,
            pool_per_degree=4,
        )
    return ReferencePlan()


def _cell_key(instance_id: str, degree: int, task: str = PUSH_TASK) -> tuple[str, int]:
    """(instance label, d): ``Instance.label`` is the id for push, ``task/id`` otherwise."""
    label = instance_id if task == PUSH_TASK else f"{task}/{instance_id}"
    return (label, int(degree))


def _part_name(instance: Instance, degree: int) -> str:
    """The file of a finished cell in a computation's ``.cells`` folder."""
    prefix = "" if instance.task == PUSH_TASK else f"{instance.task}-"
    return f"{prefix}d{degree}-{instance.id}.json"


def _stream(plan: ReferencePlan, instance: Instance, degree: int, purpose: int) -> Any:
    """The seed stream of a cell's random pool (1) or restarts (2); another task's its own."""
    key: tuple[int, ...] = (instance.number, degree, purpose)
    if instance.task != PUSH_TASK:
        key += (task_key(instance.task),)
    return np.random.SeedSequence(plan.seed, spawn_key=key)


def packaged_references(size: str) -> Path | None:
    """The committed references file of a size, if there is one (``quick`` uses ``full``'s)."""
    name = "smoke" if size == "smoke" else "full"
    path = resources.files("benchmarks.protocol").joinpath(f"data/references-{name}.json")
    return Path(str(path)) if path.is_file() else None


def references_size(size: str) -> str:
    """The size whose references a run of ``size`` is measured against (``quick`` uses full's)."""
    return "smoke" if size == "smoke" else "full"


def _plan_fields(plan: ReferencePlan) -> dict[str, Any]:
    """The plan's fields that a references file must match.

    Not the floor's minimum: it is recorded per cell, and comes from the equivalence reference,
    which may be recorded again without the references being stale.
    """
    fields = dataclasses.asdict(plan)
    fields.pop("floor_min_fraction")
    fields.pop("rule")  # compared apart: files written before it existed are "lowest"
    return fields


def check_references_match(
    data: dict[str, Any],
    config: ProtocolConfig,
    where: str | os.PathLike[str],
    *,
    plan: ReferencePlan | None = None,
    sizes: tuple[str, ...] | None = None,
) -> None:
    """Refuse references computed for another run: instance set, p^X, size or plan.

    Args:
        data: The references file's JSON (or a resumed computation's header).
        config: The run they are for.
        where: The file, for the message.
        plan: The plan they must have been computed with; :func:`reference_plan` (config.size)
            if ``None``.
        sizes: Sizes accepted; ``config.size`` and the size whose references it uses if
            ``None``.

    Raises:
        ValueError: naming the first field that differs, its value and the run's.
    """
    # A report accepts references of either rule; a computation that resumes only its own.
    explicit = plan is not None
    plan = plan or reference_plan(config.size)
    sizes = sizes or tuple(dict.fromkeys((config.size, references_size(config.size))))
    tasks = "" if config.tasks == (PUSH_TASK,) else f" --tasks {' '.join(config.tasks)}"
    hint = (
        f"compute references for this run (`tooldesign bench protocol --references --size "
        f"{config.size}{tasks} --out FILE.json`) or give the ones it was made with"
    )
    for field, want in (
        ("instance_version", config.instance_version),
        ("goal_precision", config.goal_precision),
    ):
        if data.get(field) != want:
            raise ValueError(
                f"{where} was computed with {field} = {data.get(field)!r}, this run has "
                f"{want!r}: {hint}"
            )
    if data.get("size") not in sizes:
        raise ValueError(
            f"{where} was computed for size {data.get('size')!r}, this run of size "
            f"{config.size!r} uses references of size {' or '.join(map(repr, sizes))}: {hint}"
        )
    got = data.get("plan")
    want_plan = _plan_fields(plan)
    if not isinstance(got, dict):
        raise ValueError(f"{where} has no plan (got {got!r}): {hint}")
    for field, want in want_plan.items():
        if got.get(field) != want:
            raise ValueError(
                f"{where} was computed with plan {field} = {got.get(field)!r}, the plan of size "
                f"{config.size!r} has {want!r}: {hint}"
            )
    rule = got.get("rule", "lowest")
    if explicit and rule != plan.rule:
        raise ValueError(
            f"{where} was computed with plan rule = {rule!r}, this plan has {plan.rule!r}"
        )


def load_references(
    path: str | os.PathLike[str],
    *,
    config: ProtocolConfig | None = None,
    expected_sha256: str | None = None,
) -> dict[tuple[str, int], dict[str, Any]]:
    """The cells of a references file, by (instance label, d): ``("i01", 3)``, ``("hook/i01", 3)``.

    The file is read without following a symbolic link (a run folder's ``references.json`` may
    come from someone else: ``benchmarks.storage.read_run_file``), and with
    ``expected_sha256`` it must have that SHA-256.

    Args:
        path: The references file.
        config: The run it is for: its instance set, p^X, size and plan must match
            (:func:`check_references_match`).
        expected_sha256: The SHA-256 its run folder's ``protocol.json`` records.

    Raises:
        ValueError: If the file is missing, a link, not a references file, changed since it was
            recorded, or computed for another run (naming the field).
    """
    from benchmarks.storage import read_run_file

    path = Path(path)
    try:
        raw = read_run_file(path.parent, path.name, max_bytes=256 << 20)
    except FileNotFoundError:
        raise ValueError(f"references file {path} does not exist") from None
    if expected_sha256 is not None:
        actual = hashlib.sha256(raw).hexdigest()
        if actual != expected_sha256:
            raise ValueError(
                f"{path} is not the references this run folder recorded (sha256 "
                f"{actual[:12]}..., protocol.json records {expected_sha256[:12]}...): it was "
                "replaced or edited; compute them again with --with-references"
            )
    try:
        data = json.loads(raw)
        if not isinstance(data, dict) or data.get("format") != REFERENCE_FORMAT:
            got = data.get("format") if isinstance(data, dict) else data
            raise ValueError(f"format is {got!r}, not {REFERENCE_FORMAT!r}")
        if data.get("version") != REFERENCE_VERSION:
            raise ValueError(f"version is {data.get('version')!r}, not {REFERENCE_VERSION}")
        cells = {}
        for cell in data["cells"]:
            for key in ("f_ref", "noise_floor", "f_straight"):
                if not math.isfinite(float(cell[key])):
                    raise ValueError(f"{key} of {cell['instance']} d={cell['degree']} not finite")
            if float(cell["noise_floor"]) <= 0:
                raise ValueError(f"noise_floor of {cell['instance']} d={cell['degree']} <= 0")
            pool = np.asarray(cell["random_pool"], dtype=float)
            if pool.size == 0 or not np.all(np.isfinite(pool)):
                raise ValueError(f"random_pool of {cell['instance']} must be finite F values")
            task = cell.get("task", PUSH_TASK)
            if not isinstance(task, str) or not task:
                raise ValueError(f"task of {cell['instance']} must be a task name, got {task!r}")
            cells[_cell_key(cell["instance"], cell["degree"], task)] = cell
    except (KeyError, TypeError, ValueError, UnicodeDecodeError) as err:
        raise ValueError(f"{path} is not a protocol references file: {err}") from None
    if config is not None:
        check_references_match(data, config, path)
    return cells


def _task(config: ProtocolConfig, instance: Instance, degree: int) -> Any:
    return config.cell_suite(instance, degree).runs()[0].design.task()


def _evaluate(pool: Any, designs: np.ndarray, task: Any) -> list[dict[str, Any]]:
    from benchmarks.execution import evaluate_batch

    rows: list[dict[str, Any]] = []
    for start in range(0, len(designs), 64):
        rows += evaluate_batch(pool, designs[start : start + 64], task)
    return rows


def _cmaes_runs(
    pool: Any, config: ProtocolConfig, instance: Instance, degree: int, plan: ReferencePlan
) -> tuple[np.ndarray, list[dict[str, Any]]]:
    from benchmarks.design import DesignStepper
    from benchmarks.execution import evaluate_batch

    base = config.cell_suite(instance, degree).runs()[0].design
    iterations = math.ceil(plan.restart_evaluations_per_degree * degree / 8)
    seeds = _stream(plan, instance, degree, 2)
    designs, rows = [], []
    for child in seeds.spawn(plan.restarts):
        run = dataclasses.replace(
            base,
            optimizer="cmaes",
            optimizer_settings=(),
            seed=int(child.generate_state(1, dtype=np.uint32)[0]),
            batch_size=8,
            iterations=iterations,
        )
        stepper = DesignStepper(run, suite="reference")
        task = run.task()
        for _ in range(iterations):
            x = stepper.ask()
            got = evaluate_batch(pool, x, task)
            stepper.tell(got)
            designs.append(x)
            rows += got
    return np.vstack(designs), rows


#: Candidates (best F first) :func:`compute_cell` tries for a reference valid in every nudged
#: scene before it gives up on a cell (:data:`benchmarks.suites.retest.FLOOR_CANDIDATES`).
MAX_REFERENCE_CANDIDATES = FLOOR_CANDIDATES


def compute_cell(
    pool: Any, config: ProtocolConfig, instance: Instance, degree: int, plan: ReferencePlan
) -> dict[str, Any]:
    """The reference record of one cell (see the module doc), evaluated through ``pool``."""
    from benchmarks.execution import map_robust
    from benchmarks.storage.designs import INVALID_IN_SCENE
    from benchmarks.suites.dense_search import grid
    from benchmarks.suites.retest import RetestConfig, RetestItem, retest_design

    task = _task(config, instance, degree)
    bounds = np.asarray(bounds_of(degree))
    rng = np.random.default_rng(_stream(plan, instance, degree, 1))
    n_pool = plan.pool_size(degree, config.budget(degree))
    random_x = rng.uniform(bounds[:, 0], bounds[:, 1], size=(n_pool, degree))
    random_rows = _evaluate(pool, random_x, task)
    straight_rows = _evaluate(pool, np.zeros((1, degree)), task)
    search_x = np.zeros((0, degree))
    search_rows: list[dict[str, Any]] = []
    if degree == 3 and plan.grid_points:
        search_x = grid(plan.grid_points, 3)
        search_rows = _evaluate(pool, search_x, task)
        method = f"dense grid {plan.grid_points}^3"
    elif plan.restarts:
        search_x, search_rows = _cmaes_runs(pool, config, instance, degree, plan)
        method = f"{plan.restarts} CMA-ES runs x {len(search_rows) // plan.restarts} evaluations"
    else:
        method = "no search"
    method += f" + {n_pool} random + straight"
    designs = np.vstack([random_x, np.zeros((1, degree)), search_x])
    rows = random_rows + straight_rows + search_rows
    f = np.array([r["free_energy"] if r["status"] == "ok" else math.inf for r in rows])
    if not np.isfinite(f).any():
        raise RuntimeError(f"no valid design for instance {instance.label} at d = {degree}")
    fraction = floor_min_fraction() if plan.floor_min_fraction is None else plan.floor_min_fraction
    retest = RetestConfig(nudges=plan.nudges, seed=plan.seed, repeats=1)  # noise only
    # The reference is the best design that is valid in every nudged scene: one that a 0.1 mm
    # nudge of the box makes unbuildable (it touches the box at the start of the sweep) has an
    # F no one can reproduce, and no noise floor. Such designs are passed over, best first, and
    # counted; the number of candidates tried is bounded.
    order = [int(i) for i in np.argsort(f, kind="stable") if np.isfinite(f[i])]
    unstable: list[float] = []
    valid: list[tuple[int, dict[str, Any]]] = []  # candidates valid in every scene, best first
    for candidate in order[:MAX_REFERENCE_CANDIDATES]:
        item = RetestItem(coeffs=tuple(designs[candidate].tolist()), task=task, config=retest)
        ((result, exc, _),) = map_robust(pool, retest_design, [item])
        if exc is not None and INVALID_IN_SCENE in str(exc):
            unstable.append(float(f[candidate]))
            continue
        if exc is not None:
            raise RuntimeError(f"noise floor of {instance.label} at d = {degree}: {exc}") from exc
        valid.append((candidate, result))
        if plan.rule == "lowest":
            break
    if not valid:
        raise RuntimeError(
            f"no reference for {instance.label} at d = {degree}: the {len(unstable)} best "
            f"designs are all invalid in a nudged scene (at most {MAX_REFERENCE_CANDIDATES} "
            "are tried)"
        )
    best, result = valid[0]
    if plan.rule == "median":  # the first of equal medians: the lower unnudged F
        best, result = min(
            valid, key=lambda c: float(np.median([row["free_energy"] for row in c[1]["noise"]]))
        )
        method += (
            f"; the lowest median F over the nudges among {len(valid)} valid candidates of the "
            f"{min(len(order), MAX_REFERENCE_CANDIDATES)} best"
        )
        unstable = [u for u in unstable if u < float(f[best])]
    noise = np.array([row["free_energy"] for row in result["noise"]])
    f_ref = float(f[best])
    floor = max(float(noise.max() - noise.min()), fraction * abs(f_ref))
    pool_f = np.array([r["free_energy"] for r in random_rows], dtype=float)
    task = {} if instance.task == PUSH_TASK else {"task": instance.task}
    return {
        **task,
        "instance": instance.id,
        "degree": degree,
        "f_ref": f_ref,
        "design": designs[best].tolist(),
        "final_distance": float(rows[best]["final_distance"]),
        "method": method,
        "evaluations": len(rows) + plan.nudges * len(valid),
        "noise_floor": floor,
        "noise_range": float(noise.max() - noise.min()),
        "noise_nudges": plan.nudges,
        **({"unstable_better": unstable} if unstable else {}),
        "floor_min_fraction": fraction,
        "f_straight": float(straight_rows[0]["free_energy"]),
        "random_pool": sorted(float(v) for v in pool_f[np.isfinite(pool_f)]),
    }


def compute_references(
    config: ProtocolConfig,
    out_file: str | os.PathLike[str],
    *,
    plan: ReferencePlan | None = None,
    say: Callable[[str], None] | None = None,
    seed_from: str | os.PathLike[str] | None = None,
) -> Path:
    """Compute the references of every cell of ``config`` into ``out_file``, resumably.

    Args:
        config: The protocol whose cells need references (its executor and workers are used).
        out_file: The references file (JSON), written atomically at the end; finished cells
            wait in ``<out_file>.cells/``. The cells of an existing file are kept, not
            computed again, also those of tasks ``config`` does not run (a rerun adds the cells
            it lacks: ``--tasks all`` over a push-only file adds the other tasks' cells).
        plan: How; :func:`reference_plan` (config.size) if ``None``.
        say: Called with one line per cell.
        seed_from: References whose cells are kept, not computed again, while ``out_file``
            does not exist (the committed ones of the size, which ``--with-references`` extends
            with the cells of other tasks); they must match ``config`` like ``out_file``.

    Returns:
        ``out_file``.
    """
    from benchmarks.execution import make_executor
    from benchmarks.storage import atomic_write_text, check_write_folder, read_run_file

    plan = plan or reference_plan(config.size)
    if plan.floor_min_fraction is None:  # recorded as the value used, not as "the default"
        plan = dataclasses.replace(plan, floor_min_fraction=floor_min_fraction())
    out = Path(out_file)
    if out.suffix != ".json":
        raise ValueError(f"the references file must end in .json, got {out}")
    parts = out.with_name(out.name + ".cells")
    check_write_folder(out.parent, parts)  # a linked .cells folder is not written through
    header = {
        "size": config.size,
        "instance_version": config.instance_version,
        "goal_precision": config.goal_precision,
        "plan": dataclasses.asdict(plan),
    }
    if os.path.lexists(out):  # a finished file: its cells are done, if they are this plan's
        done = load_references(out)
        data = json.loads(read_run_file(out.parent, out.name))
        check_references_match(data, config, out, plan=plan, sizes=(config.size,))
    elif seed_from is not None:
        done = load_references(seed_from)
        seed = Path(seed_from)
        data = json.loads(read_run_file(seed.parent, seed.name, max_bytes=256 << 20))
        check_references_match(data, config, seed, plan=plan)
    else:
        done = {}
    parts.mkdir(parents=True, exist_ok=True)
    plan_file = parts / _PARTS_PLAN
    if os.path.lexists(plan_file):  # cells computed before: only if under the same plan
        try:
            before = json.loads(read_run_file(parts, _PARTS_PLAN, max_bytes=1 << 20))
        except (UnicodeDecodeError, json.JSONDecodeError) as err:
            raise ValueError(f"{plan_file} is not a plan record: {err}") from None
        if not isinstance(before, dict):
            raise ValueError(f"{plan_file} is not a plan record: {before!r}")
        check_references_match(
            {**before, "plan": before.get("plan")}, config, parts, plan=plan, sizes=(config.size,)
        )
        earlier = before.get("plan")
        fraction = earlier.get("floor_min_fraction") if isinstance(earlier, dict) else None
        if fraction != plan.floor_min_fraction:
            raise ValueError(
                f"{parts} was computed with plan floor_min_fraction = {fraction!r}, this plan "
                f"has {plan.floor_min_fraction!r}: remove it or use its plan"
            )
    elif any(parts.iterdir()):
        raise ValueError(
            f"{parts} holds cells but no {_PARTS_PLAN}: they may be of another plan; remove it"
        )
    else:
        atomic_write_text(plan_file, json.dumps(header, indent=1) + "\n")
    for cell in done.values():
        task = cell.get("task", PUSH_TASK)
        prefix = "" if task == PUSH_TASK else f"{task}-"
        target = parts / f"{prefix}d{cell['degree']}-{cell['instance']}.json"
        if not os.path.lexists(target):
            atomic_write_text(target, json.dumps(cell) + "\n")
    # The file's cells first, in its order (those of another task selection too: a rerun with
    # more tasks adds theirs), then the run's that it lacks.
    cells = list(done.values())
    with make_executor(config.executor, config.workers, config.scheduler) as pool:
        for k, (instance, degree) in enumerate(config.cells(), 1):
            if (instance.label, degree) in done:
                continue
            name = _part_name(instance, degree)
            part = parts / name
            if os.path.lexists(part):
                cells.append(json.loads(read_run_file(parts, name, max_bytes=64 << 20)))
                continue
            if say is not None:
                say(
                    f"references {k}/{len(config.cells())}: d = {degree}, instance {instance.label}"
                )
            cell = compute_cell(pool, config, instance, degree, plan)
            atomic_write_text(part, json.dumps(cell) + "\n")
            cells.append(cell)
    from benchmarks.storage import platform_id

    record = {
        "format": REFERENCE_FORMAT,
        "version": REFERENCE_VERSION,
        **header,
        # Where the values reproduce to the bit (verify_references expects identity there
        # only). A computation resumed on another kind of CPU mixes two: then it is the
        # last one's, and --verify-references on that machine says which cells differ.
        "platform": platform_id(),
        "cells": cells,
    }
    atomic_write_text(out, json.dumps(record, indent=1) + "\n")
    shutil.rmtree(parts)  # every cell is in the file now
    return out


def verify_references(
    path: str | os.PathLike[str],
    config: ProtocolConfig,
    *,
    say: Callable[[str], None] | None = None,
) -> Any:
    """Evaluate every cell's reference design and straight tool again, on this machine and tree.

    A references file is computed once and committed, so that no user recomputes it; this is
    how a user checks it cheaply (two evaluations a cell when nothing moved: seconds for the
    smoke size, under a minute for the full one). Each value is compared with the file's:
    ``identical`` is bit for bit (what the same tree gives on the same CPU), ``within_floor``
    a difference no larger than the value's own noise floor (what another x86-64 CPU, whose
    other last bits diverge like a nudge, or a change that moves F inside its noise may give).
    The reference design's floor is the cell's ``noise_floor``. The straight tool's F is often
    far noisier than the reference design's (at the committed smoke cells its range over
    the nudges is 3 to 17 times the cell's floor, but in hook's), so it is judged against a
    floor of its own, measured as the cell's was (its F over the plan's nudged scenes, at
    least ``floor_min_fraction`` x |F|), only when its F is not identical to the bit: another
    ``nudges`` evaluations for that cell.

    Args:
        path: The references file.
        config: The run whose cells are checked (its instance set, p^X, size and plan must
            match the file's: :func:`check_references_match`); cells of the file that
            ``config`` does not run are not checked.
        say: Called with one line per cell.

    Returns:
        A ``pandas.DataFrame``, a row per (cell, value): ``task``, ``instance``, ``d``,
        ``value`` (``"reference"`` or ``"straight"``), ``f_file``, ``f_now`` (NaN if the design
        is no longer usable), ``difference``, ``noise_floor`` (the value's own; NaN for a
        straight tool identical to the bit, whose floor is not measured; inf for one invalid
        in a nudged scene, whose outcome has no range), ``identical``, ``within_floor``.

    Raises:
        ValueError: The file is not a references file of ``config`` (naming the field), or it
            has none of ``config``'s cells.
    """
    import pandas as pd

    from benchmarks.execution import make_executor
    from benchmarks.storage import platform_id, read_run_file

    cells = load_references(path, config=config)
    where = Path(path)
    recorded = json.loads(read_run_file(where.parent, where.name, max_bytes=256 << 20)).get(
        "platform"
    )
    todo = [(i, d) for i, d in config.cells() if (i.label, d) in cells]
    if not todo:
        raise ValueError(f"{path} has no cell of this run ({len(config.cells())} cells)")
    rows: list[dict[str, Any]] = []
    with make_executor(config.executor, config.workers, config.scheduler) as pool:
        for instance, degree in todo:
            cell = cells[(instance.label, degree)]
            task = _task(config, instance, degree)
            designs = np.array([cell["design"], np.zeros(degree)], dtype=float)
            now = _evaluate(pool, designs, task)
            for value, key, row in zip(
                ("reference", "straight"), ("f_ref", "f_straight"), now, strict=True
            ):
                f_file = float(cell[key])
                f_now = float(row["free_energy"]) if row["status"] == "ok" else math.nan
                difference = f_now - f_file
                identical = f_now == f_file
                if value == "reference":
                    floor = float(cell["noise_floor"])
                elif identical or math.isnan(f_now):
                    floor = math.nan  # nothing to judge: the same bits, or no F at all
                else:
                    floor = _straight_floor(pool, config, task, degree, cell, f_now)
                rows.append(
                    {
                        "task": instance.task,
                        "instance": instance.id,
                        "d": degree,
                        "value": value,
                        "f_file": f_file,
                        "f_now": f_now,
                        "difference": difference,
                        "noise_floor": floor,
                        "identical": identical,
                        # NaN difference (no longer usable): False.
                        "within_floor": bool(identical or abs(difference) <= floor),
                    }
                )
            if say is not None:
                last = rows[-2:]
                say(
                    f"verified {instance.label} d = {degree}: reference "
                    f"{last[0]['difference']:+.6g} (noise floor {last[0]['noise_floor']:.4g}), "
                    f"straight {last[1]['difference']:+.6g}"
                    + (
                        ""
                        if math.isnan(last[1]["noise_floor"])
                        else f" (its noise floor {last[1]['noise_floor']:.4g})"
                    )
                )
    table = pd.DataFrame(rows)
    table.attrs["platform"] = recorded
    table.attrs["same_platform"] = recorded == platform_id()
    return table


#: On a platform other than the one the references reproduce on, the share of values that may
#: lie beyond their noise floor: another CPU's last bits diverge like a nudge, and a new nudge
#: falls outside the range of 16 with probability about 2/17 (at most; the floor's minimum
#: fraction makes it rarer: 2 to 3 % measured), so a few values beyond it are expected.
FOREIGN_BEYOND_SHARE = 0.10


def verify_verdict(table: Any) -> tuple[bool, str]:
    """Whether a :func:`verify_references` table passes, and the sentence that says why.

    On the platform the file records (or when it records none): every value within its noise
    floor. On another: at most :data:`FOREIGN_BEYOND_SHARE` of them beyond it.
    """
    beyond = int((~table["within_floor"]).sum())
    identical = int(table["identical"].sum())
    if table.attrs.get("same_platform") or table.attrs.get("platform") is None:
        where = (
            "on the platform that computed them"
            if table.attrs.get("platform")
            else "(the file records no platform)"
        )
        if beyond:
            return False, f"{beyond} value(s) beyond their noise floor {where}"
        moved = len(table) - identical
        return True, (
            f"all within their noise floor {where}"
            + (f"; {moved} not identical to the bit: F changed on this tree" if moved else "")
        )
    allowed = math.floor(FOREIGN_BEYOND_SHARE * len(table))
    sentence = (
        f"{beyond} beyond their noise floor on another platform than the file's "
        f"({table.attrs['platform']}), at most {allowed} allowed "
        f"({FOREIGN_BEYOND_SHARE:.0%}: another CPU's last bits act like a nudge)"
    )
    return beyond <= allowed, sentence


def _straight_floor(
    pool: Any,
    config: ProtocolConfig,
    task: Any,
    degree: int,
    cell: dict[str, Any],
    f_now: float,
) -> float:
    """The straight tool's noise floor at a cell, measured as :func:`compute_cell` measures one.

    Its F's range over the plan's nudged scenes, at least the cell's ``floor_min_fraction`` x
    |F|; inf if a nudge makes it unusable (its outcome changed by more than any range, as the
    equivalence rule counts such a design).
    """
    from benchmarks.execution import map_robust
    from benchmarks.storage.designs import INVALID_IN_SCENE
    from benchmarks.suites.retest import RetestConfig, RetestItem, retest_design

    plan = reference_plan(config.size)
    retest = RetestConfig(nudges=plan.nudges, seed=plan.seed, repeats=1)
    item = RetestItem(coeffs=(0.0,) * degree, task=task, config=retest)
    ((result, exc, _),) = map_robust(pool, retest_design, [item])
    if exc is not None and INVALID_IN_SCENE in str(exc):
        return math.inf
    if exc is not None:
        raise RuntimeError(
            f"noise floor of the straight tool at {cell['instance']}: {exc}"
        ) from exc
    noise = np.array([row["free_energy"] for row in result["noise"]])
    fraction = float(cell.get("floor_min_fraction", floor_min_fraction()))
    return max(float(noise.max() - noise.min()), fraction * abs(f_now))
