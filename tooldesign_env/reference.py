"""The plan's joint references, and their caches in memory and on disk.

The joint references depend only on the plan and the control period, not on the tool. The inverse
kinematics behind them (about 2 s) is solved once per plan and kept in memory and on disk
(:func:`tooldesign_env.plan.cache_dir`); the spline to the control steps is redone per control
period and kept the same way. Every file holds float64 values exactly, so a process that reads one
gets the same references, bit for bit, as the process that solved them.
"""

from __future__ import annotations

import platform
from typing import Any

import numpy as np
import scipy

from tooldesign_env.bullet import BulletWorld, engine_version
from tooldesign_env.plan import (
    KNOT_DT,
    REST_POSE,
    JointReference,
    cache_key,
    knot_times,
    load_knots,
    reference_from_knots,
    solve_knots,
    source_digest,
    store_knots,
)
from tooldesign_env.robot_model import panda_urdf_with_tool, robot_model_digest
from tooldesign_env.specs import PlanSpec, spec_to_dict

__all__ = [
    "IK_ITERATIONS",
    "IK_THRESHOLD",
    "REFERENCE_FORMAT",
    "plan_cache_key",
    "plan_knots",
    "plan_reference",
]

#: Settings of PyBullet's inverse-kinematics solver for the plan's knots.
IK_ITERATIONS = 200
IK_THRESHOLD = 1e-6

#: Bumped whenever what :func:`plan_reference` stores changes meaning.
REFERENCE_FORMAT = 1

_REFERENCES: dict[tuple[PlanSpec, float], JointReference] = {}
_KNOTS: dict[str, np.ndarray] = {}


def plan_cache_key(plan: PlanSpec) -> str:
    """The cache key of a plan's IK knot solutions: a digest of everything they depend on.

    The plan's every field, the knot spacing, the rest pose and solver settings, the arm's
    URDF (as loaded for IK), PyBullet's version and NumPy's (which computes the Cartesian path),
    and the machine's architecture (the same versions may round otherwise on another one, and
    a home folder may be shared between them).
    """
    return cache_key(
        {
            "plan": spec_to_dict(plan),
            "knot_dt": KNOT_DT,
            "rest_pose": list(REST_POSE),
            "solver": {"iterations": IK_ITERATIONS, "threshold": IK_THRESHOLD, "passes": 2},
            "robot": robot_model_digest(),
            "pybullet": engine_version(),
            "numpy": np.__version__,
            "machine": platform.machine(),
        }
    )


def plan_reference(plan: PlanSpec, control_dt: float, world: BulletWorld) -> JointReference:
    """The joint references of ``plan`` at control period ``control_dt`` (s).

    From memory, else from the disk cache, else splined from the knots (:func:`plan_knots`) and
    stored. ``world`` solves the inverse kinematics when the knots are in neither cache; it is
    emptied then.
    """
    key = (plan, control_dt)
    if key not in _REFERENCES:
        _REFERENCES[key] = _stored_reference(plan, control_dt, world)
    return _REFERENCES[key]


def _stored_reference(plan: PlanSpec, control_dt: float, world: BulletWorld) -> JointReference:
    """The references from the disk cache, else splined from the knots and stored.

    Splining and the Cartesian path take about 15-20 ms, once per process and plan; the
    file (beside the knots', keyed by them, the control period and SciPy's and NumPy's
    versions) holds the float64 values exactly, so the references are the same bit for bit.
    """
    knots = plan_knots(plan, world)
    steps = int(round(plan.duration / control_dt))
    key = cache_key(
        {
            "reference": REFERENCE_FORMAT,
            "source": source_digest("tooldesign_env.plan"),
            "knots": plan_cache_key(plan),
            "control_dt": control_dt,
            "scipy": scipy.__version__,
            "numpy": np.__version__,
        }
    )
    # Columns: time, q (7), qd (7), qdd (7), the grasp point (3), the yaw.
    stored = load_knots(key, (steps, 26))
    if stored is not None:
        times, q, qd, qdd, ee, yaw = np.split(stored, [1, 8, 15, 22, 25], axis=1)
        return JointReference(
            times=np.ascontiguousarray(times[:, 0]),
            q=np.ascontiguousarray(q),
            qd=np.ascontiguousarray(qd),
            qdd=np.ascontiguousarray(qdd),
            q0=knots[0].copy(),
            ee_position=np.ascontiguousarray(ee),
            yaw=np.ascontiguousarray(yaw[:, 0]),
        )
    ref = reference_from_knots(plan, control_dt, knots)
    if ref.times.shape == (steps,):
        store_knots(
            key,
            np.column_stack([ref.times, ref.q, ref.qd, ref.qdd, ref.ee_position, ref.yaw]),
        )
    return ref


def plan_knots(plan: PlanSpec, world: BulletWorld) -> np.ndarray:
    """The plan's IK knot solutions: from memory, else from the disk cache, else solved."""
    key = plan_cache_key(plan)
    if key in _KNOTS:
        return _KNOTS[key]
    shape = (knot_times(plan).size, 7)
    knots = load_knots(key, shape)
    if knots is None:
        knots = _inverse_kinematics(plan, world)
        store_knots(key, knots)
    _KNOTS[key] = knots
    return knots


def _inverse_kinematics(plan: PlanSpec, world: BulletWorld) -> np.ndarray:
    """Solve the knots in ``world`` with the arm alone (the world is emptied before and after)."""
    world.reset()
    arm = world.load_robot(panda_urdf_with_tool(None, visuals=False))

    def solve(position: np.ndarray, quaternion: tuple[Any, ...], seed: np.ndarray) -> np.ndarray:
        world.set_joint_positions(arm, seed)
        return world.inverse_kinematics(
            arm,
            tuple(position),
            quaternion,
            rest_pose=REST_POSE,
            iterations=IK_ITERATIONS,
            threshold=IK_THRESHOLD,
        )

    knots = solve_knots(plan, solve)
    world.reset()
    return knots
