"""The protocol suite: every (dimension, instance) cell a suite of its own, in one folder.

A protocol run folder::

    run_folder/
        protocol.json                 the ProtocolConfig, the instance-set version, the sizes,
                                      and the SHA-256 of references.json once computed here
        cells/d<d>/<instance>/        one suite run folder per push cell (benchmarks.suites.runner:
                                      manifest, parts, designs; resumable on its own)
        cells/<task>/d<d>/<instance>/ the same for a cell of another task (the task axis)
        ioh/                          the trajectories in the IOHprofiler format (ioh_export)
        report/                       tables, ECDF figures, report.md (benchmarks.protocol.report)

Each cell is a :class:`~benchmarks.suites.SuiteConfig` run by
:func:`~benchmarks.suites.run_suite` on the project's executors (serial, process pool, Dask),
so resuming, checksums and seeds are those of every suite: a rerun of the same command skips the
finished cells and runs, and replays unfinished ones. Every optimizer sees the same seeds in a
cell: the cell's root seed is the first state word of ``SeedSequence(root_seed,
spawn_key=(instance number, d))`` (push) or ``(instance number, d, task_key(task))`` (another
task), so an optimizer run later, alone (a user's), gets the seeds the committed built-ins had,
and its results merge with theirs in one report.

The task axis: ``tasks`` names the registered tasks (``tooldesign_env.tasks``) to run, push
alone by default (``tooldesign bench protocol --tasks``; ``--tasks all`` into a push run's
folder extends it, :func:`extends`). Push cells are ``instances`` x ``degrees``, as before
tasks existed; every other task's cells are ``task_instances`` of its own committed set
(:func:`~benchmarks.protocol.instances.load_instances` with ``task``) x ``task_degrees`` (d = 3:
at d = 5 and 8 its references and runs would cost about 1.5 and 2.5 times as much again each).
A config of push alone writes no task field to ``protocol.json``, so a folder made before the
axis existed reads, resumes and reports unchanged, and one made now is the same file.

The folder is data (``benchmarks.storage.runfiles``): :func:`run_protocol` refuses to start or
resume in one that holds a symbolic link anywhere below it, and ``protocol.json`` is read
without following a link.

Budgets grow with the dimension, as COCO's: a run has ``iterations(d) x batch_size`` evaluations.

Sizes (:data:`PROTOCOL_SIZES`, push alone; their measured and estimated times are in
docs/protocol.md's "Sizes" section, the one place that keeps them):

======  ==========================  =====  =======  =====  ===============  ==================
size    instances                   d      seeds    batch  evaluations/run  evaluations in all
======  ==========================  =====  =======  =====  ===============  ==================
smoke   i01, i02 (public)           3, 5   1        4      8, 12            80 (2 optimizers)
quick   6 public                    3,5,8  2        8      32, 56, 80       8,064
full    all 24 (16 public, 8 held)  3,5,8  3        8      120, 200, 320    184,320
======  ==========================  =====  =======  =====  ===============  ==================

Each other task adds (``--tasks``; d = 3 only): smoke its i01 (8 evaluations per optimizer),
quick 6 public instances (2 seeds x 4 optimizers x 32: 1,536 evaluations), full all 16 (3 x 4 x
120: 5,760).

Before anything is written, :func:`run_protocol` makes every optimizer once
(:func:`check_protocol_optimizers`, through the :mod:`optimizers` registry as every suite's
run does), so a mistyped name leaves no ``protocol.json`` behind; :func:`check_mergeable` is
the rule for folders reported together, which ``tooldesign bench protocol --baseline`` checks
before running and the report checks again.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.protocol.dimensions import DEGREES, bounds_of
from benchmarks.protocol.instances import (
    INSTANCE_VERSION,
    PUSH_TASK,
    Instance,
    committed_tasks,
    load_instances,
    select_instances,
    task_key,
)
from benchmarks.suites.config import OptimizerSpec, SuiteConfig

__all__ = [
    "BUILTIN_OPTIMIZERS",
    "PROTOCOL_FILE",
    "PROTOCOL_SIZES",
    "PROTOCOL_SUITE_NAME",
    "MERGE_FIELDS",
    "TASK_DEGREES",
    "ProtocolConfig",
    "cell_folder",
    "check_mergeable",
    "check_protocol_optimizers",
    "extends",
    "protocol_config",
    "protocol_record",
    "read_protocol",
    "run_protocol",
    "write_protocol_record",
]

PROTOCOL_SUITE_NAME = "protocol"
PROTOCOL_SIZES: tuple[str, ...] = ("smoke", "quick", "full")
PROTOCOL_FILE = "protocol.json"
PROTOCOL_FORMAT = 1

#: The committed built-ins of the ``quick`` and ``full`` sizes.
BUILTIN_OPTIMIZERS: tuple[str, ...] = ("cmaes", "bo", "pso", "random")

#: Fields that do not change results: a resumed protocol may set them differently.
_RUNTIME = frozenset({"executor", "workers", "scheduler", "max_retries"})

#: The degrees of the tasks other than push (d = 3, the paper's cubic).
TASK_DEGREES: tuple[int, ...] = (3,)

#: The plan's fields that protocol runs reported together must share: instances, degrees,
#: seeds, budgets, p^X and the task axis (absent from a push-only ``protocol.json``, so compared
#: as written). Not the size's name, nor the optimizers, nor the runtime fields.
MERGE_FIELDS: tuple[str, ...] = (
    "instances",
    "instance_version",
    "degrees",
    "n_seeds",
    "batch_size",
    "evaluations_per_degree",
    "goal_precision",
    "root_seed",
    "tasks",
    "task_instances",
    "task_degrees",
)

#: The task axis's fields and their defaults: left out of the JSON when at their default, so a
#: push-only config's ``protocol.json`` is the one written before the axis existed.
_TASK_FIELDS: dict[str, Any] = {"tasks": (PUSH_TASK,), "task_instances": (), "task_degrees": (3,)}


@dataclasses.dataclass(frozen=True, kw_only=True)
class ProtocolConfig:
    """A protocol run: the cells (instances x degrees), the optimizers, seeds and budgets.

    Attributes:
        size: ``"smoke"``, ``"quick"`` or ``"full"`` (what the sizes table says), recorded.
        instances: Instance ids of the committed set ``instance_version``.
        instance_version: Version of the committed instance set.
        degrees: Tool degrees d.
        optimizers: The optimizers (registry names or ``"module:Class"``).
        n_seeds: Seeds per (cell, optimizer).
        batch_size: Designs per iteration, the same for every optimizer.
        evaluations_per_degree: Budget per unit of d: a run has ``ceil(e * d / batch)`` iterations.
        goal_precision: p^X, 1/m^2.
        root_seed: The protocol's root seed.
        executor, workers, scheduler, max_retries: As ``SuiteConfig``'s (not results).
        tasks: The registered tasks run (``tooldesign_env.tasks``), distinct; push alone by
            default. Every task must have a committed instance set of ``instance_version``.
        task_instances: Instance ids of each task other than push, in its own set (every set
            numbers its instances i01 upward); ``instances`` are push's. Needed when ``tasks``
            has a task other than push.
        task_degrees: Tool degrees d of the tasks other than push.
    """

    size: str
    instances: tuple[str, ...]
    instance_version: int = INSTANCE_VERSION
    degrees: tuple[int, ...] = DEGREES
    optimizers: tuple[OptimizerSpec, ...] = tuple(OptimizerSpec(name=n) for n in BUILTIN_OPTIMIZERS)
    n_seeds: int = 3
    batch_size: int = 8
    evaluations_per_degree: int = 40
    goal_precision: float = 20.0
    root_seed: int = 0
    executor: str = "process"
    workers: int | None = None
    scheduler: str | None = None
    max_retries: int = 0
    tasks: tuple[str, ...] = (PUSH_TASK,)
    task_instances: tuple[str, ...] = ()
    task_degrees: tuple[int, ...] = TASK_DEGREES

    def __post_init__(self) -> None:
        if self.size not in PROTOCOL_SIZES:
            raise ValueError(f"unknown size {self.size!r}; sizes: {', '.join(PROTOCOL_SIZES)}")
        object.__setattr__(self, "instances", tuple(self.instances))
        select_instances(self.instance_set(), self.instances)  # unknown ids are refused
        if len(set(self.instances)) != len(self.instances):
            raise ValueError(f"instances must be distinct, got {list(self.instances)}")
        for field in ("degrees", "task_degrees"):
            degrees = tuple(getattr(self, field))
            for d in degrees:
                bounds_of(d)
            if not degrees or len(set(degrees)) != len(degrees):
                raise ValueError(f"{field} must be distinct and at least one, got {degrees}")
            object.__setattr__(self, field, degrees)
        self._check_tasks()
        specs = tuple(
            o if isinstance(o, OptimizerSpec) else OptimizerSpec(name=o) for o in self.optimizers
        )
        if not specs:
            raise ValueError("optimizers must name at least one optimizer")
        object.__setattr__(self, "optimizers", specs)
        for name in ("n_seeds", "batch_size", "evaluations_per_degree"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be an int >= 1, got {value!r}")
        for cell in self.cells():
            self.cell_suite(*cell)  # SuiteConfig checks the rest with its own messages

    def _check_tasks(self) -> None:
        from tooldesign_env.tasks import get_task, task_names

        if isinstance(self.tasks, str):
            raise ValueError(f"tasks must be a sequence of task names, got {self.tasks!r}")
        tasks = tuple(self.tasks)
        if not tasks or len(set(tasks)) != len(tasks):
            raise ValueError(f"tasks must be distinct and at least one, got {list(tasks)}")
        for task in tasks:
            if not isinstance(task, str) or task not in task_names():
                raise ValueError(f"unknown task {task!r}; known tasks: {', '.join(task_names())}")
            get_task(task)
            if task != PUSH_TASK:
                load_instances(self.instance_version, task=task)  # a task without a set: refused
        object.__setattr__(self, "tasks", tasks)
        if isinstance(self.task_instances, str):  # tuple("i01") would be ('i', '0', '1')
            raise ValueError(
                f"task_instances must be a sequence of instance ids, got {self.task_instances!r}"
            )
        ids = tuple(self.task_instances)
        object.__setattr__(self, "task_instances", ids)
        others = [t for t in tasks if t != PUSH_TASK]
        if not others and (ids or self.task_degrees != TASK_DEGREES):
            # They would be written into protocol.json: a push-only record is the file of before.
            raise ValueError(
                f"task_instances {list(ids)} and task_degrees {list(self.task_degrees)} are for "
                "tasks other than push; with tasks ('push',) leave them at () and "
                f"{TASK_DEGREES}"
            )
        if others and not ids:
            raise ValueError(
                f"task_instances must name the instances of the tasks {others} (e.g. ('i01',))"
            )
        if len(set(ids)) != len(ids):
            raise ValueError(f"task_instances must be distinct, got {list(ids)}")
        for task in others:
            select_instances(self.instance_set(task), ids)

    def instance_set(self, task: str = PUSH_TASK) -> tuple[Instance, ...]:
        """The committed instances of ``instance_version`` of a task (push's by default)."""
        return load_instances(self.instance_version, task=task)

    def task_cells(self, task: str) -> list[tuple[Instance, int]]:
        """(instance, d) of the cells of one task, d by d."""
        if task == PUSH_TASK:
            chosen, degrees = select_instances(self.instance_set(), self.instances), self.degrees
        else:
            chosen = select_instances(self.instance_set(task), self.task_instances)
            degrees = self.task_degrees
        return [(i, d) for d in degrees for i in chosen]

    def task_degrees_of(self, task: str) -> tuple[int, ...]:
        """The degrees a task is run at."""
        return self.degrees if task == PUSH_TASK else self.task_degrees

    def all_degrees(self) -> tuple[int, ...]:
        """Every degree some task is run at, ascending."""
        return tuple(sorted({d for t in self.tasks for d in self.task_degrees_of(t)}))

    def iterations(self, degree: int) -> int:
        """Iterations of a run at degree d: ``ceil(evaluations_per_degree * d / batch_size)``."""
        return math.ceil(self.evaluations_per_degree * degree / self.batch_size)

    def budget(self, degree: int) -> int:
        """Evaluations of a run at degree d."""
        return self.iterations(degree) * self.batch_size

    def cells(self) -> list[tuple[Instance, int]]:
        """(instance, d) of every cell: task by task (in ``tasks``' order), d by d.

        An instance knows its task (``Instance.task``).
        """
        return [cell for task in self.tasks for cell in self.task_cells(task)]

    def cell_seed(self, instance: Instance, degree: int) -> int:
        """The root seed of a cell's suite (the same for every optimizer)."""
        key: tuple[int, ...] = (instance.number, degree)
        if instance.task != PUSH_TASK:
            key += (task_key(instance.task),)
        seq = np.random.SeedSequence(self.root_seed, spawn_key=key)
        return int(seq.generate_state(1, dtype=np.uint32)[0])

    def cell_suite(self, instance: Instance, degree: int) -> SuiteConfig:
        """The suite of one cell."""
        if instance.task == PUSH_TASK:
            name = f"{PROTOCOL_SUITE_NAME}-d{degree}-{instance.id}"
            what = f"instance {instance.id}"
        else:
            name = f"{PROTOCOL_SUITE_NAME}-{instance.task}-d{degree}-{instance.id}"
            what = f"task {instance.task}, instance {instance.id}"
        return SuiteConfig(
            name=name,
            description=f"protocol cell: {what}, degree {degree}",
            task_name=instance.task,
            goal=instance.goal,
            goal_precision=self.goal_precision,
            box_mass=instance.box_mass,
            scene=instance.scene(),
            bounds=bounds_of(degree),
            optimizers=self.optimizers,
            batch_size=self.batch_size,
            iterations=self.iterations(degree),
            root_seed=self.cell_seed(instance, degree),
            n_seeds=self.n_seeds,
            executor=self.executor,
            workers=self.workers,
            scheduler=self.scheduler,
            max_retries=self.max_retries,
        )

    def evaluations(self) -> int:
        """Planned evaluations of the whole protocol run."""
        return sum(self.cell_suite(i, d).evaluations() for i, d in self.cells())

    def to_json(self) -> dict[str, Any]:
        """JSON values of the config.

        The task axis's fields are left out where they have their defaults (push alone), so a
        push-only config is written as before the axis existed; :meth:`from_json` reads a
        missing one as its default.
        """
        data = dataclasses.asdict(self)
        data["optimizers"] = [
            {**dataclasses.asdict(o), "settings": dict(o.settings)} for o in self.optimizers
        ]
        for field, default in _TASK_FIELDS.items():
            if tuple(data[field]) == default:
                del data[field]
        return json.loads(json.dumps(data))  # type: ignore[no-any-return]

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> ProtocolConfig:
        """The config of :meth:`to_json`'s values (a missing task field: its default)."""
        fields = dict(data)
        fields["optimizers"] = tuple(OptimizerSpec(**o) for o in fields.get("optimizers", ()))
        for key in ("instances", "degrees", *(k for k in _TASK_FIELDS if k in fields)):
            fields[key] = tuple(fields[key])
        return cls(**fields)

    def replace(self, **changes: Any) -> ProtocolConfig:
        """A copy with fields changed (checked again)."""
        return dataclasses.replace(self, **changes)


def resolve_tasks(tasks: Sequence[str] | None) -> tuple[str, ...]:
    """Task names as the command line gives them.

    ``None`` is push alone, ``["all"]`` every task with a committed instance set; the names
    come back in the task registry's order (push first).

    Raises:
        ValueError: An unknown task (naming the known ones), ``all`` beside other names, or a
            repeated name.
    """
    from tooldesign_env.tasks import task_names

    if tasks is None:
        return (PUSH_TASK,)
    if isinstance(tasks, str):  # list("hook") would be ['h', 'o', 'o', 'k']
        raise ValueError(f"tasks must be a sequence of task names, got {tasks!r}")
    names = list(tasks)
    if "all" in names:
        if len(names) > 1:
            raise ValueError(f"all stands alone (every task with an instance set), got {names}")
        return committed_tasks()
    for name in names:
        if name not in task_names():
            raise ValueError(
                f"unknown task {name!r}; known tasks: {', '.join(task_names())} (or all)"
            )
    if not names or len(set(names)) != len(names):
        raise ValueError(f"tasks must be distinct and at least one, got {names}")
    # In the registry's order (push first), whatever order they were given in: the same tasks
    # make the same config, so runs of them merge.
    return tuple(t for t in task_names() if t in names)


def protocol_config(
    size: str, *, optimizer: str | None = None, tasks: Sequence[str] | None = None
) -> ProtocolConfig:
    """The protocol at a size; with ``optimizer`` that one optimizer alone (a user's run).

    Args:
        size: ``smoke``, ``quick`` or ``full``.
        optimizer: Run this optimizer alone.
        tasks: The tasks (:func:`resolve_tasks`: ``None`` push alone, ``["all"]`` every one).
            Push's cells are the size's as before; every other task's are d = 3 and, of its own
            set, i01 (smoke), the first 6 public instances (quick) or all 16 (full).

    Raises:
        ValueError: An unknown size or task.
    """
    if not isinstance(size, str) or size not in PROTOCOL_SIZES:
        raise ValueError(f"unknown size {size!r}; sizes: {', '.join(PROTOCOL_SIZES)}")
    chosen_tasks = resolve_tasks(tasks)
    instances = load_instances()
    public = [i.id for i in instances if i.set == "public"]
    task_instances: tuple[str, ...] = ()
    others = [t for t in chosen_tasks if t != PUSH_TASK]
    if others:
        # The tasks' sets share their held-out split (draw_task_instances): the ids public in
        # all of them are the size's (a task registered with a set of its own may differ).
        sets = [load_instances(task=t) for t in others]
        size_of = min(len(s) for s in sets)
        shared = [
            f"i{k:02d}"
            for k in range(1, size_of + 1)
            if all(s[k - 1].set == "public" for s in sets)
        ]
        task_instances = {
            "smoke": tuple(shared[:1]),
            "quick": tuple(shared[:6]),
            "full": tuple(f"i{k:02d}" for k in range(1, size_of + 1)),
        }[size]
    if size == "smoke":
        config = ProtocolConfig(
            size=size,
            instances=tuple(public[:2]),
            degrees=(3, 5),
            optimizers=(OptimizerSpec(name="random"), OptimizerSpec(name="cmaes")),
            n_seeds=1,
            batch_size=4,
            evaluations_per_degree=2,  # ceil(2 d / 4): 2 and 3 iterations, 8 and 12 evaluations
        )
    elif size == "quick":
        config = ProtocolConfig(
            size=size, instances=tuple(public[:6]), n_seeds=2, evaluations_per_degree=10
        )
    else:
        config = ProtocolConfig(size=size, instances=tuple(i.id for i in instances), n_seeds=3)
    if optimizer is not None:
        config = config.replace(optimizers=(OptimizerSpec(name=optimizer),))
    if chosen_tasks != (PUSH_TASK,):
        config = config.replace(tasks=chosen_tasks, task_instances=task_instances)
    return config


def check_protocol_optimizers(config: ProtocolConfig) -> None:
    """Make every optimizer of ``config`` once per degree, as each cell's run would first.

    The names are resolved by the :mod:`optimizers` registry (a registered name, an installed
    plugin's entry point or an importable ``"module:Class"`` of an ``optimizers.Optimizer``),
    through :func:`benchmarks.suites.check_optimizers`, the check every suite makes before its
    first file; no simulation is built. :func:`run_protocol` calls it before it writes
    ``protocol.json``, and ``tooldesign bench protocol`` before anything else.

    Raises:
        ValueError: An unknown name (the message lists the available ones), a ``module:Class``
            that cannot be imported, or a missing backend (naming the pip extra).
        TypeError: A name that resolves to something that is not an ask/tell optimizer, or a
            setting it does not take.
    """
    from benchmarks.suites import check_optimizers

    checked: set[int] = set()
    for instance, degree in config.cells():
        if degree not in checked:  # the bounds depend on d alone
            checked.add(degree)
            check_optimizers(config.cell_suite(instance, degree))


def check_mergeable(plans: Sequence[tuple[str | os.PathLike[str], ProtocolConfig]]) -> None:
    """Refuse protocol runs that cannot be reported together.

    Every plan must share the first one's :data:`MERGE_FIELDS`, and no optimizer (its column:
    label or name) may be in two of them. :func:`~benchmarks.protocol.report.make_protocol_report`
    checks its folders with it; ``tooldesign bench protocol --baseline`` checks the run it is
    about to make against the baselines with it before running, so that a run the report would
    refuse is not made.

    Args:
        plans: (folder, its config) pairs, the first the one the others are compared with.

    Raises:
        ValueError: No plan, a plan that is not a (folder, ProtocolConfig) pair, a folder of
            another plan (naming the fields that differ), or an optimizer in two folders
            (naming both).
    """
    if isinstance(plans, (str, bytes)) or not isinstance(plans, Sequence) or not plans:
        raise ValueError(f"plans must be a non-empty sequence of (folder, config), got {plans!r}")
    for plan in plans:
        if not isinstance(plan, tuple) or len(plan) != 2 or not isinstance(
            plan[1], ProtocolConfig
        ):
            raise ValueError(f"a plan must be a (folder, ProtocolConfig) pair, got {plan!r}")
    seen: dict[str, str] = {}
    first_folder, first = plans[0]
    first_json = first.to_json()
    for folder, config in plans:
        other = config.to_json()
        differ = [k for k in MERGE_FIELDS if first_json.get(k) != other.get(k)]
        if differ:
            raise ValueError(
                f"{folder} is a protocol run of another plan than {first_folder} "
                f"(they differ in {', '.join(differ)}): runs merge only at the same size and "
                "tasks"
            )
        for name in dict.fromkeys(o.column for o in config.optimizers):
            if name in seen:
                raise ValueError(
                    f"optimizer {name!r} is in both {seen[name]} and {folder}; give it another "
                    "label"
                )
            seen[name] = str(folder)


def cell_folder(run_folder: str | os.PathLike[str], instance: Instance, degree: int) -> Path:
    """The suite run folder of a cell: ``cells/d<d>/<id>`` (push), ``cells/<task>/d<d>/<id>``."""
    cells = Path(run_folder) / "cells"
    if instance.task != PUSH_TASK:
        cells = cells / instance.task
    return cells / f"d{degree}" / instance.id


def protocol_record(run_folder: str | os.PathLike[str]) -> dict[str, Any]:
    """The ``protocol.json`` of a run folder, read without following a link.

    It holds ``format``, ``config`` and, once references were computed into the folder,
    ``references_sha256``: the SHA-256 of its ``references.json``, checked whenever that file
    is read.

    Raises:
        ValueError: If the folder has no readable ``protocol.json`` (a link, not a file, not
            JSON, another format).
    """
    from benchmarks.storage import read_run_file

    path = Path(run_folder) / PROTOCOL_FILE
    if not os.path.lexists(path):
        raise ValueError(f"{run_folder} is not a protocol run folder: it has no {PROTOCOL_FILE}")
    try:
        data = json.loads(read_run_file(run_folder, PROTOCOL_FILE, max_bytes=1 << 20))
    except FileNotFoundError:
        raise ValueError(
            f"{run_folder} is not a protocol run folder: it has no {PROTOCOL_FILE}"
        ) from None
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ValueError(f"{path} is not a protocol file: {err}") from None
    if not isinstance(data, dict) or data.get("format") != PROTOCOL_FORMAT:
        got = data.get("format") if isinstance(data, dict) else data
        raise ValueError(
            f"{path} is not a protocol file: format {got!r}, expected {PROTOCOL_FORMAT}"
        )
    digest = data.get("references_sha256")
    if digest is not None and (
        not isinstance(digest, str)
        or len(digest) != 64
        or any(c not in "0123456789abcdef" for c in digest)
    ):
        raise ValueError(f"{path}: references_sha256 must be 64 hex digits, got {digest!r}")
    return data


def read_protocol(run_folder: str | os.PathLike[str]) -> ProtocolConfig:
    """The config a protocol run folder was made with.

    Raises:
        ValueError: If the folder has no readable ``protocol.json`` (or it is a link).
    """
    data = protocol_record(run_folder)
    try:
        return ProtocolConfig.from_json(data["config"])
    except (KeyError, TypeError, ValueError) as err:
        raise ValueError(
            f"{Path(run_folder) / PROTOCOL_FILE} is not a protocol file: {err}"
        ) from None


def write_protocol_record(
    run_folder: str | os.PathLike[str],
    config: ProtocolConfig,
    *,
    references_sha256: str | None = None,
) -> Path:
    """Write ``protocol.json`` atomically (refusing a linked folder on the way)."""
    from benchmarks.storage import atomic_write_text, check_write_folder

    out = Path(run_folder)
    check_write_folder(out, out)
    record: dict[str, Any] = {"format": PROTOCOL_FORMAT, "config": config.to_json()}
    if references_sha256 is not None:
        record["references_sha256"] = references_sha256
    return atomic_write_text(
        out / PROTOCOL_FILE, json.dumps(record, indent=2, sort_keys=True) + "\n"
    )


def _comparable(config: ProtocolConfig) -> dict[str, Any]:
    return {k: v for k, v in config.to_json().items() if k not in _RUNTIME}


def extends(old: ProtocolConfig, new: ProtocolConfig) -> bool:
    """Whether ``new`` runs every cell of ``old`` as ``old`` did, and maybe more.

    True when the two differ at most in the task axis and ``new``'s cells include ``old``'s:
    ``--tasks all`` into a push run's folder keeps its cells (the same suites, seeds and
    budgets) and adds the other tasks'.
    """
    axis = set(_TASK_FIELDS)
    same = {k: v for k, v in _comparable(old).items() if k not in axis} == {
        k: v for k, v in _comparable(new).items() if k not in axis
    }
    cells = {(i.label, d) for i, d in new.cells()}
    return same and all((i.label, d) in cells for i, d in old.cells())


def _left_by_a_refused_name(out: Path, old: ProtocolConfig) -> bool:
    """Whether ``out/protocol.json`` is all a run of an optimizer that cannot be made left.

    Versions before :func:`check_protocol_optimizers` wrote the record and then failed on the
    first cell: such a folder holds no other file (at most empty folders), and its record names
    an optimizer that cannot be made. Replacing it loses nothing.
    """
    if any(p.name != PROTOCOL_FILE or p.parent != out for p in out.rglob("*") if not p.is_dir()):
        return False
    try:
        check_protocol_optimizers(old)
    except (ImportError, TypeError, ValueError):
        return True
    return False


def _refuse_kept_without_parts(out: Path, config: ProtocolConfig) -> None:
    """Refuse a folder whose cells were kept without their part files (committed results).

    Such a cell cannot be resumed (its run would say a recorded part is missing, after
    ``protocol.json`` was written again); its report can be rebuilt.
    """
    from benchmarks.storage import read_manifest
    from benchmarks.storage.manifest import PART_CHECKSUMS

    for instance, degree in config.cells():
        folder = cell_folder(out, instance, degree)
        if not (folder / "manifest.json").is_file() or (folder / "parts").exists():
            continue
        try:
            extra = read_manifest(folder).get("extra")
        except (FileNotFoundError, ValueError):
            continue  # the cell's own run says what is wrong with it
        if isinstance(extra, dict) and extra.get(PART_CHECKSUMS):
            raise ValueError(
                f"{out} is a protocol run kept without its cells' part files ({folder / 'parts'} "
                "is missing), as committed results are: it cannot be resumed or extended; "
                f"`tooldesign report {out}` rebuilds its report, or run into another --out"
            )


def run_protocol(
    config: ProtocolConfig,
    out_dir: str | os.PathLike[str],
    *,
    progress: bool = True,
    say: Callable[[str], None] | None = None,
) -> Path:
    """Run (or resume) every cell of the protocol into ``out_dir``.

    Args:
        config: The protocol.
        out_dir: The run folder; a folder of another protocol config is refused, unless
            ``config`` only adds tasks to it (:func:`extends`): its cells are kept and the
            new tasks' run, and ``protocol.json`` then records the tasks.
        progress: Progress bars of the cells.
        say: Called with one line per cell started.

    Returns:
        The run folder.

    Raises:
        ValueError: ``out_dir`` holds another protocol run or other files, a finished run kept
            without its cells' part files (committed results: they cannot be resumed), or an
            optimizer cannot be made (:func:`check_protocol_optimizers`); nothing is written
            then.
        TypeError: An optimizer that is not an ask/tell optimizer, or a setting it lacks.
    """
    from benchmarks.storage import check_out_dir, refuse_links
    from benchmarks.suites import run_suite

    if not isinstance(config, ProtocolConfig):
        raise TypeError(f"config must be a ProtocolConfig, got {type(config).__name__}")
    out = check_out_dir(out_dir)
    # Nothing is written into a folder that holds a link anywhere below it: a linked cells/,
    # cells/d3/ or report/ would have the run's files written into another folder.
    refuse_links(out)
    # Before protocol.json: a record of a name that cannot be made would block the corrected
    # command ("another configuration"), and each cell's run would refuse it anyway.
    check_protocol_optimizers(config)
    path = out / PROTOCOL_FILE
    digest = None
    if os.path.lexists(path):
        record = protocol_record(out)
        old = read_protocol(out)
        if _comparable(old) != _comparable(config) and not extends(old, config):
            if not _left_by_a_refused_name(out, old):
                raise ValueError(
                    f"{out} holds a protocol run of another configuration (size {old.size}, "
                    f"optimizers {[o.column for o in old.optimizers]}, tasks "
                    f"{', '.join(old.tasks)}); use another folder"
                )
            if say is not None:
                say(
                    f"{path} replaced: it names optimizers {[o.column for o in old.optimizers]}, "
                    "which cannot be made, and nothing was run into the folder"
                )
        else:
            _refuse_kept_without_parts(out, old)
        digest = record.get("references_sha256")
    elif out.is_dir() and any(out.iterdir()):
        raise ValueError(f"--out {out} is not empty and is not a protocol run folder")
    out.mkdir(parents=True, exist_ok=True)
    write_protocol_record(out, config, references_sha256=digest)
    cells = config.cells()
    if say is not None:
        say(
            f"protocol {config.size}: {len(cells)} cells, {len(config.optimizers)} optimizer(s), "
            f"{config.n_seeds} seed(s), {config.evaluations():,} evaluations planned"
        )
    for k, (instance, degree) in enumerate(cells, 1):
        if say is not None:
            say(f"cell {k}/{len(cells)}: d = {degree}, instance {instance.label}")
        run_suite(
            config.cell_suite(instance, degree),
            cell_folder(out, instance, degree),
            progress=progress,
            size=config.size,
        )
    return out
