"""The protocol's instances: push tasks drawn once with a fixed seed, committed, versioned.

An instance is one push task: a goal X^g for the box, the box's mass and its friction. The
optimum moves with each of them (a heavier box slides less after the sweep, a slipperier one
more). The set is drawn ONCE by :func:`draw_instances` and committed as
``benchmarks/protocol/data/instances-v1.json``; the protocol reads that file, never redraws it,
so a new version of NumPy cannot change the benchmark. A change of the distribution or of the
drawing makes a new version (a new file); old run folders name the version they used.

Distribution of version 1 (``INSTANCE_SEED`` = 20261127, 24 instances):

- goal x uniform in [-0.5, 0.5] m, y uniform in [0.5, 1.5] m, z = 0.1 m (the box's centre
  height): the paper's goal range (``tooldesign_env.schema.GOAL_LOW``/``GOAL_HIGH``), the one
  the robustness suite draws from. The box starts at radius 1.35 m and 30 degrees, (1.169,
  0.675); the plan sweeps it round to the y axis and pulls toward (0, 0.35), so a straight tool
  leaves it near (-0.08, 1.49) and hooks pull it inward: the range spans both.
- box mass log-uniform in [0.1, 0.9] kg (the paper's nominal mass and its heaviest test mass);
- box friction uniform in [0.3, 0.5] (the default 0.4 +- 25 %).

The 24 instances are split at random (same seed) into 16 public and 8 held-out instances of the
same distribution: methods that learn or are tuned use the public set and are judged on both,
so tuning to the public set shows as a gap. Reachability is not assumed: the references record
the final distance of each instance's best known design (:mod:`benchmarks.protocol.references`).

The other tasks (``tooldesign_env.tasks``: hook, obstacle, puck) have instance sets of their own,
``data/instances-<task>-v1.json``, drawn once by :func:`draw_task_instances`: 16 goals uniform
in the task's goal range (``TaskDefinition.goal_low``/``goal_high``) from
``SeedSequence(INSTANCE_SEED, spawn_key=(task_key(task),))``, 12 public and 4 held out by one
permutation shared by every task (the same ids are held out in each). The box mass and friction are
the task's own (0.1 kg, the task scene's friction), not drawn: each task's placement (the
obstacle's curb, the hook's box), puck friction and noise floor were measured at those values
only (docs/tasks.md), and a drawn mass or friction would leave what was measured. An
instance's ``task`` names its task; its ``label`` (``"i01"`` for push, ``"hook/i01"`` for the
others) is its name in references and tables.

The module lives in the design layer (an instance is a task to design a tool for), below the
protocol and the rl layer, so that the break-even study (:mod:`benchmarks.rl.breakeven`) reads
the same held-out instances from the committed file; :mod:`benchmarks.protocol.instances`
re-exports its names.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from collections.abc import Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "INSTANCE_SEED",
    "INSTANCE_SETS",
    "INSTANCE_VERSION",
    "PUSH_TASK",
    "TASK_INSTANCES",
    "Instance",
    "committed_tasks",
    "draw_instances",
    "draw_task_instances",
    "instance_file_name",
    "instances_json",
    "load_instances",
    "select_instances",
    "task_key",
]

#: The version of the committed instance set the protocol uses.
INSTANCE_VERSION = 1

#: The seed the committed set was drawn with (``SeedSequence`` entropy).
INSTANCE_SEED = 20261127

#: The two sets of the same distribution.
INSTANCE_SETS: tuple[str, ...] = ("public", "held-out")

_GOAL_X = (-0.5, 0.5)
_GOAL_Y = (0.5, 1.5)
_GOAL_Z = 0.1
_MASS = (0.1, 0.9)
_FRICTION = (0.3, 0.5)
_N_INSTANCES = 24
_N_HELD_OUT = 8

#: The push task: the instance set of ``instances-v<version>.json`` (the protocol's first).
PUSH_TASK = "push"

#: Instances of each other task's set, and how many of them are held out.
TASK_INSTANCES = 16
_TASK_HELD_OUT = 4

#: The name whose :func:`task_key` keys the held-out split shared by every other task's set.
_SPLIT = "held-out split"

#: Box mass of every other task's instances, kg: the tasks' nominal (``DEFAULT_BOX_MASS``).
_TASK_BOX_MASS = 0.1


@dataclasses.dataclass(frozen=True, kw_only=True)
class Instance:
    """One push task of the protocol.

    Attributes:
        id: ``"i01"`` to ``"i24"``: the name in run folders and tables.
        number: 1 to 24; the IOHprofiler instance id.
        set: ``"public"`` or ``"held-out"``.
        goal: X^g, (x, y, z) in m.
        box_mass: kg.
        box_friction: lateral friction coefficient of the box (PyBullet multiplies it by the
            floor's 1.0 and the tool's 0.5 at their contacts).
        task: The registered task (``tooldesign_env.tasks``) it is an instance of; ``"push"``,
            the protocol's first, by default.
    """

    id: str
    number: int
    set: str
    goal: tuple[float, float, float]
    box_mass: float
    box_friction: float
    task: str = PUSH_TASK

    def __post_init__(self) -> None:
        if not isinstance(self.number, int) or isinstance(self.number, bool) or self.number < 1:
            raise ValueError(f"instance number must be an int >= 1, got {self.number!r}")
        if self.id != f"i{self.number:02d}":
            raise ValueError(f"instance id must be 'i{self.number:02d}', got {self.id!r}")
        if self.set not in INSTANCE_SETS:
            raise ValueError(f"instance set must be one of {INSTANCE_SETS}, got {self.set!r}")
        goal = tuple(float(v) for v in self.goal)
        if len(goal) != 3 or not all(math.isfinite(v) for v in goal):
            raise ValueError(f"instance goal must be 3 finite numbers (m), got {self.goal!r}")
        object.__setattr__(self, "goal", goal)
        if self.task == PUSH_TASK:
            ranges = (("box_mass", _MASS), ("box_friction", _FRICTION))
        else:
            from tooldesign_env.specs import BOX_MASS_MAX, FRICTION_MAX
            from tooldesign_env.tasks import get_task

            get_task(self.task).check_goal(goal, f"instance {self.id} goal")
            ranges = (("box_mass", (1e-3, BOX_MASS_MAX)), ("box_friction", (0.0, FRICTION_MAX)))
        for name, (low, high) in ranges:
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not low <= float(value) <= high:
                raise ValueError(f"instance {name} must be in [{low}, {high}], got {value!r}")
            object.__setattr__(self, name, float(value))

    @property
    def label(self) -> str:
        """Its name in references, run tables and reports: ``"i01"`` (push), ``"hook/i01"``."""
        return self.id if self.task == PUSH_TASK else f"{self.task}/{self.id}"

    def scene(self) -> dict[str, Any]:
        """The ``SceneSpec`` overrides of the instance (the box friction)."""
        return {"box_friction": self.box_friction}


def task_key(task: str) -> int:
    """A task's stable number for seed streams: the first 4 bytes of SHA-256 of its name."""
    return int.from_bytes(hashlib.sha256(task.encode()).digest()[:4], "little")


def draw_instances(seed: int = INSTANCE_SEED, n: int = _N_INSTANCES) -> tuple[Instance, ...]:
    """Draw an instance set of version 1's distribution (used once to make the committed file).

    Args:
        seed: ``SeedSequence`` entropy.
        n: Instances, >= 2; a quarter of them (at least one) are held out.

    Returns:
        The instances, numbered 1 to n.
    """
    if isinstance(n, bool) or not isinstance(n, int) or n < 2:
        raise ValueError(f"n must be an int >= 2, got {n!r}")
    goal_stream, task_stream, split_stream = np.random.SeedSequence(seed).spawn(3)
    rng = np.random.default_rng(goal_stream)
    xy = rng.uniform((_GOAL_X[0], _GOAL_Y[0]), (_GOAL_X[1], _GOAL_Y[1]), size=(n, 2))
    rng = np.random.default_rng(task_stream)
    mass = np.exp(rng.uniform(math.log(_MASS[0]), math.log(_MASS[1]), size=n))
    friction = rng.uniform(*_FRICTION, size=n)
    held = max(1, round(n * _N_HELD_OUT / _N_INSTANCES))
    held_out = set(np.random.default_rng(split_stream).permutation(n)[:held].tolist())
    return _numbered(
        [(round(float(x), 4), round(float(y), 4), _GOAL_Z) for x, y in xy],
        held_out,
        [round(float(m), 4) for m in mass],
        [round(float(f), 4) for f in friction],
    )


def draw_task_instances(
    task: str, seed: int = INSTANCE_SEED, n: int = TASK_INSTANCES
) -> tuple[Instance, ...]:
    """Draw the instance set of a task other than push (used once to make its committed file).

    Goals uniform in the task's goal range (an axis whose range is one value keeps it), from
    ``SeedSequence(seed, spawn_key=(task_key(task),))``; the box mass is 0.1 kg and the friction
    the task scene's (not drawn, see the module doc); a quarter of them (at least one) are held
    out by the permutation every task shares.

    Raises:
        ValueError: ``task`` is push (its set is :func:`draw_instances`'s) or not registered,
            or ``n`` < 2.
    """
    from tooldesign_env.tasks import get_task

    if task == PUSH_TASK:
        raise ValueError("the push task's instances are draw_instances()'s, not a task set")
    definition = get_task(task)
    if isinstance(n, bool) or not isinstance(n, int) or n < 2:
        raise ValueError(f"n must be an int >= 2, got {n!r}")
    goal_stream = np.random.SeedSequence(seed, spawn_key=(task_key(task),))
    # One split for every task: an id is public in every task's set or in none, so a size's
    # public ids are the same in every task.
    split_stream = np.random.SeedSequence(seed, spawn_key=(task_key(_SPLIT),))
    goals = np.random.default_rng(goal_stream).uniform(
        definition.goal_low, definition.goal_high, size=(n, 3)
    )
    held = max(1, round(n * _TASK_HELD_OUT / TASK_INSTANCES))
    held_out = set(np.random.default_rng(split_stream).permutation(n)[:held].tolist())
    return _numbered(
        [(round(float(x), 4), round(float(y), 4), round(float(z), 4)) for x, y, z in goals],
        held_out,
        [_TASK_BOX_MASS] * n,
        [definition.scene.box_friction] * n,
        task,
    )


def _numbered(
    goals: Sequence[tuple[float, float, float]],
    held_out: set[int],
    masses: Sequence[float],
    frictions: Sequence[float],
    task: str = PUSH_TASK,
) -> tuple[Instance, ...]:
    """The instances i01, i02, ... of a drawn set; those whose index is in ``held_out`` held out."""
    return tuple(
        Instance(
            id=f"i{k + 1:02d}",
            number=k + 1,
            set="held-out" if k in held_out else "public",
            goal=goal,
            box_mass=mass,
            box_friction=friction,
            task=task,
        )
        for k, (goal, mass, friction) in enumerate(zip(goals, masses, frictions, strict=True))
    )


def instances_json(
    instances: Sequence[Instance], version: int = INSTANCE_VERSION, *, task: str = PUSH_TASK
) -> str:
    """The text of an instance file: version, distribution, seed and the instances."""
    if task == PUSH_TASK:
        distribution: dict[str, Any] = {
            "goal_x_m": list(_GOAL_X),
            "goal_y_m": list(_GOAL_Y),
            "goal_z_m": _GOAL_Z,
            "box_mass_kg_log_uniform": list(_MASS),
            "box_friction_uniform": list(_FRICTION),
            "held_out": f"{_N_HELD_OUT} of {_N_INSTANCES}, a random permutation of the same seed",
        }
    else:
        from tooldesign_env.tasks import get_task

        definition = get_task(task)
        distribution = {
            "goal_uniform_in_m": [list(definition.goal_low), list(definition.goal_high)],
            "seed_spawn_key": [task_key(task)],
            "box_mass_kg": _TASK_BOX_MASS,
            "box_friction": definition.scene.box_friction,
            "held_out": f"{_TASK_HELD_OUT} of {TASK_INSTANCES}, a random permutation shared by "
            "every task's set",
        }
    rows = []
    for instance in instances:
        row = dataclasses.asdict(instance)
        if row["task"] == PUSH_TASK:
            del row["task"]  # the push set's file is as it was before tasks existed
        rows.append(row)
    data: dict[str, Any] = {"version": version, "seed": INSTANCE_SEED}
    if task != PUSH_TASK:
        data["task"] = task
    data.update(distribution=distribution, instances=rows)
    return json.dumps(data, indent=2) + "\n"


def instance_file_name(version: int, task: str = PUSH_TASK) -> str:
    """``instances-v<version>.json`` (push) or ``instances-<task>-v<version>.json``."""
    return (
        f"instances-v{version}.json" if task == PUSH_TASK else f"instances-{task}-v{version}.json"
    )


def _data_file(version: int, task: str = PUSH_TASK) -> Any:
    # Named from the top package: importing benchmarks.protocol would load the layers above.
    return resources.files("benchmarks").joinpath(
        f"protocol/data/{instance_file_name(version, task)}"
    )


def committed_tasks(version: int = INSTANCE_VERSION) -> tuple[str, ...]:
    """The registered tasks that have a committed instance set of ``version``, push first."""
    from tooldesign_env.tasks import task_names

    return tuple(t for t in task_names() if _data_file(version, t).is_file())


def load_instances(
    version: int = INSTANCE_VERSION,
    *,
    path: str | Path | None = None,
    task: str = PUSH_TASK,
) -> tuple[Instance, ...]:
    """The committed instance set of a version and task (or the set in ``path``).

    Raises:
        ValueError: If no such version is committed for the task, or the file is malformed.
    """
    if path is None:
        if isinstance(version, bool) or not isinstance(version, int):
            raise ValueError(f"instance set version must be an int, got {version!r}")
        source = _data_file(version, task)
        if not source.is_file():
            if task != PUSH_TASK:
                raise ValueError(
                    f"the task {task!r} has no committed instance set of version {version}; "
                    f"tasks with one: {', '.join(committed_tasks(version)) or 'none'}"
                )
            raise ValueError(
                f"no committed instance set of version {version}; committed: {INSTANCE_VERSION}"
            )
        text, where = source.read_text(), instance_file_name(version, task)
    else:
        text, where = Path(path).read_text(), str(path)
    try:
        data = json.loads(text)
        if data["version"] != version and path is None:
            raise ValueError(f"holds version {data['version']}, not {version}")
        if data.get("task", PUSH_TASK) != task and path is None:
            raise ValueError(f"holds the task {data.get('task', PUSH_TASK)!r}, not {task!r}")
        instances = tuple(
            Instance(**{"task": data.get("task", PUSH_TASK), **i, "goal": tuple(i["goal"])})
            for i in data["instances"]
        )
    except (KeyError, TypeError, ValueError) as err:
        raise ValueError(f"{where} is not an instance file: {err}") from None
    numbers = [i.number for i in instances]
    if numbers != list(range(1, len(numbers) + 1)):
        raise ValueError(f"{where}: instances must be numbered 1 to n in order, got {numbers}")
    return instances


def select_instances(
    instances: Sequence[Instance], ids: Sequence[str] | None = None, sets: Sequence[str] = ()
) -> tuple[Instance, ...]:
    """The instances named by ``ids`` (in that order) or, if ``None``, those of ``sets``.

    Raises:
        ValueError: An unknown id or set, or an empty selection.
    """
    by_id = {i.id: i for i in instances}
    if ids is not None:
        unknown = [i for i in ids if i not in by_id]
        if unknown:
            raise ValueError(f"unknown instance ids {unknown}; known: i01 to i{len(by_id):02d}")
        chosen = tuple(by_id[i] for i in ids)
    else:
        bad = [s for s in sets if s not in INSTANCE_SETS]
        if bad:
            raise ValueError(f"unknown instance sets {bad}; allowed: {list(INSTANCE_SETS)}")
        chosen = tuple(i for i in instances if i.set in sets)
    if not chosen:
        raise ValueError("the selection holds no instance")
    return chosen
