"""The floor guard: a rollout without the arm's floor contacts, unless it came near the floor.

With ``SceneSpec.arm_floor_contacts="auto"`` the arm and its tool pass through the floor (their
contacts with it cost time in every step), and the guard bounds from below how close they came to
it (:func:`floor_clearance_bound`). When the bound is under the guard's limit, the simulator runs
the episode again with those contacts. :class:`FloorGuard` holds what the bound needs: the points
that hold the tool's group in the grasp frame (per tool), and the plan's clearance and the levers
of the other links (once per simulator).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import scipy
from numpy.typing import ArrayLike

from tooldesign_env.bullet import BulletWorld, RobotHandles, rotation_matrices
from tooldesign_env.geometry import ToolGeometry
from tooldesign_env.native import LoopRecord
from tooldesign_env.plan import JointReference, cache_key, load_knots, source_digest, store_knots
from tooldesign_env.reference import plan_cache_key
from tooldesign_env.robot_model import principal_inertia
from tooldesign_env.specs import ControllerSpec, PlanSpec, SceneSpec

__all__ = [
    "BREAKING_THRESHOLD",
    "FLOOR_GUARD_VERSION",
    "FloorGuard",
    "breaking_threshold",
    "floor_clearance_bound",
]

#: The floor guard's sweep of a plan (the lowest point of the arm's first links per step), by key.
_ARM_FLOOR: dict[str, np.ndarray] = {}
#: Bump when the sweep changes: it is part of the sweep's cache key.
FLOOR_GUARD_VERSION = 2
#: Bullet's gContactBreakingThreshold: contact points are kept closer than this times a
#: shape's angular-motion disc (m).
BREAKING_THRESHOLD = 0.02


def floor_clearance_bound(
    tool_position: np.ndarray,
    tool_orientation: np.ndarray,
    points: np.ndarray,
    arm_clearance: ArrayLike,
    strayed: ArrayLike,
    between: ArrayLike,
) -> float:
    """A lower bound on the distance of the arm and its tool from the floor z = 0 over a rollout.

    Two groups of links, each bounded in its own way at each recorded step:

    * the tool and the links rigidly attached to it (the last arm link, the hand, the fingers):
      ``points`` bound their shapes in a frame attached to them, so their lowest point is
      exact for those points: ``z + min(R[2] . p)``;
    * the links before the last arm joint: their lowest point at the same step of the plan,
      ``arm_clearance``, less a bound on how far any of their points strayed from its planned
      place, ``strayed`` (see :meth:`FloorGuard.set_up`).

    The physics steps between two records are covered by ``between``: how far any point may
    have been from its place at the next record.

    Args:
        tool_position: (T, 3) origin of a frame attached to the tool per recorded step, m.
        tool_orientation: (T, 4) that frame's quaternion (x, y, z, w) per recorded step.
        points: (m, 3) points in that frame whose convex hull holds the tool's group.
        arm_clearance: (T,) lowest point of the other links at each step of the plan, m.
        strayed: (T,) how far their points may have moved from the plan at each step, m.
        between: (T,) how far any point may have been, in the physics steps before each
            record, from where it is at the record, m.

    Returns:
        The bound, m (negative if the floor may have been reached).
    """
    third_row = rotation_matrices(tool_orientation)[:, 2, :]  # (T, 3): world z of each axis
    lowest = np.asarray(tool_position, dtype=float)[:, 2] + (third_row @ points.T).min(axis=1)
    arm = np.asarray(arm_clearance, dtype=float) - np.asarray(strayed, dtype=float)
    return float((np.minimum(lowest, arm) - np.asarray(between, dtype=float)).min())


def breaking_threshold(geometry: ToolGeometry) -> float:
    """An upper bound (m) on PyBullet's contact breaking threshold for the tool's shape.

    Bullet keeps contact points closer than 0.02 m times the shape's angular-motion disc,
    |c| + r for the centre c and half-diagonal r of the shape's box in its own frame (the
    principal frame at the centre of mass). The shape lies in the tool's bounding box, so
    |c| is at most that box's farthest corner from the centre of mass, and r at most the
    half-diagonal of that box turned into the principal frame.
    """
    corners = _box_corners(np.asarray(geometry.bounds, dtype=float)[None])
    corners = corners - np.asarray(geometry.center_of_mass, dtype=float)
    _, yaw = principal_inertia(np.asarray(geometry.inertia))
    turn = np.array([[math.cos(yaw), -math.sin(yaw), 0.0], [math.sin(yaw), math.cos(yaw), 0.0]])
    turned = np.column_stack([corners[:, :2] @ turn[:, :2], corners[:, 2]])
    half_diagonal = float(np.linalg.norm(turned.max(axis=0) - turned.min(axis=0))) / 2.0
    farthest = float(np.linalg.norm(corners, axis=1).max())
    return BREAKING_THRESHOLD * (farthest + half_diagonal)


def _box_corners(boxes: np.ndarray) -> np.ndarray:
    """(8 k, 3) corners of k axis-aligned boxes given as (k, 2, 3) (min, max)."""
    pick = np.array(list(itertools.product((0, 1), repeat=3)))  # (8, 3) min/max per axis
    return boxes[:, pick, np.arange(3)].reshape(-1, 3)


class FloorGuard:
    """What :func:`floor_clearance_bound` needs for one simulator, and its limit.

    Args:
        scene: the simulator's scene (its ``floor_clearance`` is the guard's least limit).

    Attributes:
        points: (m, 3) points in the grasp frame whose convex hull holds the tool's group, for
            the tool of the last :meth:`set_up`.
        arm_floor: (levers (7,) m/rad, the plan's clearance per step (T,) m, the lowest point
            of the links no joint moves up or down, m), found once per simulator.
        substep_levers: (7,) m/rad, how far a rotation of 1 rad may move any point of the arm
            and the tool (for the physics steps between two records).
        threshold: the guard's limit for the last tool, m: a rollout whose bound is below it is
            simulated again with the floor contacts.
        warned: whether the warning of a second simulation was given.
    """

    def __init__(self, scene: SceneSpec) -> None:
        self.scene = scene
        self.points: np.ndarray | None = None
        self.arm_floor: tuple[np.ndarray, np.ndarray, float] | None = None
        self.arm_to_last = np.zeros(7)
        self.substep_levers = np.zeros(7)
        self.threshold = scene.floor_clearance
        self.warned = False

    def set_up(
        self,
        world: BulletWorld,
        robot: RobotHandles,
        geometry: ToolGeometry,
        reference: JointReference,
        plan: PlanSpec,
        control_dt: float,
    ) -> None:
        """What :func:`floor_clearance_bound` needs, with the arm at q(0).

        The tool's group (the last arm link and every link after it: the hand, the fingers and
        the tool) is bounded, in the grasp frame whose pose the rollout records, by the corners
        of the tool's bounding box and of the other links' world bounding boxes, carried into
        that frame. What the other links need does not depend on the tool: it is found once per
        simulator (:meth:`_arm_levers`, :meth:`_arm_floor_of_plan`).
        """
        last = robot.joints[-1]
        links = world.link_count(robot)
        attached = [j for j in range(last, links) if j != robot.tool_link]
        # At q(0), where the hand points down: its links' boxes are tight there. (Just after
        # loading, PyBullet's boxes and link frames do not yet agree.)
        world.set_joint_positions(robot, reference.q0)
        # The rollout records the pose of the grasp frame (EE_LINK): the points are in it.
        ee_position, ee_orientation = world.link_pose(robot, robot.ee_link)
        tool_position, tool_orientation = world.link_pose(robot, robot.tool_link)
        to_ee = rotation_matrices(ee_orientation)
        tool_corners = _box_corners(np.asarray(geometry.bounds, dtype=float)[None])
        tool_world = tool_corners @ rotation_matrices(tool_orientation).T + np.asarray(
            tool_position
        )
        attached_world = _box_corners(world.link_boxes(robot, attached))
        corners = np.vstack([tool_world, attached_world])
        self.points = (corners - np.asarray(ee_position)) @ to_ee
        if self.arm_floor is None:
            levers, first, fixed = self._arm_levers(world, robot, last)
            plan_floor = self._arm_floor_of_plan(
                world, robot, reference, plan, control_dt, first, last
            )
            self.arm_floor = (levers, plan_floor, fixed)
        # Between two records every point of the arm and the tool moves, so the levers of the
        # sub-steps reach to the tool's group too: the joint-to-joint lengths up to the last
        # joint plus the farthest corner of the group from it.
        origin = np.asarray(world.link_pose(robot, last)[0], dtype=float)
        radius = float(np.linalg.norm(corners - origin, axis=1).max())
        tool_levers = np.nan_to_num(self.arm_to_last + radius)
        self.substep_levers = np.maximum(self.arm_floor[0], tool_levers)
        # PyBullet keeps contact points closer than its breaking threshold, 0.02 m times the
        # shape's angular-motion disc (|AABB centre| + AABB half-diagonal, about the centre of
        # mass), in its own frame: the tool's grows with its size.
        self.threshold = max(self.scene.floor_clearance, breaking_threshold(geometry))

    def clearance(
        self, record: LoopRecord, reference: JointReference, controller: ControllerSpec
    ) -> float:
        """The bound of :func:`floor_clearance_bound` for a loop's record, m."""
        assert self.points is not None and self.arm_floor is not None
        steps = record.steps
        levers, plan_floor, fixed = self.arm_floor
        # How far a point of the links before the last joint may have strayed from its
        # planned place: each joint's error times its lever (see _arm_levers).
        strayed = np.abs(record.q - reference.q[:steps]) @ levers
        # Bullet integrates positions with the step's new velocities, so the physics
        # step before a record was at q - h qd: its points were at most h |qd| . levers
        # away (exact for a control period of 2; with more sub-steps their velocities are
        # taken to be the recorded one).
        period = controller.control_period
        between = (period - 1) * self.scene.time_step * (np.abs(record.qd) @ self.substep_levers)
        clearance = floor_clearance_bound(
            record.ee_position,
            record.ee_orientation,
            self.points,
            plan_floor[:steps],
            strayed,
            between,
        )
        return min(clearance, fixed)

    def _arm_levers(
        self, world: BulletWorld, robot: RobotHandles, last: int
    ) -> tuple[np.ndarray, int, float]:
        """What bounds the links before ``last``.

        Returns (levers, first, fixed): per arm joint (7,), how far (m) a rotation of 1 rad
        may move a point of those links; the first link that a joint can move up or down; and
        the lowest point (m) of the links before it, which stays where it is (inf if none).

        A rotation by dq about an axis through o moves a point p by at most |p - o| dq. For
        joint i, |p - o_i| is at most the joint-to-joint distances from o_i to the origin of
        p's link plus the farthest corner of that link's bounding box from its origin: sums of
        lengths that no joint changes, taken at q(0). The first joint turns about the vertical
        axis through the base: it moves no point up or down, and so, with the links it alone
        moves (the first), has no lever.
        """
        chain = list(range(last))  # the links before the last arm joint, base side first
        origins = np.array([world.link_pose(robot, j)[0] for j in chain], dtype=float)
        boxes = world.link_boxes(robot, chain)
        corners = _box_corners(boxes).reshape(len(chain), 8, 3)
        radius = np.linalg.norm(corners - origins[:, None, :], axis=2).max(axis=1)
        steps = np.linalg.norm(np.diff(origins, axis=0), axis=1)
        levers = np.zeros(len(robot.joints))
        for i, joint in enumerate(robot.joints):
            if joint >= last:
                continue  # moves the tool's group only, whose pose is recorded
            if i == 0 and abs(world.joint_axis(robot, joint)[2]) > 1.0 - 1e-9:
                continue
            reach = [steps[joint:m].sum() + radius[m] for m in range(joint, last)]
            levers[i] = max(reach)
        # Per arm joint: its distance along the chain to the last joint, for the levers that
        # reach the tool's group (NaN for a joint that lowers nothing).
        last_origin = np.asarray(world.link_pose(robot, last)[0], dtype=float)
        to_last = float(np.linalg.norm(last_origin - origins[-1]))
        self.arm_to_last = np.array(
            [to_last + steps[joint:].sum() if joint < last else 0.0 for joint in robot.joints]
        )
        if levers[0] == 0.0:
            self.arm_to_last[0] = math.nan
        first = 1 if levers[0] == 0.0 else 0
        fixed = float(boxes[:first, 0, 2].min()) if first else math.inf
        return levers, first, fixed

    def _arm_floor_of_plan(
        self,
        world: BulletWorld,
        robot: RobotHandles,
        reference: JointReference,
        plan: PlanSpec,
        control_dt: float,
        first: int,
        last: int,
    ) -> np.ndarray:
        """(T,) lowest point (m) of the links ``first`` to ``last - 1`` at each step of the plan.

        From memory, else from the plan cache on disk (the sweep costs about one evaluation,
        which would double the first evaluation of a process), else swept.
        """
        key = cache_key(
            {
                "arm_floor": FLOOR_GUARD_VERSION,
                "links": [first, last],
                "knots": plan_cache_key(plan),
                "control_dt": control_dt,
                # The references it sweeps (SciPy's splines, the plan's code) and its own code.
                "scipy": scipy.__version__,
                "source": [source_digest(m) for m in ("tooldesign_env.plan", __name__)],
            }
        )
        if key in _ARM_FLOOR:
            return _ARM_FLOOR[key]
        steps = len(reference.q)
        stored = load_knots(key, (1, steps))
        if stored is None:
            lowest = np.empty((1, steps))
            for k, q in enumerate(reference.q):
                world.set_joint_positions(robot, q)
                lowest[0, k] = world.link_boxes(robot, range(first, last))[:, 0, 2].min()
            world.set_joint_positions(robot, reference.q0)
            stored = lowest
            store_knots(key, stored)
        _ARM_FLOOR[key] = stored[0]
        return _ARM_FLOOR[key]
