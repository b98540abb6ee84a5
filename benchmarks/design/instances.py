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

The module lives in the design layer (an instance is a task to design a tool for), below the
protocol and the rl layer, so that the break-even study (:mod:`benchmarks.rl.breakeven`) reads
the same held-out instances from the committed file; :mod:`benchmarks.protocol.instances`
re-exports its names.
"""

from __future__ import annotations

import dataclasses
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
    "Instance",
    "draw_instances",
    "instances_json",
    "load_instances",
    "select_instances",
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
    """

    id: str
    number: int
    set: str
    goal: tuple[float, float, float]
    box_mass: float
    box_friction: float

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
        for name, (low, high) in (("box_mass", _MASS), ("box_friction", _FRICTION)):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not low <= float(value) <= high:
                raise ValueError(f"instance {name} must be in [{low}, {high}], got {value!r}")
            object.__setattr__(self, name, float(value))

    def scene(self) -> dict[str, Any]:
        """The ``SceneSpec`` overrides of the instance (the box friction)."""
        return {"box_friction": self.box_friction}


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
    return tuple(
        Instance(
            id=f"i{k + 1:02d}",
            number=k + 1,
            set="held-out" if k in held_out else "public",
            goal=(round(float(xy[k, 0]), 4), round(float(xy[k, 1]), 4), _GOAL_Z),
            box_mass=round(float(mass[k]), 4),
            box_friction=round(float(friction[k]), 4),
        )
        for k in range(n)
    )


def instances_json(instances: Sequence[Instance], version: int = INSTANCE_VERSION) -> str:
    """The text of an instance file: version, distribution, seed and the instances."""
    data = {
        "version": version,
        "seed": INSTANCE_SEED,
        "distribution": {
            "goal_x_m": list(_GOAL_X),
            "goal_y_m": list(_GOAL_Y),
            "goal_z_m": _GOAL_Z,
            "box_mass_kg_log_uniform": list(_MASS),
            "box_friction_uniform": list(_FRICTION),
            "held_out": f"{_N_HELD_OUT} of {_N_INSTANCES}, a random permutation of the same seed",
        },
        "instances": [dataclasses.asdict(i) for i in instances],
    }
    return json.dumps(data, indent=2) + "\n"


def _data_file(version: int) -> Any:
    # Named from the top package: importing benchmarks.protocol would load the layers above.
    return resources.files("benchmarks").joinpath(f"protocol/data/instances-v{version}.json")


def load_instances(
    version: int = INSTANCE_VERSION, *, path: str | Path | None = None
) -> tuple[Instance, ...]:
    """The committed instance set of a version (or the set in ``path``).

    Raises:
        ValueError: If no such version is committed, or the file is malformed.
    """
    if path is None:
        if isinstance(version, bool) or not isinstance(version, int):
            raise ValueError(f"instance set version must be an int, got {version!r}")
        source = _data_file(version)
        if not source.is_file():
            raise ValueError(
                f"no committed instance set of version {version}; committed: {INSTANCE_VERSION}"
            )
        text, where = source.read_text(), f"instances-v{version}.json"
    else:
        text, where = Path(path).read_text(), str(path)
    try:
        data = json.loads(text)
        if data["version"] != version and path is None:
            raise ValueError(f"holds version {data['version']}, not {version}")
        instances = tuple(Instance(**{**i, "goal": tuple(i["goal"])}) for i in data["instances"])
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
