"""One use of a tool: the Panda follows the plan pi_0 under computed-torque control.

The tool is a link of the robot (fixed to the grasp target), so the controller's inverse dynamics
includes the tool's mass and inertia, and different tools produce different torques U for the same
plan. A rollout records, per control step, the box position X (3), the torques U (7) and what is
needed to plot and diagnose (grasp-point pose, joint positions, tool-box contact).
"""

from __future__ import annotations

import contextlib
import dataclasses
import gc
import itertools
import math
import platform
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
import scipy
from numpy.typing import ArrayLike

from tooldesign_env.bullet import (
    BulletWorld,
    RobotHandles,
    engine_version,
    lean_collision_meshes,
    merged_hand_inertia,
    not_copyable,
    panda_urdf_with_tool,
    robot_model_digest,
    rotation_matrices,
)
from tooldesign_env.geometry import ToolGeometry, tool_link_xml
from tooldesign_env.native import LoopRecord, NativeLoop, NativeLoopError
from tooldesign_env.plan import (
    KNOT_DT,
    REST_POSE,
    JointReference,
    cache_dir,
    cache_key,
    knot_times,
    load_knots,
    phases,
    reference_from_knots,
    solve_knots,
    source_digest,
    store_knots,
)
from tooldesign_env.specs import ControllerSpec, PlanSpec, SceneSpec, spec_to_dict

__all__ = [
    "PHASES",
    "Trajectory",
    "ToolSimulator",
    "contact_mobility",
    "principal_inertia",
]

PHASES = ("lower", "settle", "sweep", "pull", "hold")

#: Builds between two fresh physics servers (see BulletWorld.reconnect).
RECONNECT_EVERY = 100

# The plan's joint references depend only on the plan and the control period, not on the tool.
# The inverse kinematics behind them (about 2 s) is solved once per plan and kept in memory and
# on disk (plan.cache_dir); the spline to the control steps is redone per control period.
_REFERENCES: dict[tuple[PlanSpec, float], JointReference] = {}
_KNOTS: dict[str, np.ndarray] = {}
#: The floor guard's sweep of a plan (the lowest point of the arm's first links per step), by key.
_ARM_FLOOR: dict[str, np.ndarray] = {}
#: Bump when the sweep changes: it is part of the sweep's cache key.
FLOOR_GUARD_VERSION = 2
#: Bullet's gContactBreakingThreshold: contact points are kept closer than this times a
#: shape's angular-motion disc (m).
BREAKING_THRESHOLD = 0.02

#: Settings of PyBullet's inverse-kinematics solver for the plan's knots.
IK_ITERATIONS = 200
IK_THRESHOLD = 1e-6


#: Bumped whenever what :meth:`ToolSimulator._stored_reference` stores changes meaning.
REFERENCE_FORMAT = 1


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

    def __len__(self) -> int:
        return int(self.times.shape[0])


def principal_inertia(inertia: np.ndarray) -> tuple[np.ndarray, float]:
    """Principal moments (3,) kg m^2 and the yaw (rad) of the principal axes of a planar body.

    PyBullet takes a diagonal inertia in an inertial frame, so the tool's tensor is rotated into
    its principal axes. The tool is symmetric about its z = 0 plane (Ixz = Iyz = 0), so the
    principal frame differs from the tool frame by a rotation about z only.
    """
    ixx, iyy, ixy = inertia[0, 0], inertia[1, 1], inertia[0, 1]
    yaw = 0.5 * math.atan2(2.0 * ixy, ixx - iyy)
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    diag = np.diag(rot.T @ inertia @ rot).copy()
    return diag, yaw


def contact_mobility(
    points: np.ndarray,
    normals: np.ndarray,
    tool_com: np.ndarray,
    linear_jacobian: np.ndarray,
    angular_jacobian: np.ndarray,
    inverse_mass_matrix: np.ndarray,
    box_center: np.ndarray,
    box_mass: float,
    box_size: tuple[float, float, float],
) -> np.ndarray:
    """The box's acceleration per unit joint torque through each contact point with the tool.

    A small torque offset dU on the arm accelerates the free arm by M^-1 dU, and the tool's
    contact point i by J_i M^-1 dU, where J_i = J_v - [r_i]x J_w is the point's Jacobian
    (r_i from the tool's centre of mass). Along the contact normal n_i the arm and the box then
    move together: the contact force grows by df_i = n_i^T J_i M^-1 dU / (1/Lambda_i + 1/m_i),
    with 1/Lambda_i = n_i^T J_i M^-1 J_i^T n_i the arm's inverse effective mass at the point and
    1/m_i = 1/m + (s_i x n_i)_z^2 / I_zz the box's (s_i from the box's centre; the box turns
    about the vertical only). The box's centre accelerates by n_i,h df_i / m, with n_i,h the
    horizontal part of the normal (the floor carries the vertical part). Tangential friction
    between tool and box is left out: PyBullet's pair friction here is 0.2, so pushes act
    along the normal.

    Every argument is batched over the N contact points (the arm's matrices repeated for the
    points of one step).

    Args:
        points: (N, 3) contact points on the tool, world frame, m.
        normals: (N, 3) unit contact normals, pointing from the tool into the box.
        tool_com: (N, 3) the tool link's centre of mass, m.
        linear_jacobian: (N, 3, 7) J_v of the tool's centre of mass, m/rad.
        angular_jacobian: (N, 3, 7) J_w of the tool link, rad/rad.
        inverse_mass_matrix: (N, 7, 7) M(q)^-1 of the arm and tool, 1 / (kg m^2).
        box_center: (N, 3) the box's centre, m.
        box_mass: kg.
        box_size: the box's full extents (x, y, z), m.

    Returns:
        (N, 3, 7) d(box acceleration)/dU per point, m s^-2 / N m.
    """
    points = np.asarray(points, dtype=float)
    normals = np.asarray(normals, dtype=float)
    arm = points - tool_com
    # J_i = J_v - [r_i]x J_w, one column per joint: (N, 3, 7).
    cross = np.cross(arm[:, None, :], np.swapaxes(angular_jacobian, 1, 2))  # (N, 7, 3)
    point_jac = linear_jacobian - np.swapaxes(cross, 1, 2)
    push = np.einsum("ni,nij,njk->nk", normals, point_jac, inverse_mass_matrix)  # (N, 7)
    arm_inv_mass = np.einsum("nj,nij,ni->n", push, point_jac, normals)
    lever = np.cross(points - box_center, normals)[:, 2]
    inertia_zz = box_mass * (box_size[0] ** 2 + box_size[1] ** 2) / 12.0
    box_inv_mass = 1.0 / box_mass + lever**2 / inertia_zz
    force_per_push = 1.0 / (arm_inv_mass + box_inv_mass)  # (N,), N per (m/s^2)
    horizontal = normals * np.array([1.0, 1.0, 0.0])
    return np.asarray(np.einsum("ni,nj,n->nij", horizontal, push, force_per_push) / box_mass)


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
      place, ``strayed`` (see :meth:`ToolSimulator._arm_levers`).

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


def _breaking_threshold(geometry: ToolGeometry) -> float:
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


def _principal_link_xml(geometry: ToolGeometry) -> tuple[str, np.ndarray]:
    """The tool's URDF link with its inertial frame turned to the principal axes."""
    diag, yaw = principal_inertia(np.asarray(geometry.inertia))
    xml = tool_link_xml(geometry, "tool")
    start = xml.index("<inertial>")
    end = xml.index("</inertial>") + len("</inertial>")
    com = " ".join(repr(float(v)) for v in geometry.center_of_mass)
    # Python floats: NumPy 2 writes a np.float64 as "np.float64(...)", which is not a URDF number.
    ixx, iyy, izz = (float(v) for v in diag)
    inertial = (
        f'<inertial><origin xyz="{com}" rpy="0 0 {yaw!r}"/><mass value="{geometry.mass!r}"/>'
        f'<inertia ixx="{ixx!r}" ixy="0" ixz="0" iyy="{iyy!r}" iyz="0" izz="{izz!r}"/>'
        "</inertial>"
    )
    return xml[:start] + inertial + xml[end:], diag


#: The arm joints' indices in PyBullet's state vectors: (q indices, u indices).
_JointSlots = tuple[tuple[int, ...], tuple[int, ...]]


@dataclass(frozen=True)
class _LoopSettings:
    """What a control loop needs beyond the simulator's specs, per rollout."""

    phase: np.ndarray  # (n,) index into PHASES of each control step
    hold_phase: int  # PHASES.index("hold")
    hold_from: int  # the first step of the final hold
    rest_needed: int  # steps at rest before the loop fast-forwards
    record_mobility: bool
    snapshot_every: int | None


@dataclass
class _Snapshots:
    """World snapshots taken during a rollout, for re-simulation."""

    every: int
    ids: dict[int, int] = field(default_factory=dict)
    rest_from: int | None = None
    rest_responses: dict[bytes, np.ndarray] = field(default_factory=dict)


class ToolSimulator:
    """A PyBullet world in which a Panda uses one tool after another.

    One instance owns one physics client; reuse it across evaluations (the plan's inverse
    kinematics is solved once per instance and plan).

    Args:
        scene: the physical world.
        plan: the fixed plan pi_0.
        controller: the computed-torque controller.
        render_mode: None, ``"human"`` or ``"rgb_array"``.
        native_loop: run the control loop in C, inside PyBullet's server
            (:mod:`tooldesign_env.native`): None (default) where the plugin is available and
            nothing is rendered, else the Python loop; True requires it (an error says why it
            cannot run); False always runs the Python loop. Both give the same results bit for
            bit; the C loop is faster. :attr:`native_status` says which one ran.
    """

    def __reduce_ex__(self, protocol: Any) -> Any:
        raise not_copyable("a ToolSimulator")

    def __init__(
        self,
        *,
        scene: SceneSpec | None = None,
        plan: PlanSpec | None = None,
        controller: ControllerSpec | None = None,
        render_mode: str | None = None,
        native_loop: bool | None = None,
    ) -> None:
        if not (native_loop is None or native_loop is True or native_loop is False):
            raise TypeError(f"native_loop must be None, True or False, got {native_loop!r}")
        if native_loop and render_mode is not None:
            raise ValueError(
                f"native_loop=True needs render_mode=None (a rendered world runs the Python "
                f"loop), got render_mode={render_mode!r}"
            )
        self.scene = scene or SceneSpec()
        self.plan = plan or PlanSpec()
        self.controller = controller or ControllerSpec()
        self.world = BulletWorld(
            render_mode=render_mode,
            time_step=self.scene.time_step,
            solver_iterations=self.scene.solver_iterations,
            # Without a render mode nothing is drawn: loading is cheaper without the renderer.
            renderer=render_mode is not None,
        )
        self._visuals = render_mode is not None
        # The arm's collision meshes, as lean copies in the plan cache's folder (the same
        # shapes, loaded faster); None loads the originals.
        self._meshes = lean_collision_meshes(cache_dir())
        self._reference: JointReference | None = None
        self._robot: RobotHandles | None = None
        self._box: int | None = None
        self._snapshots: _Snapshots | None = None
        self._last_torques: np.ndarray | None = None
        self._box_mass = self.scene.box_mass
        self._builds = 0
        self._floor_contacts = True
        # SceneSpec.arm_floor_contacts == "auto": the last build's arguments (to build again
        # with the floor contacts), the points that bound the tool's group in its frame, and,
        # once per simulator, the plan's clearance and reach of the other links.
        self._last_build: tuple[ToolGeometry, float | None, Any] | None = None
        self._guarded = False
        self._guard_points: np.ndarray | None = None
        self._arm_floor: tuple[np.ndarray, np.ndarray, float] | None = None
        self._guard_warned = False
        self._arm_to_last = np.zeros(7)
        self._substep_levers = np.zeros(7)
        self._guard_threshold = self.scene.floor_clearance
        self._targets_for: JointReference | None = None
        self._target_rows: list[tuple[list[float], list[float], list[float]]] = []
        # The C control loop (tooldesign_env.native), loaded on the first rollout.
        self._native: NativeLoop | None = None
        self._use_native = native_loop is not False
        self._native_requested = native_loop is True
        self._joint_slots: tuple[RobotHandles, _JointSlots] | None = None
        #: Which loop the last rollout ran, and why not the C one ("native" or "Python loop: ...").
        self.native_status = "not run yet"

    # ---------------------------------------------------------------- setup
    @property
    def control_dt(self) -> float:
        """Control period, s."""
        return self.scene.time_step * self.controller.control_period

    @property
    def reference(self) -> JointReference:
        """Joint references of the plan (computed on first use, then cached)."""
        if self._reference is None:
            self._reference = self._solve_reference()
        return self._reference

    def _solve_reference(self) -> JointReference:
        key = (self.plan, self.control_dt)
        if key not in _REFERENCES:
            _REFERENCES[key] = self._stored_reference()
        return _REFERENCES[key]

    def _stored_reference(self) -> JointReference:
        """The references from the disk cache, else splined from the knots and stored.

        Splining and the Cartesian path take about 15-20 ms, once per process and plan; the
        file (beside the knots', keyed by them, the control period and SciPy's and NumPy's
        versions) holds the float64 values exactly, so the references are the same bit for bit.
        """
        knots = self._knots()
        steps = int(round(self.plan.duration / self.control_dt))
        key = cache_key(
            {
                "reference": REFERENCE_FORMAT,
                "source": source_digest("tooldesign_env.plan"),
                "knots": plan_cache_key(self.plan),
                "control_dt": self.control_dt,
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
        ref = reference_from_knots(self.plan, self.control_dt, knots)
        if ref.times.shape == (steps,):
            store_knots(
                key,
                np.column_stack([ref.times, ref.q, ref.qd, ref.qdd, ref.ee_position, ref.yaw]),
            )
        return ref

    def _targets(self) -> list[tuple[list[float], list[float], list[float]]]:
        """(qdd_ref, q_ref, qd_ref) per control step as plain floats, made once per reference."""
        ref = self.reference
        if self._targets_for is not ref:
            self._target_rows = list(
                zip(ref.qdd.tolist(), ref.q.tolist(), ref.qd.tolist(), strict=True)
            )
            self._targets_for = ref
        return self._target_rows

    def _knots(self) -> np.ndarray:
        """The plan's IK knot solutions: from memory, else from the disk cache, else solved."""
        key = plan_cache_key(self.plan)
        if key in _KNOTS:
            return _KNOTS[key]
        shape = (knot_times(self.plan).size, 7)
        knots = load_knots(key, shape)
        if knots is None:
            knots = self._inverse_kinematics()
            store_knots(key, knots)
        _KNOTS[key] = knots
        return knots

    def _inverse_kinematics(self) -> np.ndarray:
        world = self.world
        world.reset()
        arm = world.load_robot(panda_urdf_with_tool(None, visuals=False))

        def solve(
            position: np.ndarray, quaternion: tuple[Any, ...], seed: np.ndarray
        ) -> np.ndarray:
            world.set_joint_positions(arm, seed)
            return world.inverse_kinematics(
                arm,
                tuple(position),
                quaternion,
                rest_pose=REST_POSE,
                iterations=IK_ITERATIONS,
                threshold=IK_THRESHOLD,
            )

        knots = solve_knots(self.plan, solve)
        world.reset()
        return knots

    def build(
        self,
        geometry: ToolGeometry,
        *,
        box_mass: float | None = None,
        box_offset: tuple[float, float, float] | None = None,
    ) -> bool:
        """Empty the world and set up floor, box, and the arm holding ``geometry`` at q(0).

        Args:
            geometry: the tool.
            box_mass: override of the scene's box mass, kg.
            box_offset: (dx m, dy m, dyaw rad) added to the scene's box pose (the other scenes
                of ``ObjectiveSpec.scene_samples``).

        Returns:
            Whether the tool, lowered to the start of the sweep, overlaps the box. Such a tool
            would be pressed down onto the box while lowering: an invalid design.
        """
        if box_mass is not None and not (math.isfinite(box_mass) and box_mass > 0):
            raise ValueError(f"box_mass must be a finite number > 0 kg, got {box_mass!r}")
        dx, dy, dyaw = (0.0, 0.0, 0.0) if box_offset is None else box_offset
        if not all(math.isfinite(v) for v in (dx, dy, dyaw)):
            raise ValueError(f"box_offset must be 3 finite numbers, got {box_offset!r}")
        contacts = self.scene.arm_floor_contacts
        self._last_build = (geometry, box_mass, box_offset)
        return self._build(geometry, box_mass, (dx, dy, dyaw), floor_contacts=contacts is True)

    def _build(
        self,
        geometry: ToolGeometry,
        box_mass: float | None,
        box_offset: tuple[float, float, float],
        *,
        floor_contacts: bool,
    ) -> bool:
        scene = self.scene
        dx, dy, dyaw = box_offset
        reference = self.reference
        world = self.world
        self._builds += 1
        if self._builds % RECONNECT_EVERY == 0:
            world.reconnect()  # else PyBullet's cache of loaded URDFs grows with every build
        world.reset()
        world.add_floor(friction=scene.floor_friction, arm_contacts=floor_contacts)
        self._box_mass = scene.box_mass if box_mass is None else float(box_mass)
        self._box = world.add_box(
            size=scene.box_size,
            mass=self._box_mass,
            friction=scene.box_friction,
            position=(
                scene.box_position[0] + dx,
                scene.box_position[1] + dy,
                scene.box_size[2] / 2.0,
            ),
            yaw=scene.box_yaw + dyaw,
        )
        world.step(int(round(scene.box_settle_time / scene.time_step)))
        link, diag = _principal_link_xml(geometry)
        merge = scene.merge_fixed_links
        robot = self._robot = world.load_robot(
            panda_urdf_with_tool(
                link, visuals=self._visuals, meshes=self._meshes, merge_hand=merge
            ),
            tool_mass=geometry.mass,
            tool_inertia_diagonal=(float(diag[0]), float(diag[1]), float(diag[2])),
            tool_friction=scene.tool_friction,
            floor_contacts=floor_contacts,
            link_inertias=(
                merged_hand_inertia(visuals=self._visuals, meshes=self._meshes) if merge else None
            ),
        )
        self._floor_contacts = floor_contacts
        self._guarded = scene.arm_floor_contacts == "auto" and not floor_contacts
        if self._guarded:
            self._set_up_floor_guard(geometry)
        lowered = phases(self.plan)[0].duration
        k = min(max(int(round(lowered / self.control_dt)) - 1, 0), len(reference.times) - 1)
        world.set_joint_positions(robot, reference.q[k])
        overlaps = world.overlaps(self._box, robot.body, robot.tool_link)
        world.set_joint_positions(robot, reference.q0)
        return overlaps

    def _set_up_floor_guard(self, geometry: ToolGeometry) -> None:
        """What :func:`floor_clearance_bound` needs, with the arm at q(0).

        The tool's group (the last arm link and every link after it: the hand, the fingers and
        the tool) is bounded, in the grasp frame whose pose the rollout records, by the corners
        of the tool's bounding box and of the other links' world bounding boxes, carried into
        that frame. What the other links need does not depend on the tool: it is found once per
        simulator (:meth:`_arm_levers`, :meth:`_arm_floor_of_plan`).
        """
        world, robot = self.world, self._robot
        assert robot is not None
        last = robot.joints[-1]
        links = world.link_count(robot)
        attached = [j for j in range(last, links) if j != robot.tool_link]
        # At q(0), where the hand points down: its links' boxes are tight there. (Just after
        # loading, PyBullet's boxes and link frames do not yet agree.)
        world.set_joint_positions(robot, self.reference.q0)
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
        self._guard_points = (corners - np.asarray(ee_position)) @ to_ee
        if self._arm_floor is None:
            levers, first, fixed = self._arm_levers(last)
            self._arm_floor = (levers, self._arm_floor_of_plan(first, last), fixed)
        # Between two records every point of the arm and the tool moves, so the levers of the
        # sub-steps reach to the tool's group too: the joint-to-joint lengths up to the last
        # joint plus the farthest corner of the group from it.
        origin = np.asarray(world.link_pose(robot, last)[0], dtype=float)
        radius = float(np.linalg.norm(corners - origin, axis=1).max())
        tool_levers = np.nan_to_num(self._arm_to_last + radius)
        self._substep_levers = np.maximum(self._arm_floor[0], tool_levers)
        # PyBullet keeps contact points closer than its breaking threshold, 0.02 m times the
        # shape's angular-motion disc (|AABB centre| + AABB half-diagonal, about the centre of
        # mass), in its own frame: the tool's grows with its size.
        self._guard_threshold = max(self.scene.floor_clearance, _breaking_threshold(geometry))

    def _arm_levers(self, last: int) -> tuple[np.ndarray, int, float]:
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
        world, robot = self.world, self._robot
        assert robot is not None
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
        self._arm_to_last = np.array(
            [to_last + steps[joint:].sum() if joint < last else 0.0 for joint in robot.joints]
        )
        if levers[0] == 0.0:
            self._arm_to_last[0] = math.nan
        first = 1 if levers[0] == 0.0 else 0
        fixed = float(boxes[:first, 0, 2].min()) if first else math.inf
        return levers, first, fixed

    def _arm_floor_of_plan(self, first: int, last: int) -> np.ndarray:
        """(T,) lowest point (m) of the links ``first`` to ``last - 1`` at each step of the plan.

        From memory, else from the plan cache on disk (the sweep costs about one evaluation,
        which would double the first evaluation of a process), else swept.
        """
        key = cache_key(
            {
                "arm_floor": FLOOR_GUARD_VERSION,
                "links": [first, last],
                "knots": plan_cache_key(self.plan),
                "control_dt": self.control_dt,
                # The references it sweeps (SciPy's splines, the plan's code) and its own code.
                "scipy": scipy.__version__,
                "source": [source_digest(m) for m in ("tooldesign_env.plan", __name__)],
            }
        )
        if key in _ARM_FLOOR:
            return _ARM_FLOOR[key]
        steps = len(self.reference.q)
        stored = load_knots(key, (1, steps))
        if stored is None:
            world, robot = self.world, self._robot
            assert robot is not None
            lowest = np.empty((1, steps))
            for k, q in enumerate(self.reference.q):
                world.set_joint_positions(robot, q)
                lowest[0, k] = world.link_boxes(robot, range(first, last))[:, 0, 2].min()
            world.set_joint_positions(robot, self.reference.q0)
            stored = lowest
            store_knots(key, stored)
        _ARM_FLOOR[key] = stored[0]
        return _ARM_FLOOR[key]

    # -------------------------------------------------------------- rollout
    def rollout(
        self,
        geometry: ToolGeometry,
        *,
        box_mass: float | None = None,
        box_offset: tuple[float, float, float] | None = None,
        snapshot_every: int | None = None,
    ) -> Trajectory:
        """Build the world for ``geometry`` and use the tool once (see :meth:`run`).

        The tool is used even if it overlaps the box at the start; to refuse such tools, call
        :meth:`build` and then :meth:`run` only when it answers False. ``box_mass`` and
        ``box_offset`` are those of :meth:`build`.
        """
        self.build(geometry, box_mass=box_mass, box_offset=box_offset)
        return self.run(snapshot_every=snapshot_every)

    def run(
        self, *, snapshot_every: int | None = None, record_mobility: bool = False
    ) -> Trajectory:
        """Use the tool of the last :meth:`build` once and record the trajectory.

        Args:
            snapshot_every: also save a world snapshot every this many control steps (before
                the step's torques are applied), for re-simulation.
            record_mobility: also record the contact manifold at every step in contact and
                return :attr:`Trajectory.contact_mobility` (for the contact estimator of Pi_U).

        Returns:
            The recorded :class:`Trajectory`.

        Build before every run: a second run after one build continues from where the first
        ended, unless the floor guard (``SceneSpec.arm_floor_contacts="auto"``) sends it back
        to be simulated again from the build.
        """
        if self._robot is None:
            raise RuntimeError("call build(geometry) before run()")
        if snapshot_every is not None and (
            isinstance(snapshot_every, bool)
            or not isinstance(snapshot_every, (int, np.integer))
            or snapshot_every < 1
        ):
            raise ValueError(f"snapshot_every must be None or an int >= 1, got {snapshot_every!r}")
        with _gc_paused():
            trajectory = self._run(snapshot_every, record_mobility)
        clearance = trajectory.floor_clearance
        if clearance is None or clearance >= self._guard_threshold:
            return trajectory
        # The arm or the tool may have come near the floor: simulate again with its contacts.
        if not self._guard_warned:
            self._guard_warned = True
            warnings.warn(
                f"the arm or the tool may have come within {max(clearance, 0.0):.3f} m of the "
                f"floor (the guard's limit: {self._guard_threshold:.3f} m): the "
                "episode is simulated again with their floor contacts; with this plan, "
                "SceneSpec(arm_floor_contacts=True) saves the first rollout",
                RuntimeWarning,
                stacklevel=2,
            )
        self.release_snapshots()
        assert self._last_build is not None
        geometry, box_mass, box_offset = self._last_build
        offset = (0.0, 0.0, 0.0) if box_offset is None else box_offset
        self._build(geometry, box_mass, offset, floor_contacts=True)
        with _gc_paused():
            again = self._run(snapshot_every, record_mobility)
        return dataclasses.replace(again, floor_clearance=clearance)

    def _run(self, snapshot_every: int | None, record_mobility: bool) -> Trajectory:
        ref = self.reference
        scene = self.scene
        n = len(ref.times)
        phase = self._phase_index(ref.times)
        hold = PHASES.index("hold")
        loop = _LoopSettings(
            phase=phase,
            hold_phase=hold,
            hold_from=int(np.argmax(phase == hold)) if np.any(phase == hold) else n,
            rest_needed=max(int(math.ceil(scene.rest_time / self.control_dt)), 1),
            record_mobility=record_mobility,
            snapshot_every=snapshot_every,
        )
        self._snapshots = None  # before the loop: a failed rollout leaves none behind
        native = self._native_loop()
        record = self._loop_native(native, loop) if native else self._loop_python(loop)
        if snapshot_every:
            ids = record.snapshots
            snapshots = _Snapshots(snapshot_every)
            regular = range(0, record.steps, snapshot_every)
            snapshots.ids = dict(zip(regular, ids, strict=False))
            if len(ids) > len(regular):  # the rest state's, taken when the loop fast-forwarded
                snapshots.ids[record.fast_forward_from] = ids[-1]
                snapshots.rest_from = record.fast_forward_from
            self._snapshots = snapshots
        return self._trajectory(record, loop)

    def _native_loop(self) -> NativeLoop | None:
        """The world's C control loop, or None where it cannot run (then the Python loop runs).

        Only a world without a render mode uses it: a GUI's server runs in its own thread, and
        a rendered rollout is no place to save microseconds.
        """
        if not self._use_native or self.world.render_mode is not None:
            if self.native_status == "not run yet":
                self.native_status = "Python loop: " + (
                    "native_loop=False" if not self._use_native else "the world renders"
                )
            return None
        if self._native is None:
            try:
                self._native = NativeLoop(self.world)
            except NativeLoopError as error:
                if self._native_requested:
                    raise  # and again on the next rollout: never the Python loop instead
                self._use_native = False
                self.native_status = f"Python loop: {error}"
                return None
            self.native_status = "native"
        return self._native

    def _loop_native(self, native: NativeLoop, loop: _LoopSettings) -> LoopRecord:
        robot, box = self._robot, self._box
        assert robot is not None and box is not None
        ref, scene, ctrl = self.reference, self.scene, self.controller
        return native.rollout(
            robot=robot.body,
            box=box,
            ee_link=robot.ee_link,
            tool_link=robot.tool_link,
            slots=self._slots(),
            period=ctrl.control_period,
            qdd_ref=ref.qdd,
            q_ref=ref.q,
            qd_ref=ref.qd,
            kp=ctrl.kp,
            kd=ctrl.kd,
            torque_limits=tuple(ctrl.torque_limits),
            fast_forward=scene.fast_forward_rest,
            rest_speed=scene.rest_speed,
            phase=loop.phase,
            hold_phase=loop.hold_phase,
            hold_from=loop.hold_from,
            rest_needed=loop.rest_needed,
            record_mobility=loop.record_mobility,
            snapshot_every=loop.snapshot_every,
        )

    def _slots(self) -> _JointSlots:
        """The arm joints' places in PyBullet's state vectors, read once per build."""
        assert self._robot is not None
        if self._joint_slots is None or self._joint_slots[0] is not self._robot:
            self._joint_slots = (self._robot, self.world.joint_slots(self._robot))
        return self._joint_slots[1]

    def _loop_python(self, loop: _LoopSettings) -> LoopRecord:
        """The control loop in Python: what the plugin (tooldesign_env.native) runs in C."""
        phase, hold_phase, hold_from = loop.phase, loop.hold_phase, loop.hold_from
        rest_needed, snapshot_every = loop.rest_needed, loop.snapshot_every
        record_mobility = loop.record_mobility
        world, robot, box = self.world, self._robot, self._box
        assert robot is not None and box is not None
        scene, ctrl = self.scene, self.controller
        n = len(self.reference.times)
        period = ctrl.control_period
        kp, kd = ctrl.kp, ctrl.kd

        # Per-step records, appended as plain tuples and turned into arrays once at the end.
        box_rows: list[tuple[float, ...]] = []
        torque_rows: list[list[float]] = []
        q_rows: list[tuple[float, ...]] = []
        qd_rows: list[tuple[float, ...]] = []  # for the floor guard's sub-steps
        tool_rows: list[tuple[float, ...]] = []
        orientations: list[tuple[float, ...]] = []
        counts: list[int] = []
        # Steps in contact, when recording: the step, the tool's centre of mass and PyBullet's
        # contact points.
        logged: list[tuple[int, tuple[float, ...], tuple[Any, ...]]] = []
        snapshot_ids: list[int] = []
        at_rest = 0
        fast_forward_from = n

        # The hot loop works on plain floats: NumPy's per-call overhead on 7-vectors cost more
        # than the arithmetic. The operations and their order are those of
        # qdd_ref + kp (q_ref - q) + kd (qd_ref - qd) and clip, so results are bit-identical.
        # Every PyBullet call is pre-bound (ControlCalls), and what can wait for the end of the
        # rollout (the tool's yaw, the arrays) does.
        calls = world.control_calls(robot, box, robot.tool_link)
        joint_states, inverse_dynamics = calls.joint_states, calls.inverse_dynamics
        motor, physics_step = calls.motor, calls.step
        link_state, link_states = calls.link_state, calls.link_states
        box_pose, contacts, box_velocity = calls.box_pose, calls.contacts, calls.box_velocity
        targets = self._targets()
        limits = list(ctrl.torque_limits)
        fast_forward = scene.fast_forward_rest
        rest_speed = scene.rest_speed
        q, qd, _, _ = zip(*joint_states(), strict=True)
        for k in range(n):
            if snapshot_every and k % snapshot_every == 0:
                snapshot_ids.append(world.save_state())
            qdd_ref, q_ref, qd_ref = targets[k]
            qdd = [
                a + kp * (b - x) + kd * (c - v)
                for a, b, c, x, v in zip(qdd_ref, q_ref, qd_ref, q, qd, strict=True)
            ]
            command = [
                -lim if t < -lim else (lim if t > lim else t)
                for t, lim in zip(inverse_dynamics(q, qd, qdd), limits, strict=True)
            ]
            torque_rows.append(command)
            for _ in range(period):
                motor(forces=command)
                physics_step()
            q, qd, _, _ = zip(*joint_states(), strict=True)
            box_now = box_pose()[0]
            box_rows.append(box_now)
            q_rows.append(q)
            qd_rows.append(qd)
            manifold = contacts()
            if manifold and record_mobility:
                ee, tool = link_states()
                logged.append((k, tool[0], manifold))
            else:
                ee = link_state()
            tool_rows.append(ee[4])
            orientations.append(ee[5])
            counts.append(len(manifold))
            if fast_forward and k >= hold_from and phase[k] == hold_phase:
                box_speed = np.linalg.norm(box_velocity()[0])
                still = box_speed < rest_speed and max(map(abs, qd)) < rest_speed
                at_rest = at_rest + 1 if still else 0
                if at_rest >= rest_needed and k + 1 < n:
                    fast_forward_from = k + 1
                    if snapshot_every:
                        # One snapshot of the rest state serves every fast-forwarded step.
                        snapshot_ids.append(world.save_state())
                    break
        steps = len(q_rows)
        flat = itertools.chain.from_iterable

        def rows(values: list[Any], width: int) -> np.ndarray:
            # Flattened: much faster than np.array's shape discovery on nested rows.
            return np.fromiter(flat(values), float, len(values) * width).reshape(-1, width)

        manifold_points = [point for _, _, manifold in logged for point in manifold]
        return LoopRecord(
            torques=rows(torque_rows, 7),
            q=rows(q_rows, 7),
            qd=rows(qd_rows, 7),
            box_position=rows(box_rows, 3),
            ee_position=rows(tool_rows, 3),
            ee_orientation=rows(orientations, 4),
            contact_points=np.array(counts, dtype=np.int32).reshape(steps),
            fast_forward_from=fast_forward_from,
            snapshots=tuple(snapshot_ids),
            logged_steps=np.array([k for k, _, _ in logged], dtype=np.intp),
            tool_com=rows([com for _, com, _ in logged], 3),
            # PyBullet's contact points: position on the tool [6] and normal [7], 3 floats each.
            points=rows([(*m[6], *m[7]) for m in manifold_points], 6),
        )

    def _trajectory(self, record: LoopRecord, loop: _LoopSettings) -> Trajectory:
        """The :class:`Trajectory` of a loop's record: the fast-forward, the guard, the mobility."""
        ref, scene = self.reference, self.scene
        n = len(ref.times)
        steps = record.steps
        fast_forward_from = record.fast_forward_from
        orientations = record.ee_orientation.tolist()
        yaw_rows = [_tool_yaw(o) for o in orientations]
        clearance = None
        if self._guarded:
            assert self._guard_points is not None and self._arm_floor is not None
            levers, plan_floor, fixed = self._arm_floor
            # How far a point of the links before the last joint may have strayed from its
            # planned place: each joint's error times its lever (see _arm_levers).
            strayed = np.abs(record.q - ref.q[:steps]) @ levers
            # Bullet integrates positions with the step's new velocities, so the physics
            # step before a record was at q - h qd: its points were at most h |qd| . levers
            # away (exact for a control period of 2; with more sub-steps their velocities are
            # taken to be the recorded one).
            period = self.controller.control_period
            between = (period - 1) * scene.time_step * (np.abs(record.qd) @ self._substep_levers)
            clearance = floor_clearance_bound(
                record.ee_position,
                record.ee_orientation,
                self._guard_points,
                plan_floor[:steps],
                strayed,
                between,
            )
            clearance = min(clearance, fixed)
        # The scene is static and the reference constant after a fast-forward: every remaining
        # step repeats the last one (the controller's torque at rest is the gravity torque it
        # just applied).
        repeat = n - fast_forward_from

        def table(simulated: np.ndarray) -> np.ndarray:
            if not repeat:
                return simulated
            return np.concatenate([simulated, np.repeat(simulated[-1:], repeat, axis=0)])

        tool_position = table(record.ee_position)
        torques = table(record.torques)
        self._last_torques = torques
        mobility = None
        if loop.record_mobility:
            mobility = self._mobility(record, n)
            if fast_forward_from < n:
                # The fast-forwarded steps repeat the rest state. Its mobility is the mean over
                # the steps that found the scene at rest, not the last step alone: one contact
                # manifold, repeated for seconds, would carry that step's noise into all of them.
                rest = mobility[fast_forward_from - loop.rest_needed : fast_forward_from]
                mobility[fast_forward_from:] = rest.mean(axis=0)
        return Trajectory(
            times=ref.times.copy(),
            box_position=table(record.box_position),
            torques=torques,
            joint_positions=table(record.q),
            tool_position=tool_position,
            tool_yaw=table(np.array(yaw_rows, dtype=float)),
            contact=table(record.contact_points > 0),
            phase=loop.phase,
            tracking_error=np.linalg.norm(tool_position - ref.ee_position, axis=1),
            fast_forward_from=fast_forward_from,
            contact_mobility=mobility,
            floor_contacts=self._floor_contacts,
            floor_clearance=clearance,
        )

    def _mobility(self, record: LoopRecord, n: int) -> np.ndarray:
        """(n, 3, 7) mean :func:`contact_mobility` over the manifold of each logged step.

        The mean, not the sum, so that a manifold that gains or loses a duplicate point does
        not change it. The Jacobians and the mass matrix are functions of q alone, so they are
        computed here, after the rollout, rather than inside the control loop.
        """
        out = np.zeros((n, 3, 7))
        logged = record.logged_steps
        steps = len(logged)
        if not steps:
            return out
        jacobians, mass = self._arm_matrices(record.q[logged])
        counts = record.contact_points[logged].astype(np.intp)
        owner = np.repeat(np.arange(steps), counts)  # the step of each contact point
        points = record.points
        per_point = contact_mobility(
            np.ascontiguousarray(points[:, :3]),
            np.ascontiguousarray(points[:, 3:]),
            record.tool_com[owner],
            jacobians[owner, 0],
            jacobians[owner, 1],
            np.linalg.inv(mass)[owner],
            record.box_position[logged][owner],
            self._box_mass,
            self.scene.box_size,
        )
        per_step = np.zeros((steps, 3, 7))
        np.add.at(per_step, owner, per_point)
        out[logged] = per_step / counts[:, None, None]
        return out

    def _arm_matrices(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The tool's centre-of-mass Jacobians (m, 2, 3, 7) and M(q) (m, 7, 7) at q (m, 7)."""
        robot = self._robot
        assert robot is not None
        native = self._native_loop()
        if native is not None:
            return native.arm_matrices(robot=robot.body, tool_link=robot.tool_link, q=q)
        steps = q.shape[0]
        # PyBullet's nested tuples are flattened and converted to arrays once: converting each
        # step's small matrices separately cost more than the calls themselves.
        jacobian, mass_matrix = self.world.jacobian_calls(robot, robot.tool_link)
        flat = itertools.chain.from_iterable
        rows = q.tolist()
        jacobians = np.fromiter(
            flat(flat(flat(jacobian(row) for row in rows))),
            dtype=np.float64,
            count=steps * 2 * 3 * 7,
        ).reshape(steps, 2, 3, 7)
        mass = np.fromiter(
            flat(flat(mass_matrix(row) for row in rows)),
            dtype=np.float64,
            count=steps * 7 * 7,
        ).reshape(steps, 7, 7)
        return jacobians, mass

    def replay_open_loop(
        self, geometry: ToolGeometry, torques: np.ndarray, *, box_mass: float | None = None
    ) -> np.ndarray:
        """Build the scene and apply a torque sequence with no controller in the loop.

        The same physics as a rollout without the controller's reads and inverse dynamics:
        benchmarks use it as the floor of a rollout's cost. It runs in the same loop, C or
        Python, as :meth:`run` would (see :mod:`tooldesign_env.native`). With
        ``SceneSpec.arm_floor_contacts="auto"`` it runs without the arm's floor contacts, as a
        rollout that the floor guard let pass, but nothing checks the clearance.

        Args:
            geometry: the tool.
            torques: (n, 7) torques per control step, N m.
            box_mass: override of the box mass, kg.

        Returns:
            (n, 3) box positions after each control step, m.
        """
        torques = np.asarray(torques, dtype=float)
        if torques.ndim != 2 or torques.shape[1] != 7 or not np.all(np.isfinite(torques)):
            raise ValueError(f"torques must be a finite (n, 7) array, got shape {torques.shape}")
        self.build(geometry, box_mass=box_mass)
        world, robot, box = self.world, self._robot, self._box
        assert robot is not None and box is not None
        period = self.controller.control_period
        native = self._native_loop()
        if native is not None:
            return native.replay(
                robot=robot.body, box=box, slots=self._slots(), period=period, torques=torques
            )
        # The same bound calls as the control loop of run(), so that the two differ only by
        # the controller and the recording.
        calls = world.control_calls(robot, box, robot.tool_link)
        motor, physics_step, box_pose = calls.motor, calls.step, calls.box_pose
        rows = []
        with _gc_paused():  # as in run(), so that the two differ only by what run() adds
            for command in torques.tolist():
                for _ in range(period):
                    motor(forces=command)
                    physics_step()
                rows.append(box_pose()[0])
        return np.array(rows, dtype=float).reshape(-1, 3)

    def _phase_index(self, times: np.ndarray) -> np.ndarray:
        index = np.zeros(times.shape[0], dtype=np.int8)
        for seg in phases(self.plan):
            # A step belongs to the segment in which it starts.
            starts = times - self.control_dt
            index[starts >= seg.start - 1e-9] = PHASES.index(seg.name)
        return index

    # ---------------------------------------------------------- re-simulate
    def replay_responses(self, k: int, horizon: int, offsets: np.ndarray) -> np.ndarray:
        """Box positions after replaying the recorded torques with constant offsets.

        Restores the snapshot taken before control step ``k`` and, for each row of ``offsets``,
        replays the torques of steps ``k .. k + horizon - 1`` open loop with that offset added,
        then reads the box position. Every response starts from the same restore, so differences
        between responses are free of PyBullet's inexact restore while in contact.

        Args:
            k: a control step at which a snapshot was taken.
            horizon: control steps to replay.
            offsets: (m, 7) torque offsets, N m.

        Returns:
            (m, 3) box positions, m.
        """
        snaps = self._snapshots
        if snaps is not None and snaps.rest_from is not None and k >= snaps.rest_from:
            # Every fast-forwarded step is the same rest state under the same torques.
            key = np.asarray(offsets, dtype=float).tobytes() + horizon.to_bytes(4, "little")
            if key not in snaps.rest_responses:
                snaps.rest_responses[key] = self._replay(snaps.rest_from, horizon, offsets)
            return cast("np.ndarray", snaps.rest_responses[key].copy())
        if snaps is None or k not in snaps.ids:
            raise ValueError(f"no snapshot at control step {k}: roll out with snapshot_every first")
        return self._replay(k, horizon, offsets)

    def _replay(self, k: int, horizon: int, offsets: np.ndarray) -> np.ndarray:
        assert self._snapshots is not None
        world, robot, box = self.world, self._robot, self._box
        assert robot is not None and box is not None and self._last_torques is not None
        torques = self._last_torques
        n = torques.shape[0]
        period = self.controller.control_period
        limits = np.asarray(self.controller.torque_limits)
        out = np.empty((offsets.shape[0], 3))
        for i, offset in enumerate(np.asarray(offsets, dtype=float)):
            world.restore_state(self._snapshots.ids[k])
            for j in range(k, min(k + horizon, n)):
                command = np.clip(torques[j] + offset, -limits, limits).tolist()
                world.step_with_torques(robot, command, period)
            out[i] = world.body_position(box)
        return out

    def release_snapshots(self) -> None:
        """Free the snapshots of the last rollout."""
        self.world.drop_states()
        self._snapshots = None

    def render(self, **camera: float) -> np.ndarray:
        """An RGB frame (H, W, 3) uint8 of the current scene."""
        return self.world.render(**camera)  # type: ignore[arg-type]

    def close(self) -> None:
        """Release the physics client; safe to call more than once."""
        self.world.close()


@contextlib.contextmanager
def _gc_paused() -> Iterator[None]:
    """Pause Python's cyclic garbage collector inside the block (restored after it).

    A rollout allocates a few tuples and lists per control step and no reference cycles, yet
    those allocations trigger collections that walk every object the process holds (tens of
    thousands after importing SciPy): about 3-5 % of a rollout. Reference counting still frees
    everything at once; only the search for cycles waits until the block ends.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def _tool_yaw(ee_orientation: tuple[Any, ...]) -> float:
    """Yaw of the tool frame from the end-effector quaternion (x, y, z, w).

    The tool frame is the end-effector frame turned by Rx(pi); its x axis is the end effector's.
    """
    x, y, z, w = ee_orientation
    # First column of the rotation matrix: the end effector's x axis in the world.
    r00 = 1.0 - 2.0 * (y * y + z * z)
    r10 = 2.0 * (x * y + z * w)
    return math.atan2(r10, r00)
