"""The one module that imports PyBullet: the client wrapper.

It owns a physics client per instance (never PyBullet's global connection), builds the bodies of the
scene, saves and restores state, and exposes the few fast calls the control loop needs. Everything
else in the library asks it (``tests/test_architecture.py`` checks that no other module imports
``pybullet``, ``pybullet_data`` or ``pybullet_utils``). The robot model and its asset caches are
:mod:`tooldesign_env.robot_model` and :mod:`tooldesign_env.lean_meshes`.

Longer than 600 lines for that reason: every PyBullet call of the library is one short method of
:class:`BulletWorld` here, and splitting the class would only spread the one connection it owns
over several files.
"""

from __future__ import annotations

import contextlib
import functools
import importlib.metadata
import os
import re
import sys
import tempfile
import uuid
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import IO, Any, NamedTuple, cast

import numpy as np

# PyBullet's C code prints a banner ("pybullet build time", "argv[0]=") and renderer warnings
# ("b3Warning[...]") straight to the file descriptors, where Python's redirection cannot reach.
# These lines are recognised and dropped; anything else the C code prints is passed on unchanged.
_NOISE = re.compile(r"^(pybullet build time:|argv\[\d+\]=|b3Warning\[|b3Printf:)")


@contextlib.contextmanager
def _quiet_pybullet() -> Iterator[None]:
    """Drop PyBullet's banner and warning lines printed to fd 1 and 2 inside the block.

    Every other line is written back to the descriptor it was printed to, so real errors stay
    visible; Python exceptions are not touched (they propagate as usual).
    """
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    saved: list[tuple[int, int, IO[bytes]]] = []
    try:
        for fd in (1, 2):
            try:
                copy = os.dup(fd)
            except OSError:  # no such descriptor (e.g. a daemon without stdio)
                continue
            sink = tempfile.TemporaryFile(mode="w+b")
            os.dup2(sink.fileno(), fd)
            saved.append((fd, copy, sink))
    except OSError:
        pass
    try:
        yield
    finally:
        for fd, copy, captured in saved:
            os.dup2(copy, fd)
            os.close(copy)
            captured.seek(0)
            text = captured.read().decode("utf-8", "replace")
            captured.close()
            keep = _filter_noise(text)
            if keep:
                os.write(fd, keep.encode("utf-8"))


def _filter_noise(text: str) -> str:
    """The lines of ``text`` that are not PyBullet noise.

    A ``b3Warning[file,line]:`` header is followed by its message on the next line; both go.
    """
    out: list[str] = []
    skip_next = False
    for line in text.splitlines(keepends=True):
        if skip_next:
            skip_next = False
            continue
        if _NOISE.match(line):
            skip_next = line.startswith("b3Warning[") and line.rstrip().endswith(":")
            continue
        out.append(line)
    return "".join(out)


with _quiet_pybullet():
    import pybullet
import pybullet_data  # noqa: E402
from pybullet_utils.bullet_client import BulletClient  # noqa: E402

__all__ = [
    "BulletWorld",
    "ControlCalls",
    "RobotHandles",
    "engine_library",
    "engine_version",
    "not_copyable",
    "rotation_matrices",
]

#: Names that lived here before the asset pipeline moved out (issue 30), and where they live now.
#: ``from tooldesign_env.bullet import panda_urdf_with_tool`` keeps working: the module is imported
#: on first use, not here, because those modules import this one.
_MOVED = {
    **dict.fromkeys(
        (
            "HAND_LINKS",
            "HAND_ROOT",
            "merged_hand_inertia",
            "panda_urdf_with_tool",
            "robot_model_digest",
        ),
        "tooldesign_env.robot_model",
    ),
    **dict.fromkeys(
        ("LEAN_MESH_FORMAT", "lean_collision_mesh", "lean_collision_meshes"),
        "tooldesign_env.lean_meshes",
    ),
}


def __getattr__(name: str) -> Any:
    module = _MOVED.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(module), name)


PANDA_DIR = os.path.join(pybullet_data.getDataPath(), "franka_panda")
ARM_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
EE_LINK = "panda_grasptarget"
TOOL_LINK = "tool"


# Collision groups. PyBullet makes a pair collide when either body's group meets the other's
# mask, so keeping the arm off the floor needs both masks: the floor's (set when it is made,
# before anything else exists: re-adding a body that already touches another resets their
# contact and moves results) and the arm's links' (set as the robot is loaded).
_STATIC_GROUP = 2  # btBroadphaseProxy::StaticFilter, PyBullet's group of fixed bodies
_ARM_GROUP = 4  # the arm's links and its tool, when they are kept off the floor
_ALL = -1

_RENDERER_PLUGIN = "tinyRendererPlugin"  # the name PyBullet registers its software renderer by


@functools.cache
def engine_version() -> str:
    """PyBullet's package version and API version, e.g. ``"3.2.7 api 202010061"``."""
    try:
        version = importlib.metadata.version("pybullet")
    except importlib.metadata.PackageNotFoundError:
        version = "unknown"
    return f"{version} api {pybullet.getAPIVersion()}"


def engine_library() -> str:
    """The path of PyBullet's compiled library, whose C API a plugin of a world calls."""
    return cast("str", pybullet.__file__)


def rotation_matrices(quaternions: Any) -> np.ndarray:
    """(..., 3, 3) rotation matrices of quaternions (..., 4) in PyBullet's order (x, y, z, w).

    A matrix's columns are the rotated frame's axes in the world.
    """
    x, y, z, w = np.moveaxis(np.asarray(quaternions, dtype=float), -1, 0)
    rows = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
    return np.moveaxis(np.array(rows, dtype=float), (0, 1), (-2, -1))


def _project(
    points: np.ndarray, view: tuple[Any, ...], proj: tuple[Any, ...], width: int, height: int
) -> np.ndarray:
    """Pixel coordinates (T, 2) (column, row) of world points (T, 3) for a PyBullet camera.

    Points behind the camera get NaN.
    """
    v = np.asarray(view, dtype=float).reshape(4, 4).T  # PyBullet matrices are column-major
    p = np.asarray(proj, dtype=float).reshape(4, 4).T
    homogeneous = np.c_[points, np.ones(len(points))]
    clip = homogeneous @ (p @ v).T
    w = clip[:, 3:4]
    with np.errstate(divide="ignore", invalid="ignore"):
        ndc = np.where(w > 0, clip[:, :2] / w, np.nan)
    return cast(
        "np.ndarray", np.c_[(ndc[:, 0] + 1.0) / 2.0 * width, (1.0 - ndc[:, 1]) / 2.0 * height]
    )


def _draw_polyline(frame: np.ndarray, pixels: np.ndarray, rgb: tuple[int, int, int]) -> None:
    """Draw a 3-pixel-wide line through ``pixels`` (T, 2) onto ``frame`` in place."""
    height, width = frame.shape[:2]
    for a, b in zip(pixels[:-1], pixels[1:], strict=True):
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
            continue
        n = int(max(abs(b[0] - a[0]), abs(b[1] - a[1]), 1.0)) + 1
        cols = np.linspace(a[0], b[0], n)
        rows = np.linspace(a[1], b[1], n)
        for dc in (-1, 0, 1):
            for dr in (-1, 0, 1):
                cc = np.round(cols + dc).astype(int)
                rr = np.round(rows + dr).astype(int)
                ok = (cc >= 0) & (cc < width) & (rr >= 0) & (rr < height)
                frame[rr[ok], cc[ok]] = rgb


@dataclass(frozen=True)
class RobotHandles:
    """Indices of a loaded robot.

    Attributes:
        body: the PyBullet body id.
        joints: the 7 arm joint indices, in order.
        ee_link: link index of ``panda_grasptarget``.
        tool_link: link index of the tool, or -1 when the robot carries none.
    """

    body: int
    joints: tuple[int, ...]
    ee_link: int
    tool_link: int


class ControlCalls(NamedTuple):
    """PyBullet calls of the control loop with their fixed arguments bound.

    Attributes:
        joint_states: ``() -> ((position, velocity, reaction, torque), ...)`` of the 7 joints.
        inverse_dynamics: ``(q, qd, qdd) -> torques``, each 7 floats.
        motor: ``(forces=torques)``: command joint torques for the next physics step.
        step: ``()``: one physics step.
        link_state: ``() -> getLinkState`` tuple of the end-effector link, forward kinematics
            recomputed.
        link_states: ``() -> (end-effector state, other link's state)``, as ``link_state``.
        box_pose: ``() -> (position, quaternion)`` of the box.
        box_velocity: ``() -> (linear, angular)`` velocity of the box.
        contacts: ``() -> getContactPoints`` tuples between the box and the other link.
    """

    joint_states: Callable[[], Any]
    inverse_dynamics: Callable[..., Any]
    motor: Callable[..., Any]
    step: Callable[[], Any]
    link_state: Callable[[], Any]
    link_states: Callable[[], Any]
    box_pose: Callable[[], Any]
    box_velocity: Callable[[], Any]
    contacts: Callable[[], Any]


def not_copyable(what: str) -> TypeError:
    """The refusal of copy, deepcopy and pickle for ``what``, which holds a PyBullet connection.

    Raised from ``__reduce_ex__``, which copy, deepcopy and pickle all go through.
    """
    return TypeError(
        f"{what} holds its own connection to a PyBullet server, which cannot be copied or "
        "pickled (the copy would share the connection, and closing either would break the "
        "other); make another with the same arguments instead (an env: gym.make with the "
        "same id and keywords)"
    )


class BulletWorld:
    """A PyBullet physics client and the bodies of one scene.

    Args:
        render_mode: None (DIRECT, the default), ``"human"`` (GUI window) or ``"rgb_array"``
            (DIRECT with offscreen rendering).
        time_step: physics time step, s.
        solver_iterations: constraint-solver iterations per step.
        renderer: keep PyBullet's software renderer (False only without ``render_mode``).
            Without it :meth:`render` is refused, and loading a body is cheaper: PyBullet's
            renderer makes a visual from every collision shape that has no visual of its own,
            which cost about 6 ms of a 13 ms load of the Panda with its tool. Physics never
            reads visuals, so results are the same bit for bit.

    A world owns its connection: it cannot be copied or pickled (a copy would share the
    connection, and closing either would break the other), so each env, simulator or world is
    made anew, from the same arguments.
    """

    def __reduce_ex__(self, protocol: Any) -> Any:
        raise not_copyable("a BulletWorld")

    def __init__(
        self,
        *,
        render_mode: str | None = None,
        time_step: float = 1.0 / 240.0,
        solver_iterations: int = 50,
        renderer: bool = True,
    ) -> None:
        # First, so that __del__ (close) finds it when a check below refuses the arguments.
        self._client: BulletClient | None = None
        if not renderer and render_mode is not None:
            raise ValueError(
                f"renderer=False needs render_mode=None (nothing to render with), "
                f"got render_mode={render_mode!r}"
            )
        self.render_mode = render_mode
        self.time_step = time_step
        self.solver_iterations = solver_iterations
        self.renderer = renderer
        self._states: list[int] = []
        self._plugins: dict[tuple[str, str], int] = {}
        #: How many physics servers this world has had (each reconnect starts a new one).
        self.servers = 0
        self._connect()

    def _connect(self) -> None:
        mode = pybullet.GUI if self.render_mode == "human" else pybullet.DIRECT
        with _quiet_pybullet():
            self._client = BulletClient(connection_mode=mode)
        cid = self._client._client
        self.client_id = cid
        self._plugins.clear()  # a new server has none loaded
        self.servers += 1
        if not self.renderer:
            # The software renderer is a plugin linked into PyBullet and selected when a client
            # connects; loading it by name returns its id, and unloading it leaves the server
            # without a renderer, so that bodies are loaded without making visuals.
            plugin = pybullet.loadPlugin(_RENDERER_PLUGIN, physicsClientId=cid)
            if plugin >= 0:
                pybullet.unloadPlugin(plugin, physicsClientId=cid)
        # Bound once: the control loop calls these thousands of times per episode, and
        # BulletClient builds a new partial on every attribute access.
        self._step = functools.partial(pybullet.stepSimulation, physicsClientId=cid)
        self._joint_states = functools.partial(pybullet.getJointStates, physicsClientId=cid)
        self._inverse_dynamics = functools.partial(
            pybullet.calculateInverseDynamics, physicsClientId=cid
        )
        self._motor = functools.partial(pybullet.setJointMotorControlArray, physicsClientId=cid)
        self._base_pose = functools.partial(
            pybullet.getBasePositionAndOrientation, physicsClientId=cid
        )
        self._link_state = functools.partial(pybullet.getLinkState, physicsClientId=cid)
        self._contacts = functools.partial(pybullet.getContactPoints, physicsClientId=cid)
        self._base_velocity = functools.partial(pybullet.getBaseVelocity, physicsClientId=cid)
        self._jacobian = functools.partial(pybullet.calculateJacobian, physicsClientId=cid)
        self._mass_matrix = functools.partial(pybullet.calculateMassMatrix, physicsClientId=cid)
        self.reset()

    # ------------------------------------------------------------------ world
    @property
    def client(self) -> BulletClient:
        """The underlying client; raises once the world is closed."""
        if self._client is None:
            raise RuntimeError("this BulletWorld is closed")
        return self._client

    def reconnect(self) -> None:
        """Replace the physics server by a fresh one (the GUI keeps its window).

        PyBullet keeps every URDF it has loaded, by file name, for the life of the server, and
        each build uses a new name: about 26 KB per build. A fresh server drops them.
        """
        if self.render_mode == "human":
            self.reset()
            return
        self.close()
        self._states.clear()
        self._connect()

    def reset(self) -> None:
        """Empty the world and set gravity, time step and solver settings."""
        c = self.client
        c.resetSimulation()
        self._states.clear()
        c.setGravity(0.0, 0.0, -9.81)
        c.setPhysicsEngineParameter(
            fixedTimeStep=self.time_step,
            numSolverIterations=self.solver_iterations,
            deterministicOverlappingPairs=1,
        )
        if self.render_mode == "human":
            c.configureDebugVisualizer(pybullet.COV_ENABLE_GUI, 0)

    def add_floor(self, *, friction: float, arm_contacts: bool = True) -> int:
        """A static plane at z = 0; returns its body id.

        With ``arm_contacts=False`` a robot loaded with ``floor_contacts=False`` passes
        through the floor; everything else still rests on it.
        """
        c = self.client
        shape = c.createCollisionShape(pybullet.GEOM_PLANE)
        visual = -1
        # With a visual, PyBullet prints "b3Warning: No default visual for URDF_GEOM_PLANE".
        with _quiet_pybullet():
            if self.render_mode is not None:
                visual = c.createVisualShape(pybullet.GEOM_PLANE, rgbaColor=[0.85, 0.85, 0.85, 1])
            body = c.createMultiBody(0.0, shape, visual, [0, 0, 0])
        c.changeDynamics(body, -1, lateralFriction=friction)
        if not arm_contacts:
            mask = _ALL ^ _STATIC_GROUP ^ _ARM_GROUP
            c.setCollisionFilterGroupMask(body, -1, _STATIC_GROUP, mask)
        return cast("int", body)

    def add_box(
        self,
        *,
        size: tuple[float, float, float],
        mass: float,
        friction: float,
        position: tuple[float, float, float],
        yaw: float,
        rgba: tuple[float, float, float, float] = (0.8, 0.35, 0.1, 1.0),
    ) -> int:
        """A dynamic box; ``size`` is its full extents (x, y, z) in m. Returns its body id."""
        c = self.client
        half = [s / 2 for s in size]
        shape = c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half)
        visual = -1
        if self.render_mode is not None:
            visual = c.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, rgbaColor=rgba)
        orn = c.getQuaternionFromEuler([0.0, 0.0, yaw])
        body = c.createMultiBody(mass, shape, visual, list(position), orn)
        c.changeDynamics(body, -1, lateralFriction=friction)
        return cast("int", body)

    def add_cylinder(
        self,
        *,
        radius: float,
        height: float,
        mass: float,
        friction: float,
        position: tuple[float, float, float],
        yaw: float,
        rgba: tuple[float, float, float, float] = (0.8, 0.35, 0.1, 1.0),
    ) -> int:
        """A dynamic upright cylinder (axis along z), ``radius`` and ``height`` in m; its id."""
        c = self.client
        shape = c.createCollisionShape(pybullet.GEOM_CYLINDER, radius=radius, height=height)
        visual = -1
        if self.render_mode is not None:
            visual = c.createVisualShape(
                pybullet.GEOM_CYLINDER, radius=radius, length=height, rgbaColor=rgba
            )
        orn = c.getQuaternionFromEuler([0.0, 0.0, yaw])
        body = c.createMultiBody(mass, shape, visual, list(position), orn)
        c.changeDynamics(body, -1, lateralFriction=friction)
        return cast("int", body)

    def add_marker(self, position: tuple[float, float, float], radius: float = 0.03) -> int:
        """A visual-only sphere (the goal), drawn when rendering; -1 in plain DIRECT mode."""
        if self.render_mode is None:
            return -1
        c = self.client
        visual = c.createVisualShape(
            pybullet.GEOM_SPHERE, radius=radius, rgbaColor=[0.1, 0.7, 0.2, 0.8]
        )
        return cast("int", c.createMultiBody(0.0, -1, visual, list(position)))

    def load_robot(
        self,
        urdf_text: str,
        *,
        tool_mass: float | None = None,
        tool_inertia_diagonal: tuple[float, float, float] | None = None,
        tool_friction: float = 0.5,
        floor_contacts: bool = True,
        link_inertias: Mapping[str, tuple[float, tuple[float, float, float]]] | None = None,
    ) -> RobotHandles:
        """Load a robot from URDF text with a fixed base at the origin.

        PyBullet caches URDF files by name (even across ``resetSimulation``), so each load uses a
        fresh file name, deleted right after loading. PyBullet takes inertia from the collision
        shapes' bounding box unless told otherwise, so the tool's mass and principal moments are
        set here explicitly (its inertial frame, with the principal axes, comes from the URDF).
        With ``floor_contacts=False`` its links pass through a floor made with
        ``arm_contacts=False``. ``link_inertias`` sets other links' mass and principal moments
        the same way, {link name: (mass, moments)} (:func:`merged_hand_inertia`).
        """
        c = self.client
        fd, path = tempfile.mkstemp(prefix=f"tooldesign-{uuid.uuid4().hex}-", suffix=".urdf")
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                f.write(urdf_text)
            body = c.loadURDF(path, [0, 0, 0], useFixedBase=True)
        finally:
            os.unlink(path)
        names = self.indices(body)
        joints = tuple(names[n] for n in ARM_JOINTS)
        tool = names.get(TOOL_LINK, -1)
        if tool >= 0 and tool_mass is not None:
            c.changeDynamics(
                body,
                tool,
                mass=tool_mass,
                localInertiaDiagonal=list(tool_inertia_diagonal or (0.0, 0.0, 0.0)),
                lateralFriction=tool_friction,
            )
        for name, (mass, moments) in (link_inertias or {}).items():
            if name not in names:
                raise ValueError(f"link_inertias names a link the robot lacks: {name!r}")
            c.changeDynamics(
                body, names[name], mass=mass, localInertiaDiagonal=[float(m) for m in moments]
            )
        if not floor_contacts:
            for j in range(c.getNumJoints(body)):
                c.setCollisionFilterGroupMask(body, j, _ARM_GROUP, _ALL ^ _STATIC_GROUP)
        # The default velocity motors fight torque control unless switched off.
        c.setJointMotorControlArray(
            body, list(joints), pybullet.VELOCITY_CONTROL, forces=[0.0] * len(joints)
        )
        return RobotHandles(body=body, joints=joints, ee_link=names[EE_LINK], tool_link=tool)

    def indices(self, body: int) -> dict[str, int]:
        """{joint name or link name: index} of a body's joints (a link shares its joint's)."""
        c, names = self.client, {}
        for j in range(c.getNumJoints(body)):
            info = c.getJointInfo(body, j)
            names[info[1].decode()] = j
            names[info[12].decode()] = j
        return names

    def dynamics_info(self, body: int, link: int) -> tuple[Any, ...]:
        """PyBullet's ``getDynamicsInfo`` of a link, as it returns it.

        Mass [0], principal moments [2], the inertial frame's position [3] and quaternion [4].
        """
        return cast("tuple[Any, ...]", self.client.getDynamicsInfo(body, link))

    def remove(self, body: int) -> None:
        """Remove a body from the world."""
        self.client.removeBody(body)

    def place_body(self, body: int, position: tuple[float, float, float]) -> None:
        """Teleport a body's base to ``position`` (x, y, z) in m, keeping its orientation."""
        c = self.client
        _, orientation = c.getBasePositionAndOrientation(body)
        c.resetBasePositionAndOrientation(body, [float(v) for v in position], orientation)

    # ----------------------------------------------------------- robot state
    def set_joint_positions(self, robot: RobotHandles, q: np.ndarray) -> None:
        """Teleport the arm to joint positions ``q`` (7,) rad with zero velocity."""
        for j, value in zip(robot.joints, q, strict=True):
            self.client.resetJointState(robot.body, j, float(value), 0.0)

    def joint_slots(self, robot: RobotHandles) -> tuple[tuple[int, ...], tuple[int, ...]]:
        """Where the 7 arm joints sit in PyBullet's state vectors: (q indices, u indices)."""
        infos = [self.client.getJointInfo(robot.body, j) for j in robot.joints]
        return tuple(int(i[3]) for i in infos), tuple(int(i[4]) for i in infos)

    def joint_state(self, robot: RobotHandles) -> tuple[list[float], list[float]]:
        """Joint positions (rad) and velocities (rad/s) of the 7 arm joints, as lists."""
        states = self._joint_states(robot.body, robot.joints)
        return [s[0] for s in states], [s[1] for s in states]

    def control_calls(self, robot: RobotHandles, box: int, link: int) -> ControlCalls:
        """The reads and writes of one control step, bound to ``robot``, ``box`` and ``link``.

        Each is a PyBullet function with every argument but the changing ones bound, so the
        control loop pays one C call and no Python-level lookups per use (see
        :class:`ControlCalls`).
        """
        cid, body, joints = self.client_id, robot.body, list(robot.joints)
        partial = functools.partial
        return ControlCalls(
            joint_states=partial(pybullet.getJointStates, body, joints, physicsClientId=cid),
            inverse_dynamics=partial(pybullet.calculateInverseDynamics, body, physicsClientId=cid),
            motor=partial(
                pybullet.setJointMotorControlArray,
                body,
                joints,
                pybullet.TORQUE_CONTROL,
                physicsClientId=cid,
            ),
            step=partial(pybullet.stepSimulation, physicsClientId=cid),
            link_state=partial(
                pybullet.getLinkState,
                body,
                robot.ee_link,
                computeForwardKinematics=1,
                physicsClientId=cid,
            ),
            link_states=partial(
                pybullet.getLinkStates,
                body,
                [robot.ee_link, link],
                computeForwardKinematics=1,
                physicsClientId=cid,
            ),
            box_pose=partial(pybullet.getBasePositionAndOrientation, box, physicsClientId=cid),
            box_velocity=partial(pybullet.getBaseVelocity, box, physicsClientId=cid),
            contacts=partial(pybullet.getContactPoints, box, body, -1, link, physicsClientId=cid),
        )

    def inverse_dynamics(
        self, robot: RobotHandles, q: list[float], qd: list[float], qdd: list[float]
    ) -> tuple[float, ...]:
        """Joint torques (N m) that produce accelerations ``qdd`` at state (q, qd)."""
        return cast("tuple[float, ...]", self._inverse_dynamics(robot.body, q, qd, qdd))

    def step_with_torques(self, robot: RobotHandles, torques: list[float], n: int) -> None:
        """Advance ``n`` physics steps, commanding the same joint torques (7,) N m on each.

        PyBullet forgets a torque command after every step, so it is sent before each one.
        """
        motor, step, body, joints = self._motor, self._step, robot.body, robot.joints
        torque_control = pybullet.TORQUE_CONTROL
        for _ in range(n):
            motor(body, joints, torque_control, forces=torques)
            step()

    def step(self, n: int = 1) -> None:
        """Advance the physics by ``n`` time steps."""
        for _ in range(n):
            self._step()

    def inverse_kinematics(
        self,
        robot: RobotHandles,
        position: tuple[float, float, float],
        orientation: tuple[float, float, float, float],
        *,
        rest_pose: tuple[float, ...],
        iterations: int = 200,
        threshold: float = 1e-6,
    ) -> np.ndarray:
        """Joint positions (7,) rad that put the end effector at a pose, seeded by the current q."""
        c = self.client
        lower, upper = [], []
        for j in robot.joints:
            info = c.getJointInfo(robot.body, j)
            lower.append(info[8])
            upper.append(info[9])
        ranges = [u - lo for lo, u in zip(lower, upper, strict=True)]
        q = c.calculateInverseKinematics(
            robot.body,
            robot.ee_link,
            list(position),
            list(orientation),
            lowerLimits=lower,
            upperLimits=upper,
            jointRanges=ranges,
            restPoses=list(rest_pose),
            maxNumIterations=iterations,
            residualThreshold=threshold,
        )
        return np.asarray(q[:7], dtype=float)

    def link_pose(self, robot: RobotHandles, link: int) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
        """World position (m) and quaternion (x, y, z, w) of a link frame."""
        state = self._link_state(robot.body, link, computeForwardKinematics=1)
        return state[4], state[5]

    def link_count(self, robot: RobotHandles) -> int:
        """Links of the robot after its base (PyBullet's joint count)."""
        return int(self.client.getNumJoints(robot.body))

    def joint_axis(self, robot: RobotHandles, joint: int) -> np.ndarray:
        """(3,) world direction of a joint's axis at the current joint positions."""
        local = np.asarray(self.client.getJointInfo(robot.body, joint)[13], dtype=float)
        orientation = self._link_state(robot.body, joint, computeForwardKinematics=1)[5]
        return np.asarray(rotation_matrices(orientation) @ local)

    def link_boxes(self, robot: RobotHandles, links: Sequence[int]) -> np.ndarray:
        """(len(links), 2, 3) world axis-aligned bounding boxes (min, max) of links, m.

        PyBullet's boxes include the shapes' collision margins: they bound the shapes.
        """
        c = self.client
        return np.array([c.getAABB(robot.body, link) for link in links], dtype=float)

    # ------------------------------------------------------------ the box etc
    def body_position(self, body: int) -> tuple[float, float, float]:
        """World position of a body's base, m."""
        return cast("tuple[float, float, float]", self._base_pose(body)[0])

    def box_velocity(self, body: int) -> tuple[float, float, float]:
        """World linear velocity of a body's base, m/s."""
        return cast("tuple[float, float, float]", self._base_velocity(body)[0])

    def body_pose(self, body: int) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
        """World position (m) and quaternion of a body's base."""
        return cast("tuple[tuple[Any, ...], tuple[Any, ...]]", self._base_pose(body))

    def in_contact(self, body_a: int, body_b: int, link_b: int) -> bool:
        """Whether body A touches link ``link_b`` of body B after the last step."""
        return len(self._contacts(body_a, body_b, -1, link_b)) > 0

    def contact_points(self, body_a: int, body_b: int, link_b: int) -> list[tuple[Any, ...]]:
        """The contact manifold between body A and link ``link_b`` of body B after the last step.

        Each entry is ``(point on B (3,) m, normal on B (3,) pointing toward A)`` in the world
        frame. Empty when they do not touch.
        """
        return [(c[6], c[7]) for c in self._contacts(body_a, body_b, -1, link_b)]

    def link_com_pose(
        self, robot: RobotHandles, link: int
    ) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
        """World position (m) and quaternion of a link's centre-of-mass (inertial) frame."""
        state = self._link_state(robot.body, link, computeForwardKinematics=1)
        return state[0], state[1]

    def link_com_jacobian(
        self, robot: RobotHandles, link: int, q: list[float]
    ) -> tuple[np.ndarray, np.ndarray]:
        """Linear and angular Jacobians (3, 7) of a link's centre of mass at joint positions q.

        Units m/rad and rad/rad, world frame; the arm's 7 joints are its only degrees of freedom.
        """
        zeros = [0.0] * len(q)
        linear, angular = self._jacobian(robot.body, link, (0.0, 0.0, 0.0), q, zeros, zeros)
        return np.asarray(linear, dtype=float), np.asarray(angular, dtype=float)

    def jacobian_calls(
        self, robot: RobotHandles, link: int
    ) -> tuple[Callable[[Sequence[float]], Any], Callable[[Sequence[float]], Any]]:
        """``jacobian(q)`` and ``mass_matrix(q)`` as PyBullet returns them (nested tuples).

        The batched forms of :meth:`link_com_jacobian` (``(linear, angular)``, each 3 rows of
        7) and :meth:`mass_matrix` (7 rows of 7), for many configurations in a row.
        """
        cid, body = self.client_id, robot.body
        zeros = [0.0] * len(robot.joints)
        origin = (0.0, 0.0, 0.0)

        def jacobian(q: Sequence[float]) -> Any:
            return pybullet.calculateJacobian(
                body, link, origin, q, zeros, zeros, physicsClientId=cid
            )

        def mass_matrix(q: Sequence[float]) -> Any:
            return pybullet.calculateMassMatrix(body, q, physicsClientId=cid)

        return jacobian, mass_matrix

    def mass_matrix(self, robot: RobotHandles, q: list[float]) -> np.ndarray:
        """Joint-space inertia matrix M(q) (7, 7) of the arm with its tool, kg m^2."""
        return np.asarray(self._mass_matrix(robot.body, list(q)), dtype=float)

    def overlaps(self, body_a: int, body_b: int, link_b: int, margin: float = 0.0) -> bool:
        """Whether two shapes are closer than ``margin`` (m), without stepping the physics."""
        c = self.client
        return len(c.getClosestPoints(body_a, body_b, margin, -1, link_b)) > 0

    # ------------------------------------------------------------- snapshots
    def save_state(self) -> int:
        """Snapshot the whole world in memory; returns an id for ``restore_state``."""
        sid = self.client.saveState()
        self._states.append(sid)
        return cast("int", sid)

    def restore_state(self, state_id: int) -> None:
        """Return the world to a snapshot (PyBullet's restore is not exact while in contact)."""
        self.client.restoreState(stateId=state_id)

    def adopt_states(self, state_ids: Sequence[int]) -> None:
        """Count snapshots taken in the server by a plugin as this world's (freed on drop)."""
        self._states.extend(int(i) for i in state_ids)

    def drop_states(self) -> None:
        """Free every snapshot taken since the last reset."""
        for sid in self._states:
            self.client.removeState(sid)
        self._states.clear()

    # ------------------------------------------------------------- plugins
    def load_plugin(self, path: str, postfix: str) -> int:
        """Load a PyBullet plugin into this world's server; its id, or -1 if PyBullet refused it.

        Loaded once per server: later calls return the same id. PyBullet refuses a library it
        cannot open, one without the plugin's functions for ``postfix``, and one built for
        another version of its C API.
        """
        key = (path, postfix)
        if key not in self._plugins:
            with _quiet_pybullet():  # a refusal is printed by PyBullet's C code as well
                plugin = pybullet.loadPlugin(path, postfix, physicsClientId=self.client_id)
            self._plugins[key] = int(plugin)
        return self._plugins[key]

    def plugin_command(self, plugin: int, text: str, ints: Sequence[int] = ()) -> int:
        """Run a command of a loaded plugin inside the server; the plugin's integer answer.

        ``ints`` are C ints (32 bits each).
        """
        answer = pybullet.executePluginCommand(
            plugin, text, [int(i) for i in ints], physicsClientId=self.client_id
        )
        return int(answer)

    # ------------------------------------------------------------- rendering
    def render(
        self,
        *,
        width: int = 480,
        height: int = 360,
        target: tuple[float, float, float] = (0.4, 0.7, 0.0),
        distance: float = 2.4,
        yaw: float = 200.0,
        pitch: float = -50.0,
        goal: tuple[float, float, float] | None = None,
        path: np.ndarray | None = None,
        region: tuple[tuple[float, float], tuple[float, float]] | None = None,
    ) -> np.ndarray:
        """An RGB frame (height, width, 3) uint8 from a fixed camera, rendered offscreen.

        Headless (PyBullet's software renderer): no display is needed.

        Args:
            width: image width in pixels.
            height: image height in pixels.
            target: point the camera looks at, (x, y, z) in m.
            distance: camera distance from ``target``, m.
            yaw: camera yaw, degrees.
            pitch: camera pitch, degrees.
            goal: draw a green sphere at this (x, y, z) in m (removed again after the frame).
            path: (T, 3) points in m (the box path), drawn as a blue line over the image.
            region: ``((x_low, y_low), (x_high, y_high))`` in m, a rectangle on the floor (a
                task's goal range), drawn as a dark green outline over the image.

        Raises:
            ValueError: a size is not a positive int, or ``goal``/``path``/``region`` has the
                wrong shape or non-finite values, or ``region``'s low corner exceeds its high.
        """
        for name, value in (("width", width), ("height", height)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"{name} must be an int >= 1 pixel, got {value!r}")
        if goal is not None:
            g = np.asarray(goal, dtype=float)
            if g.shape != (3,) or not np.all(np.isfinite(g)):
                raise ValueError(f"goal must be 3 finite numbers (x, y, z) in m, got {goal!r}")
        if path is not None:
            path = np.asarray(path, dtype=float)
            if path.ndim != 2 or path.shape[1] != 3 or not np.all(np.isfinite(path)):
                raise ValueError(f"path must be a finite (T, 3) array in m, got {path.shape}")
        outline = None
        if region is not None:
            try:
                corners = np.asarray(region, dtype=float)
            except (TypeError, ValueError):
                corners = np.full(1, np.nan)  # ragged or not numbers: refused below
            if (
                corners.shape != (2, 2)
                or not np.all(np.isfinite(corners))
                or np.any(corners[0] > corners[1])
            ):
                raise ValueError(
                    "region must be ((x_low, y_low), (x_high, y_high)) in m, finite, low <= "
                    f"high, got {region!r}"
                )
            (x0, y0), (x1, y1) = corners
            ring = [(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)]
            outline = np.array([(x, y, 0.002) for x, y in ring])  # just above the floor
        if not self.renderer:
            raise RuntimeError("this BulletWorld was made with renderer=False: it cannot render")
        c = self.client
        view = c.computeViewMatrixFromYawPitchRoll(target, distance, yaw, pitch, 0.0, 2)
        proj = c.computeProjectionMatrixFOV(50.0, width / height, 0.05, 20.0)
        marker = -1
        if goal is not None:
            visual = c.createVisualShape(
                pybullet.GEOM_SPHERE, radius=0.05, rgbaColor=[0.1, 0.75, 0.2, 1.0]
            )
            marker = c.createMultiBody(0.0, -1, visual, [float(v) for v in goal])
        try:
            with _quiet_pybullet():
                _, _, rgba, _, _ = c.getCameraImage(
                    width, height, view, proj, renderer=pybullet.ER_TINY_RENDERER
                )
        finally:
            if marker >= 0:
                c.removeBody(marker)
        frame = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3].copy()
        if path is not None and len(path) > 0:
            _draw_polyline(frame, _project(path, view, proj, width, height), (30, 80, 220))
        if outline is not None:
            # Darker than the green that benchmarks.design.video's goal finder looks for.
            _draw_polyline(frame, _project(outline, view, proj, width, height), (10, 80, 30))
        return cast("np.ndarray", frame)

    def close(self) -> None:
        """Disconnect; safe to call more than once."""
        if self._client is not None:
            try:
                self._client.disconnect()
            except Exception:  # noqa: BLE001
                # Already disconnected, or interpreter shutdown (when __del__ runs, PyBullet's
                # module globals may be gone): nothing is left to release either way.
                pass
            self._client = None

    def __del__(self) -> None:
        self.close()
