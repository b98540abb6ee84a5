"""The control loop in C: a PyBullet plugin (``control_loop.c``) and its Python side.

A rollout of :class:`~tooldesign_env.simulation.ToolSimulator` makes about eight requests to the
physics server per control step. From Python each costs microseconds of argument parsing and tuple
building on top of the server's own work, which together with the loop's Python came to about half
the cost of the physics itself. ``control_loop.c`` runs the same loop inside PyBullet's server, as
a plugin, with the same requests, in the same order, and the same floating-point operations:
results are the same bit for bit (``tests/test_native_loop.py``).

The plugin is compiled when the package is installed (``setup.py``; an optional extension, so an
install without a C compiler still succeeds). Without it, or with a PyBullet whose C API it was not
built for (PyBullet refuses it), or with ``TOOLDESIGN_NATIVE_LOOP=0`` in the environment, the
simulator runs its Python loop: the same results, slower. :func:`status` says which, and why.

Data travels through memory: the plugin's command gets the address of a :class:`LoopArgs` whose
pointers lead to NumPy arrays owned here, because PyBullet passes a plugin's float arguments as C
floats. Nothing here imports PyBullet: the world (:class:`~tooldesign_env.bullet.BulletWorld`)
loads the plugin and passes the commands.
"""

from __future__ import annotations

import ctypes
import importlib.machinery
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from tooldesign_env.bullet import BulletWorld

__all__ = [
    "ENV_SWITCH",
    "LoopRecord",
    "NativeLoop",
    "NativeLoopError",
    "library_path",
    "status",
]

#: Set to ``0`` to run the Python loop even where the plugin is available.
ENV_SWITCH = "TOOLDESIGN_NATIVE_LOOP"
#: The plugin's functions end with this (PyBullet's ``loadPlugin(path, postFix)``).
POSTFIX = "_tooldesign"
#: ``LOOP_VERSION`` in control_loop.c: a library built from another version is not used.
LOOP_VERSION = 3
ARM = 7

#: What the plugin's negative answers mean (``ERR_*`` in control_loop.c); -1 is PyBullet's.
ERRORS = {
    -1: "PyBullet knows no such plugin in this server",
    -1001: "the plugin is not bound to PyBullet's C API",
    -1002: "bad arguments",
    -1003: "unknown command",
    -1004: "a physics step failed",
    -1005: "a torque command failed",
    -1006: "reading a body's state failed",
    -1007: "the inverse dynamics failed",
    -1008: "reading the contact points failed",
    -1009: "the Jacobian failed",
    -1010: "the mass matrix failed",
    -1011: "saving a snapshot failed",
    -1012: "out of memory",
    -1013: "PyBullet's library could not be opened",
    -1014: "a function is missing from PyBullet's library",
    -1015: "the plugin's client could not learn the robot's joints",
}


class NativeLoopError(RuntimeError):
    """The plugin refused a command (a broken world, not a bad design)."""


class LoopArgs(ctypes.Structure):
    """``struct loop_args`` of control_loop.c: the inputs and outputs of one command."""

    _fields_ = [
        ("qdd_ref", ctypes.c_void_p),
        ("q_ref", ctypes.c_void_p),
        ("qd_ref", ctypes.c_void_p),
        ("phase", ctypes.c_void_p),
        ("torques_in", ctypes.c_void_p),
        ("kp", ctypes.c_double),
        ("kd", ctypes.c_double),
        ("torque_limit", ctypes.c_double * ARM),
        ("rest_speed", ctypes.c_double),
        ("robot", ctypes.c_int32),
        ("box", ctypes.c_int32),
        ("ee_link", ctypes.c_int32),
        ("tool_link", ctypes.c_int32),
        ("q_index", ctypes.c_int32 * ARM),
        ("u_index", ctypes.c_int32 * ARM),
        ("n", ctypes.c_int32),
        ("period", ctypes.c_int32),
        ("record_mobility", ctypes.c_int32),
        ("fast_forward", ctypes.c_int32),
        ("hold_phase", ctypes.c_int32),
        ("hold_from", ctypes.c_int32),
        ("rest_needed", ctypes.c_int32),
        ("snapshot_every", ctypes.c_int32),
        ("torques", ctypes.c_void_p),
        ("q", ctypes.c_void_p),
        ("qd", ctypes.c_void_p),
        ("box_position", ctypes.c_void_p),
        ("ee_position", ctypes.c_void_p),
        ("ee_orientation", ctypes.c_void_p),
        ("tool_com", ctypes.c_void_p),
        ("contact_points", ctypes.c_void_p),
        ("snapshot_ids", ctypes.c_void_p),
        ("jacobians", ctypes.c_void_p),
        ("mass_matrices", ctypes.c_void_p),
        ("steps", ctypes.c_int32),
        ("fast_forward_from", ctypes.c_int32),
        ("logged_points", ctypes.c_int32),
        ("snapshots", ctypes.c_int32),
    ]


@dataclass(frozen=True, eq=False)
class LoopRecord:
    """What a control loop recorded, one row per simulated control step (``steps`` rows).

    Both loops, the plugin's and the simulator's Python one, return this.

    Attributes:
        torques: (steps, 7) commanded joint torques, N m.
        q: (steps, 7) joint positions after each step, rad.
        qd: (steps, 7) joint velocities after each step, rad/s.
        box_position: (steps, 3) box centre, m.
        ee_position: (steps, 3) origin of the grasp frame, m.
        ee_orientation: (steps, 4) its quaternion (x, y, z, w).
        contact_points: (steps,) points in the tool-box contact manifold.
        fast_forward_from: the first step not simulated (``n`` when all were).
        snapshots: PyBullet state ids taken during the loop, in the order taken.
        logged_steps: (m,) the steps whose manifold was recorded (with ``record_mobility``).
        tool_com: (m, 3) the tool link's centre of mass at those steps, m.
        points: (P, 6) their contact points: position on the tool and normal (from the tool's
            side, as PyBullet's ``contactNormalOnB``), world frame, step by step.
    """

    torques: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    box_position: np.ndarray
    ee_position: np.ndarray
    ee_orientation: np.ndarray
    contact_points: np.ndarray
    fast_forward_from: int
    snapshots: tuple[int, ...]
    logged_steps: np.ndarray
    tool_com: np.ndarray
    points: np.ndarray

    @property
    def steps(self) -> int:
        """Control steps simulated."""
        return int(self.torques.shape[0])


def library_path() -> Path | None:
    """The compiled plugin beside this file, or None when it was not built."""
    here = Path(__file__).resolve().parent
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        candidate = here / f"_control_loop{suffix}"
        if candidate.is_file():
            return candidate
    return None


def _switched_off() -> bool:
    return os.environ.get(ENV_SWITCH, "1") == "0"


def status() -> str:
    """Whether the simulator can use the plugin, in words (without loading it into a world)."""
    if _switched_off():
        return f"off ({ENV_SWITCH}=0): the Python loop runs"
    path = library_path()
    if path is None:
        return "not built (no C compiler at install?): the Python loop runs"
    return f"built: {path}"


def _address(array: np.ndarray) -> int:
    return int(array.ctypes.data)


def _halves(address: int) -> list[int]:
    """A 64-bit address as two C ints (PyBullet's plugin arguments are 32-bit)."""
    low, high = address & 0xFFFFFFFF, address >> 32
    return [low - (1 << 32) if low >= 1 << 31 else low, high]


class NativeLoop:
    """The plugin, loaded into one world's server.

    Args:
        world: the world whose server runs the loop.

    Raises:
        NativeLoopError: the plugin is unavailable or refused; the message says why.
    """

    def __init__(self, world: BulletWorld) -> None:
        if _switched_off():
            raise NativeLoopError(f"switched off by {ENV_SWITCH}=0")
        path = library_path()
        if path is None:
            raise NativeLoopError("the plugin was not built")
        self.world = world
        self._path = str(path)
        self._server = 0  # the world's server the plugin was last checked and bound in
        self._plugin()

    def _plugin(self) -> int:
        """The plugin's id in the world's current server: loaded, checked and bound there.

        A world that reconnected has a new server; closing the old one unloaded the library
        (PyBullet closes a plugin's library with its server), binding included.
        """
        world = self.world
        plugin = world.load_plugin(self._path, POSTFIX)
        if plugin < 0:
            raise NativeLoopError(
                f"PyBullet refused the plugin {self._path} (built for another version of its C "
                "API?)"
            )
        if self._server == world.servers:
            return plugin
        version = world.plugin_command(plugin, "version")
        layout = world.plugin_command(plugin, "layout")
        if version != LOOP_VERSION or layout != ctypes.sizeof(LoopArgs):
            raise NativeLoopError(
                f"the plugin {self._path} is version {version} with a {layout}-byte argument "
                f"block, this module expects version {LOOP_VERSION} and "
                f"{ctypes.sizeof(LoopArgs)} bytes: reinstall the package to rebuild it"
            )
        # Imported here: status() runs wherever a run's manifest is written, without PyBullet.
        from tooldesign_env.bullet import engine_library

        library = engine_library()
        if len(library.encode()) > 1000:  # PyBullet drops a text argument of 1024 bytes
            raise NativeLoopError(f"PyBullet's path is too long for a plugin argument: {library}")
        answer = world.plugin_command(plugin, f"bind {library}")
        if answer != 0:
            raise NativeLoopError(f"binding the plugin failed: {ERRORS.get(answer, answer)}")
        self._server = world.servers
        return plugin

    def _command(self, text: str, args: LoopArgs | np.ndarray) -> None:
        if isinstance(args, LoopArgs):
            ints = _halves(ctypes.addressof(args))
        else:  # a float64 array of rows to fill ("contacts")
            ints = [*_halves(_address(args)), int(args.shape[0])]
        answer = self.world.plugin_command(self._plugin(), text, ints)
        if answer != 0:
            raise NativeLoopError(f"the plugin's {text!r} failed: {ERRORS.get(answer, answer)}")

    @staticmethod
    def _args(
        *,
        robot: int,
        box: int,
        ee_link: int,
        tool_link: int,
        slots: tuple[tuple[int, ...], tuple[int, ...]],
        n: int,
        period: int,
    ) -> LoopArgs:
        args = LoopArgs()
        args.robot, args.box, args.ee_link, args.tool_link = robot, box, ee_link, tool_link
        args.q_index[:] = list(slots[0])
        args.u_index[:] = list(slots[1])
        args.n, args.period = n, period
        return args

    def rollout(
        self,
        *,
        robot: int,
        box: int,
        ee_link: int,
        tool_link: int,
        slots: tuple[tuple[int, ...], tuple[int, ...]],
        period: int,
        qdd_ref: np.ndarray,
        q_ref: np.ndarray,
        qd_ref: np.ndarray,
        kp: float,
        kd: float,
        torque_limits: tuple[float, ...],
        phase: np.ndarray,
        hold_phase: int,
        hold_from: int,
        fast_forward: bool,
        rest_speed: float,
        rest_needed: int,
        record_mobility: bool,
        snapshot_every: int | None,
    ) -> LoopRecord:
        """Run the control loop of :meth:`ToolSimulator._run` in the server (see there)."""
        n = int(q_ref.shape[0])
        refs = [np.ascontiguousarray(r, dtype=np.float64) for r in (qdd_ref, q_ref, qd_ref)]
        for ref in refs:
            if ref.shape != (n, ARM):
                raise ValueError(f"references must be ({n}, {ARM}) arrays, got {ref.shape}")
        phases = np.ascontiguousarray(phase, dtype=np.int8)
        if phases.shape != (n,):
            raise ValueError(f"phase must be a ({n},) array, got {phases.shape}")
        every = int(snapshot_every or 0)
        if every < 0:
            raise ValueError(f"snapshot_every must be None or an int >= 1, got {snapshot_every!r}")
        out: dict[str, np.ndarray] = {
            "torques": np.empty((n, ARM)),
            "q": np.empty((n, ARM)),
            "qd": np.empty((n, ARM)),
            "box_position": np.empty((n, 3)),
            "ee_position": np.empty((n, 3)),
            "ee_orientation": np.empty((n, 4)),
            "tool_com": np.empty((n, 3)),
            "contact_points": np.empty(n, dtype=np.int32),
            "snapshot_ids": np.empty((n // every + 2) if every else 1, dtype=np.int32),
        }
        args = self._args(
            robot=robot,
            box=box,
            ee_link=ee_link,
            tool_link=tool_link,
            slots=slots,
            n=n,
            period=period,
        )
        args.qdd_ref, args.q_ref, args.qd_ref = (_address(r) for r in refs)
        args.phase = _address(phases)
        args.kp, args.kd = float(kp), float(kd)
        args.torque_limit[:] = [float(v) for v in torque_limits]
        args.rest_speed = float(rest_speed)
        args.record_mobility = int(record_mobility)
        args.fast_forward, args.hold_phase = int(fast_forward), int(hold_phase)
        args.hold_from, args.rest_needed = int(hold_from), int(rest_needed)
        args.snapshot_every = every
        for name, array in out.items():
            setattr(args, name, _address(array))
        try:
            self._command("rollout", args)
        finally:
            # Snapshots taken in the server are the world's to free, a failed rollout's too.
            snapshots = tuple(int(i) for i in out["snapshot_ids"][: int(args.snapshots)])
            self.world.adopt_states(snapshots)
        steps = int(args.steps)
        points = np.empty((int(args.logged_points), 6))
        if points.shape[0]:
            self._command("contacts", points)
        counts = out["contact_points"][:steps]
        logged = np.flatnonzero(counts > 0) if record_mobility else np.empty(0, dtype=np.intp)
        return LoopRecord(
            torques=out["torques"][:steps],
            q=out["q"][:steps],
            qd=out["qd"][:steps],
            box_position=out["box_position"][:steps],
            ee_position=out["ee_position"][:steps],
            ee_orientation=out["ee_orientation"][:steps],
            contact_points=counts,
            fast_forward_from=int(args.fast_forward_from),
            snapshots=snapshots,
            logged_steps=logged,
            tool_com=out["tool_com"][logged],
            points=points,
        )

    def replay(
        self,
        *,
        robot: int,
        box: int,
        slots: tuple[tuple[int, ...], tuple[int, ...]],
        period: int,
        torques: np.ndarray,
    ) -> np.ndarray:
        """Apply ``torques`` (n, 7) open loop, ``period`` physics steps each: (n, 3) box centres."""
        commands = np.ascontiguousarray(torques, dtype=np.float64)
        if commands.ndim != 2 or commands.shape[1] != ARM:
            raise ValueError(f"torques must be an (n, {ARM}) array, got shape {commands.shape}")
        n = int(commands.shape[0])
        box_position = np.empty((n, 3))
        args = self._args(
            robot=robot, box=box, ee_link=-1, tool_link=-1, slots=slots, n=n, period=period
        )
        args.torques_in = _address(commands)
        args.box_position = _address(box_position)
        self._command("replay", args)
        return box_position

    def arm_matrices(
        self, *, robot: int, tool_link: int, q: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The tool's centre-of-mass Jacobians (m, 2, 3, 7) and M(q) (m, 7, 7) at q (m, 7).

        As PyBullet's ``calculateJacobian(robot, tool_link, (0, 0, 0), q, 0, 0)`` (linear, then
        angular) and ``calculateMassMatrix(robot, q)`` give them.
        """
        positions = np.ascontiguousarray(q, dtype=np.float64)
        if positions.ndim != 2 or positions.shape[1] != ARM:
            raise ValueError(f"q must be an (m, {ARM}) array, got shape {positions.shape}")
        m = int(positions.shape[0])
        jacobians, mass = np.empty((m, 2, 3, ARM)), np.empty((m, ARM, ARM))
        args = self._args(
            robot=robot,
            box=-1,
            ee_link=-1,
            tool_link=tool_link,
            slots=((0,) * ARM, (0,) * ARM),
            n=m,
            period=1,
        )
        args.q_ref = _address(positions)
        args.jacobians, args.mass_matrices = _address(jacobians), _address(mass)
        self._command("arm_matrices", args)
        return jacobians, mass
