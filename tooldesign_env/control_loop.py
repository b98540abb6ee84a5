"""The control loops: computed-torque control of the arm along the plan, in Python or in C.

:func:`python_loop` is the loop in Python; :mod:`tooldesign_env.native` runs the same loop in C,
inside PyBullet's server, with the same requests in the same order and the same floating-point
operations (``tests/test_native_loop.py``). :class:`ControlLoops` picks one per simulator, says
which ran and why (``status``), and offers the two other things either can do: replay a torque
sequence open loop, and the arm's Jacobians and mass matrices along a trajectory.
"""

from __future__ import annotations

import contextlib
import gc
import itertools
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from tooldesign_env.bullet import BulletWorld, RobotHandles
from tooldesign_env.native import LoopRecord, NativeLoop, NativeLoopError
from tooldesign_env.plan import JointReference
from tooldesign_env.specs import ControllerSpec, SceneSpec

__all__ = ["ControlLoops", "LoopSettings", "gc_paused", "python_loop", "targets"]

#: (qdd_ref, q_ref, qd_ref) per control step, as plain floats.
Targets = list[tuple[list[float], list[float], list[float]]]

#: The arm joints' indices in PyBullet's state vectors: (q indices, u indices).
JointSlots = tuple[tuple[int, ...], tuple[int, ...]]


@dataclass(frozen=True)
class LoopSettings:
    """What a control loop needs beyond the simulator's specs, per rollout.

    Attributes:
        phase: (n,) index into ``PHASES`` of each control step.
        hold_phase: ``PHASES.index("hold")``.
        hold_from: the first step of the final hold.
        rest_needed: steps at rest before the loop fast-forwards.
        record_mobility: record the contact manifold at every step in contact.
        snapshot_every: save a world snapshot every this many control steps, or None.
    """

    phase: np.ndarray
    hold_phase: int
    hold_from: int
    rest_needed: int
    record_mobility: bool
    snapshot_every: int | None


@contextlib.contextmanager
def gc_paused() -> Iterator[None]:
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


def targets(reference: JointReference) -> Targets:
    """(qdd_ref, q_ref, qd_ref) per control step as plain floats, for :func:`python_loop`."""
    return list(
        zip(reference.qdd.tolist(), reference.q.tolist(), reference.qd.tolist(), strict=True)
    )


class ControlLoops:
    """The C loop where it can run, else the Python loop, for one simulator.

    Args:
        native_loop: None: the C loop where the plugin is available and the world renders
            nothing, else the Python loop; True: the C loop or an error saying why not; False:
            always the Python loop.
    """

    def __init__(self, native_loop: bool | None) -> None:
        self._native: NativeLoop | None = None
        self._use_native = native_loop is not False
        self._requested = native_loop is True
        self._joint_slots: tuple[RobotHandles, JointSlots] | None = None
        self._targets: tuple[JointReference, Targets] | None = None
        #: Which loop the last rollout ran, and why not the C one ("native" or "Python loop: ...").
        self.status = "not run yet"

    def native(self, world: BulletWorld) -> NativeLoop | None:
        """The world's C control loop, or None where it cannot run (then the Python loop runs).

        Only a world without a render mode uses it: a GUI's server runs in its own thread, and
        a rendered rollout is no place to save microseconds.
        """
        if not self._use_native or world.render_mode is not None:
            if self.status == "not run yet":
                self.status = "Python loop: " + (
                    "native_loop=False" if not self._use_native else "the world renders"
                )
            return None
        if self._native is None:
            try:
                self._native = NativeLoop(world)
            except NativeLoopError as error:
                if self._requested:
                    raise  # and again on the next rollout: never the Python loop instead
                self._use_native = False
                self.status = f"Python loop: {error}"
                return None
            self.status = "native"
        return self._native

    def slots(self, world: BulletWorld, robot: RobotHandles) -> JointSlots:
        """The arm joints' places in PyBullet's state vectors, read once per build."""
        if self._joint_slots is None or self._joint_slots[0] is not robot:
            self._joint_slots = (robot, world.joint_slots(robot))
        return self._joint_slots[1]

    def rollout(
        self,
        world: BulletWorld,
        robot: RobotHandles,
        box: int,
        reference: JointReference,
        scene: SceneSpec,
        ctrl: ControllerSpec,
        loop: LoopSettings,
    ) -> LoopRecord:
        """One rollout along ``reference`` in the loop that can run."""
        native = self.native(world)
        if native is None:
            if self._targets is None or self._targets[0] is not reference:
                self._targets = (reference, targets(reference))  # once per reference
            rows = self._targets[1]
            return python_loop(world, robot, box, rows, scene, ctrl, loop)
        return native.rollout(
            robot=robot.body,
            box=box,
            ee_link=robot.ee_link,
            tool_link=robot.tool_link,
            slots=self.slots(world, robot),
            period=ctrl.control_period,
            qdd_ref=reference.qdd,
            q_ref=reference.q,
            qd_ref=reference.qd,
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

    def replay(
        self, world: BulletWorld, robot: RobotHandles, box: int, period: int, torques: np.ndarray
    ) -> np.ndarray:
        """(n, 3) box positions after applying (n, 7) torques open loop, one row per step."""
        native = self.native(world)
        if native is not None:
            return native.replay(
                robot=robot.body,
                box=box,
                slots=self.slots(world, robot),
                period=period,
                torques=torques,
            )
        # The same bound calls as the Python control loop, so that the two differ only by
        # the controller and the recording.
        calls = world.control_calls(robot, box, robot.tool_link)
        motor, physics_step, box_pose = calls.motor, calls.step, calls.box_pose
        rows = []
        with gc_paused():  # as in a rollout, so that the two differ only by what it adds
            for command in torques.tolist():
                for _ in range(period):
                    motor(forces=command)
                    physics_step()
                rows.append(box_pose()[0])
        return np.array(rows, dtype=float).reshape(-1, 3)

    def arm_matrices(
        self, world: BulletWorld, robot: RobotHandles, q: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The tool's centre-of-mass Jacobians (m, 2, 3, 7) and M(q) (m, 7, 7) at q (m, 7)."""
        native = self.native(world)
        if native is not None:
            return native.arm_matrices(robot=robot.body, tool_link=robot.tool_link, q=q)
        steps = q.shape[0]
        # PyBullet's nested tuples are flattened and converted to arrays once: converting each
        # step's small matrices separately cost more than the calls themselves.
        jacobian, mass_matrix = world.jacobian_calls(robot, robot.tool_link)
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


def python_loop(
    world: BulletWorld,
    robot: RobotHandles,
    box: int,
    targets: Sequence[tuple[list[float], list[float], list[float]]],
    scene: SceneSpec,
    ctrl: ControllerSpec,
    loop: LoopSettings,
) -> LoopRecord:
    """The control loop in Python: what the plugin (:mod:`tooldesign_env.native`) runs in C.

    Args:
        world: the world, built.
        robot: the arm holding the tool.
        box: the box's body id.
        targets: (qdd_ref, q_ref, qd_ref) per control step as plain floats (:func:`targets`).
        scene: the scene (fast-forward settings).
        ctrl: the controller.
        loop: the rollout's settings.
    """
    phase, hold_phase, hold_from = loop.phase, loop.hold_phase, loop.hold_from
    rest_needed, snapshot_every = loop.rest_needed, loop.snapshot_every
    record_mobility = loop.record_mobility
    n = len(targets)
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
