"""One use of a tool: the Panda follows the plan pi_0 under computed-torque control.

The tool is a link of the robot (fixed to the grasp target), so the controller's inverse dynamics
includes the tool's mass and inertia, and different tools produce different torques U for the same
plan. A rollout records, per control step, the box position X (3), the torques U (7) and what is
needed to plot and diagnose (grasp-point pose, joint positions, tool-box contact).

:class:`ToolSimulator` composes the parts, each in its own module: the client wrapper
(:mod:`tooldesign_env.bullet`), the robot model and its asset caches
(:mod:`tooldesign_env.robot_model`, :mod:`tooldesign_env.lean_meshes`), the plan's references and
their cache (:mod:`tooldesign_env.reference`), the floor guard (:mod:`tooldesign_env.floor_guard`),
the control loops (:mod:`tooldesign_env.control_loop`, :mod:`tooldesign_env.native`) and the
contact mobility (:mod:`tooldesign_env.mobility`). What it keeps is the scene's build, the rollout's
assembly into a :class:`~tooldesign_env.rollout.Trajectory`, and the snapshots for re-simulation.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from tooldesign_env import scene_objects
from tooldesign_env.bullet import BulletWorld, RobotHandles, not_copyable
from tooldesign_env.control_loop import ControlLoops, LoopSettings, gc_paused
from tooldesign_env.floor_guard import FloorGuard, floor_clearance_bound
from tooldesign_env.geometry import ToolGeometry
from tooldesign_env.lean_meshes import lean_collision_meshes
from tooldesign_env.mobility import contact_mobility, mobility_series
from tooldesign_env.native import LoopRecord
from tooldesign_env.plan import JointReference, cache_dir, phases
from tooldesign_env.reference import plan_cache_key, plan_reference
from tooldesign_env.robot_model import (
    merged_hand_inertia,
    panda_urdf_with_tool,
    principal_inertia,
    tool_link_with_principal_axes,
)
from tooldesign_env.rollout import Recording, Rollout, Trajectory, tool_yaws
from tooldesign_env.specs import ControllerSpec, PlanSpec, SceneSpec
from tooldesign_env.tasks.base import Obstacle

__all__ = [
    "PHASES",
    "BuildResult",
    "ToolSimulator",
    "Trajectory",
    "contact_mobility",
    "floor_clearance_bound",
    "plan_cache_key",
    "principal_inertia",
]

PHASES = ("lower", "settle", "sweep", "pull", "hold")

#: Builds between two fresh physics servers (see BulletWorld.reconnect).
RECONNECT_EVERY = 100

#: Why a tool that overlaps the box at the start is not used (``BuildResult.reason``).
OVERLAP_REASON = "overlaps the box at the start of the sweep"

#: Why a tool that overlaps a fixed obstacle at the start is not used.
OBSTACLE_REASON = "overlaps a fixed obstacle at the start of the sweep"


@dataclass(frozen=True)
class BuildResult:
    """What :meth:`ToolSimulator.build` found about the tool in the scene it built.

    Attributes:
        overlaps_box: the tool, lowered to the start of the sweep, overlaps the box. Such a
            tool would be pressed down onto the box while lowering: an invalid design.
        overlaps_obstacle: the same with one of a task's fixed obstacles: invalid as well.
    """

    overlaps_box: bool
    overlaps_obstacle: bool = False

    @property
    def usable(self) -> bool:
        """Whether the tool may be used (it overlaps neither the box nor an obstacle)."""
        return not (self.overlaps_box or self.overlaps_obstacle)

    @property
    def reason(self) -> str:
        """Why the tool may not be used, or "" when it may."""
        other = OBSTACLE_REASON if self.overlaps_obstacle else ""
        return OVERLAP_REASON if self.overlaps_box else other

    def __bool__(self) -> bool:
        # build() answered True for a failure before it returned this: a truth test is
        # ambiguous, so it is refused rather than silently read the other way round.
        raise TypeError(
            "a BuildResult is neither true nor false: read .usable or .overlaps_box "
            "(ToolSimulator.build returned True for an overlapping tool before)"
        )


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
        obstacles, object_shape: a task's fixed bodies (``Obstacle``) and the moved object's
            shape, ``"box"`` or ``"cylinder"`` (:mod:`tooldesign_env.scene_objects`).
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
        obstacles: tuple[Obstacle, ...] = (),
        object_shape: str = "box",
    ) -> None:
        self.obstacles, self.object_shape = scene_objects.checked(obstacles, object_shape)
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
        # The last build's arguments, to build again with the floor contacts when the floor
        # guard (SceneSpec.arm_floor_contacts == "auto") asks for it.
        self._last_build: tuple[ToolGeometry, float | None, Any] | None = None
        self._guarded = False
        self._overlaps_obstacle = False
        self._guard = FloorGuard(self.scene)
        self._loops = ControlLoops(native_loop)

    # ---------------------------------------------------------------- setup
    @property
    def control_dt(self) -> float:
        """Control period, s."""
        return self.scene.time_step * self.controller.control_period

    @property
    def reference(self) -> JointReference:
        """Joint references of the plan (computed on first use, then cached)."""
        if self._reference is None:
            self._reference = plan_reference(self.plan, self.control_dt, self.world)
        return self._reference

    @property
    def native_status(self) -> str:
        """Which loop the last rollout ran, and why not the C one.

        ``"native"``, ``"Python loop: <why>"``, or ``"not run yet"``.
        """
        return self._loops.status

    def build(
        self,
        geometry: ToolGeometry,
        *,
        box_mass: float | None = None,
        box_offset: tuple[float, float, float] | None = None,
    ) -> BuildResult:
        """Empty the world and set up floor, box, and the arm holding ``geometry`` at q(0).

        Args:
            geometry: the tool.
            box_mass: override of the scene's box mass, kg.
            box_offset: (dx m, dy m, dyaw rad) added to the scene's box pose (the other scenes
                of ``ObjectiveSpec.scene_samples``).

        Returns:
            Whether the tool may be used: :attr:`BuildResult.overlaps_box` is true when the
            tool, lowered to the start of the sweep, overlaps the box (the world is built all
            the same, and :meth:`run` would use it).
        """
        if box_mass is not None and not (math.isfinite(box_mass) and box_mass > 0):
            raise ValueError(f"box_mass must be a finite number > 0 kg, got {box_mass!r}")
        dx, dy, dyaw = (0.0, 0.0, 0.0) if box_offset is None else box_offset
        if not all(math.isfinite(v) for v in (dx, dy, dyaw)):
            raise ValueError(f"box_offset must be 3 finite numbers, got {box_offset!r}")
        contacts = self.scene.arm_floor_contacts
        self._last_build = (geometry, box_mass, box_offset)
        overlaps = self._build(geometry, box_mass, (dx, dy, dyaw), floor_contacts=contacts is True)
        return BuildResult(overlaps_box=overlaps, overlaps_obstacle=self._overlaps_obstacle)

    def _build(
        self,
        geometry: ToolGeometry,
        box_mass: float | None,
        box_offset: tuple[float, float, float],
        *,
        floor_contacts: bool,
    ) -> bool:
        """Build the world; whether the tool overlaps the box at the start of the sweep."""
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
        start = (scene.box_position[0] + dx, scene.box_position[1] + dy)
        self._box, blocks = self.add_bodies(self._box_mass, start, scene.box_yaw + dyaw)
        world.step(int(round(scene.box_settle_time / scene.time_step)))
        link, diag = tool_link_with_principal_axes(geometry)
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
            self._guard.set_up(world, robot, geometry, reference, self.plan, self.control_dt)
        lowered = phases(self.plan)[0].duration
        k = min(max(int(round(lowered / self.control_dt)) - 1, 0), len(reference.times) - 1)
        world.set_joint_positions(robot, reference.q[k])
        overlaps = world.overlaps(self._box, robot.body, robot.tool_link)
        self._overlaps_obstacle = any(
            world.overlaps(block, robot.body, robot.tool_link) for block in blocks
        )
        world.set_joint_positions(robot, reference.q0)
        return overlaps

    def add_bodies(self, mass: float, at: tuple[float, float], yaw: float) -> tuple[int, list[int]]:
        """Put the moved object (mass kg, at (x, y) m, yaw rad), then the obstacles; their ids."""
        world, shape = self.world, self.object_shape
        box = scene_objects.add_moved_object(world, self.scene, shape, mass, at, yaw)
        return box, scene_objects.add_obstacles(world, self.obstacles)

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
        :meth:`build` and then :meth:`run` only when its result is ``usable``. ``box_mass``
        and ``box_offset`` are those of :meth:`build`.
        """
        self.build(geometry, box_mass=box_mass, box_offset=box_offset)
        return self.run(snapshot_every=snapshot_every)

    def record(self, recording: Recording | None = None) -> Rollout:
        """Use the tool of the last :meth:`build` once, recording what ``recording`` asks for.

        Args:
            recording: the estimator's needs (:class:`~tooldesign_env.rollout.Recording`);
                None records the trajectory alone.

        Returns:
            The :class:`~tooldesign_env.rollout.Rollout`: the trajectory, the control period,
            the contact log (with ``recording.contact_mobility``) and a replay handle (with
            ``recording.snapshot_every``), valid until :meth:`release_snapshots` or the next
            build. :meth:`recorded` releases the snapshots for you.
        """
        if recording is None:
            recording = Recording()
        elif not isinstance(recording, Recording):
            raise TypeError(
                f"recording must be a Recording or None, got {type(recording).__name__} "
                f"{recording!r}"
            )
        trajectory = self.run(
            snapshot_every=recording.snapshot_every,
            record_mobility=recording.contact_mobility,
        )
        replay = self.replay_responses if recording.snapshot_every is not None else None
        return Rollout.of(trajectory, self.control_dt, replay)

    @contextlib.contextmanager
    def recorded(self, recording: Recording | None = None) -> Iterator[Rollout]:
        """:meth:`record` as a context: the rollout's snapshots are released when it ends."""
        try:
            yield self.record(recording)
        finally:
            self.release_snapshots()

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
        with gc_paused():
            trajectory = self._run(snapshot_every, record_mobility)
        clearance = trajectory.floor_clearance
        guard = self._guard
        if clearance is None or clearance >= guard.threshold:
            return trajectory
        # The arm or the tool may have come near the floor: simulate again with its contacts.
        if not guard.warned:
            guard.warned = True
            warnings.warn(
                f"the arm or the tool may have come within {max(clearance, 0.0):.3f} m of the "
                f"floor (the guard's limit: {guard.threshold:.3f} m): the "
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
        with gc_paused():
            again = self._run(snapshot_every, record_mobility)
        return dataclasses.replace(again, floor_clearance=clearance)

    def _run(self, snapshot_every: int | None, record_mobility: bool) -> Trajectory:
        ref = self.reference
        scene = self.scene
        n = len(ref.times)
        phase = self._phase_index(ref.times)
        hold = PHASES.index("hold")
        loop = LoopSettings(
            phase=phase,
            hold_phase=hold,
            hold_from=int(np.argmax(phase == hold)) if np.any(phase == hold) else n,
            rest_needed=max(int(math.ceil(scene.rest_time / self.control_dt)), 1),
            record_mobility=record_mobility,
            snapshot_every=snapshot_every,
        )
        self._snapshots = None  # before the loop: a failed rollout leaves none behind
        robot, box = self._robot, self._box
        assert robot is not None and box is not None
        record = self._loops.rollout(self.world, robot, box, ref, scene, self.controller, loop)
        # The box's pose now is its final one (a fast-forward repeats the rest state): read
        # once, it costs no step and changes nothing simulated.
        box_orientation = tuple(float(v) for v in self.world.body_pose(box)[1])
        if snapshot_every:
            ids = record.snapshots
            snapshots = _Snapshots(snapshot_every)
            regular = range(0, record.steps, snapshot_every)
            snapshots.ids = dict(zip(regular, ids, strict=False))
            if len(ids) > len(regular):  # the rest state's, taken when the loop fast-forwarded
                snapshots.ids[record.fast_forward_from] = ids[-1]
                snapshots.rest_from = record.fast_forward_from
            self._snapshots = snapshots
        return self._trajectory(record, loop, box_orientation)

    def _trajectory(
        self,
        record: LoopRecord,
        loop: LoopSettings,
        box_orientation: tuple[float, ...] | None = None,
    ) -> Trajectory:
        """The :class:`Trajectory` of a loop's record: the fast-forward, the guard, the mobility."""
        ref = self.reference
        n = len(ref.times)
        fast_forward_from = record.fast_forward_from
        yaw_rows = tool_yaws(np.asarray(record.ee_orientation, dtype=float))
        clearance = None
        if self._guarded:
            clearance = self._guard.clearance(record, ref, self.controller)
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
            robot = self._robot
            assert robot is not None

            def arm_matrices(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
                return self._loops.arm_matrices(self.world, robot, q)

            size = scene_objects.inertia_footprint(self.scene, self.object_shape)
            mobility = mobility_series(record, n, arm_matrices, self._box_mass, size)
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
            box_final_orientation=box_orientation,
        )

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
        robot, box = self._robot, self._box
        assert robot is not None and box is not None
        return self._loops.replay(self.world, robot, box, self.controller.control_period, torques)

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
