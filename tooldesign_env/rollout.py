"""What a rollout records, what an estimator asks it to record, and the record estimators read.

* :class:`Trajectory`: one row per control step of what the simulator recorded.
* :class:`Recording`: what a rollout must record beyond the trajectory (the contact log, world
  snapshots for re-simulation). Each estimator of control confidence declares its own
  (``SensitivityEstimator.recording``), the objective passes it on, and the simulator honours it
  (:meth:`tooldesign_env.simulation.ToolSimulator.record`).
* :class:`Rollout`: the record passed to every estimator and objective: the trajectories, the
  control period, the contact log and a replay handle into the world that made it.

Nothing here imports PyBullet.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Recording", "Replay", "Rollout", "Trajectory", "tool_yaw", "tool_yaws"]

#: ``replay(k, horizon, offsets (m, 7)) -> (m, 3)``: the box's positions after replaying the
#: recorded torques of control steps k .. k + horizon - 1 plus each constant offset (N m), from
#: the world's snapshot before step k (:meth:`tooldesign_env.simulation.ToolSimulator.
#: replay_responses`). Only while the world still holds the rollout.
Replay = Callable[[int, int, np.ndarray], np.ndarray]


@dataclass(frozen=True, eq=False)
class Trajectory:
    """What one rollout recorded, one row per control step.

    Attributes:
        times: (T,) time at the end of each control step, s.
        box_position: (T, 3) box centre X in the world frame, m.
        torques: (T, 7) joint torques U applied during each control step, N m.
        joint_positions: (T, 7) arm joint positions at the end of each step, rad.
        tool_position: (T, 3) grasp-point position (tool-frame origin), m.
        tool_yaw: (T,) yaw of the tool frame, rad.
        contact: (T,) whether the tool touches the box.
        phase: (T,) index into :data:`PHASES` of the plan segment of each step.
        tracking_error: (T,) distance of the grasp point from the plan, m.
        fast_forward_from: index of the first step that repeats the rest state instead of being
            simulated (T when nothing was fast-forwarded).
        contact_mobility: (T, 3, 7) the box's acceleration per unit joint torque through its
            contact with the tool, m s^-2 / N m (zero without contact; see
            :func:`contact_mobility`), or None when the rollout did not record it.
        floor_contacts: whether the arm's and the tool's contacts with the floor were
            simulated (``SceneSpec.arm_floor_contacts``).
        floor_clearance: with ``arm_floor_contacts="auto"``, a lower bound on how close the arm
            and the tool came to the floor in the rollout without those contacts, m (see
            :func:`floor_clearance_bound`); None otherwise.
        box_final_orientation: the box's orientation at the end of the rollout, a quaternion
            (x, y, z, w); None when the rollout did not read it.
    """

    times: np.ndarray
    box_position: np.ndarray
    torques: np.ndarray
    joint_positions: np.ndarray
    tool_position: np.ndarray
    tool_yaw: np.ndarray
    contact: np.ndarray
    phase: np.ndarray
    tracking_error: np.ndarray
    fast_forward_from: int
    contact_mobility: np.ndarray | None = None
    floor_contacts: bool = True
    floor_clearance: float | None = None
    box_final_orientation: tuple[float, ...] | None = None

    def __len__(self) -> int:
        return int(self.times.shape[0])

    @property
    def box_final_tilt(self) -> float | None:
        """Angle of the box's up axis from the world's z axis at the end, rad (None unread)."""
        if self.box_final_orientation is None:
            return None
        x, y, _, _ = self.box_final_orientation
        return float(math.acos(min(1.0, max(-1.0, 1.0 - 2.0 * (x * x + y * y)))))


@dataclass(frozen=True, kw_only=True)
class Recording:
    """What a rollout must record beyond its trajectory: the needs of an estimator.

    Attributes:
        contact_mobility: log the tool-box contact manifold at every step in contact and
            return :attr:`Trajectory.contact_mobility` (the contact estimator).
        snapshot_every: save a world snapshot every this many control steps, so that
            :attr:`Rollout.replay` can re-simulate from them (the resimulation estimator); None
            for no snapshots.
    """

    contact_mobility: bool = False
    snapshot_every: int | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.contact_mobility, (bool, np.bool_)):
            raise TypeError(
                f"Recording.contact_mobility must be True or False, got {self.contact_mobility!r}"
            )
        every = self.snapshot_every
        if every is not None and (
            isinstance(every, (bool, np.bool_))
            or not isinstance(every, (int, np.integer))
            or every < 1
        ):
            raise ValueError(
                f"Recording.snapshot_every must be None or an int >= 1 control steps, got {every!r}"
            )

    def union(self, other: Recording) -> Recording:
        """A recording that serves both: every log either asks for, snapshots at both periods.

        Snapshots every gcd(a, b) steps lie at every multiple of a and of b.
        """
        a, b = self.snapshot_every, other.snapshot_every
        every = a if b is None else b if a is None else math.gcd(a, b)
        return Recording(
            contact_mobility=bool(self.contact_mobility or other.contact_mobility),
            snapshot_every=every,
        )


@dataclass(frozen=True, eq=False, kw_only=True)
class Rollout:
    """One use of a tool as estimators and objectives read it.

    Attributes:
        box_position: (T, 3) box centre X per control step, m.
        torques: (T, 7) joint torques U per control step, N m.
        control_dt: the control period, s (None when unknown: only estimators that need it
            refuse that).
        contact_mobility: (T, 3, 7) the contact log: the box's acceleration per unit joint
            torque through the tool, m s^-2 / N m, when the rollout recorded it
            (``Recording.contact_mobility``), else None.
        replay: the world's replay handle (:data:`Replay`) when the rollout took snapshots
            (``Recording.snapshot_every``), else None.
        trajectory: the whole :class:`Trajectory` when the rollout came from the simulator.
    """

    box_position: np.ndarray
    torques: np.ndarray
    control_dt: float | None = None
    contact_mobility: np.ndarray | None = None
    replay: Replay | None = None
    trajectory: Trajectory | None = None

    @classmethod
    def of(cls, trajectory: Trajectory, control_dt: float, replay: Replay | None = None) -> Rollout:
        """The record of a simulated :class:`Trajectory` (its contact log included)."""
        return cls(
            box_position=trajectory.box_position,
            torques=trajectory.torques,
            control_dt=control_dt,
            contact_mobility=trajectory.contact_mobility,
            replay=replay,
            trajectory=trajectory,
        )

    def __len__(self) -> int:
        return int(self.box_position.shape[0])


def tool_yaws(orientations: np.ndarray) -> list[float]:
    """:func:`tool_yaw` of every row of (n, 4) quaternions, to the same bits.

    The rotation matrix's entries are computed for all rows at once (NumPy's elementwise
    products and sums round as Python's floats do), and ``math.atan2`` takes them row by row,
    as :func:`tool_yaw` does: the per-step Python calls were 0.8 % of an evaluation (cProfile).
    """
    if orientations.shape[0] == 0:
        return []
    x, y, z, w = orientations.T
    r00 = 1.0 - 2.0 * (y * y + z * z)
    r10 = 2.0 * (x * y + z * w)
    return [math.atan2(a, b) for a, b in zip(r10.tolist(), r00.tolist(), strict=True)]


def tool_yaw(ee_orientation: tuple[Any, ...]) -> float:
    """Yaw of the tool frame from the end-effector quaternion (x, y, z, w).

    The tool frame is the end-effector frame turned by Rx(pi); its x axis is the end effector's.
    """
    x, y, z, w = ee_orientation
    # First column of the rotation matrix: the end effector's x axis in the world.
    r00 = 1.0 - 2.0 * (y * y + z * z)
    r10 = 2.0 * (x * y + z * w)
    return math.atan2(r10, r00)
