"""The fixed tool-use plan pi_0: a Cartesian path for the grasp point and its joint references.

The plan is the same for every tool (the tool hangs below the grasp point and does not change the
arm's kinematics), so its inverse kinematics is computed once per :class:`PlanSpec` and cached: in
memory, and on disk (:func:`cache_dir`) keyed by everything the solution depends on
(:func:`cache_key`), so that a new process does not solve it again.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import io
import json
import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from tooldesign_env.files import write_atomic
from tooldesign_env.specs import PlanSpec

__all__ = [
    "CACHE_ENV",
    "JointReference",
    "Phase",
    "cache_dir",
    "cache_key",
    "cartesian_path",
    "joint_reference",
    "knot_times",
    "load_knots",
    "min_jerk",
    "phases",
    "reference_from_knots",
    "solve_knots",
    "store_knots",
]

#: A comfortable elbow-up posture that resolves the Panda's redundancy in inverse kinematics.
REST_POSE = (0.0, 0.2, 0.0, -2.0, 0.0, 2.2, 0.785)

#: Spacing of the inverse-kinematics knots of the plan, s.
KNOT_DT = 0.02


def min_jerk(tau: np.ndarray) -> np.ndarray:
    """Minimum-jerk progress s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5 for tau in [0, 1]."""
    tau = np.clip(tau, 0.0, 1.0)
    return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)


@dataclass(frozen=True)
class Phase:
    """One straight segment of the plan.

    Attributes:
        name: ``"lower"``, ``"settle"``, ``"sweep"``, ``"pull"`` or ``"hold"``.
        start: start time, s.
        duration: s.
        p0: grasp-point position at the start (x, y, z), m.
        p1: grasp-point position at the end, m.
        yaw0: tool yaw at the start, rad.
        yaw1: tool yaw at the end, rad.
    """

    name: str
    start: float
    duration: float
    p0: tuple[float, float, float]
    p1: tuple[float, float, float]
    yaw0: float
    yaw1: float


def phases(plan: PlanSpec) -> tuple[Phase, ...]:
    """The plan's segments in order (phases of zero duration are left out)."""
    qa, qb, h = plan.reach, plan.pull_to, plan.height
    top = (qa, 0.0, h + plan.lift)
    a = (qa, 0.0, h)
    b = (0.0, qa, h)
    c = (0.0, qb, h)
    y0, y1 = plan.yaw_start, plan.yaw_end
    spec = [
        ("lower", plan.lower_duration, top, a, y0, y0),
        ("settle", plan.settle_duration, a, a, y0, y0),
        ("sweep", plan.sweep_duration, a, b, y0, y1),
        ("pull", plan.pull_duration, b, c, y1, y1),
        ("hold", plan.hold_duration, c, c, y1, y1),
    ]
    out, t = [], 0.0
    for name, duration, p0, p1, yaw0, yaw1 in spec:
        if duration > 0:
            out.append(Phase(name, t, duration, p0, p1, yaw0, yaw1))
        t += duration
    return tuple(out)


def cartesian_path(plan: PlanSpec, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Grasp-point positions (n, 3) m and tool yaws (n,) rad of the plan at ``times`` (n,) s."""
    times = np.asarray(times, dtype=float)
    pos = np.empty((times.size, 3))
    yaw = np.empty(times.size)
    segs = phases(plan)
    for i, t in enumerate(times):
        seg = segs[-1]
        for s in segs:
            if t < s.start + s.duration:
                seg = s
                break
        progress = float(min_jerk(np.asarray((t - seg.start) / seg.duration)))
        pos[i] = np.asarray(seg.p0) + progress * (np.asarray(seg.p1) - np.asarray(seg.p0))
        yaw[i] = seg.yaw0 + progress * (seg.yaw1 - seg.yaw0)
    return pos, yaw


def end_effector_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) of Rz(yaw) Rx(pi): the gripper points down, its x axis at ``yaw``.

    The tool hangs from the end effector rotated by a further Rx(pi), so the tool frame is Rz(yaw):
    tool z up, tool x (along the handle) at ``yaw`` from the world x axis.
    """
    half = yaw / 2.0
    # Rz(yaw) * Rx(pi) = (cos(y/2), 0, 0, sin(y/2)) * (0, 1, 0, 0) in (w, x, y, z).
    return (math.cos(half), math.sin(half), 0.0, 0.0)


@dataclass(frozen=True)
class JointReference:
    """Joint references of the plan at each control step.

    Attributes:
        times: (T,) control-step times, s (the end of each control step).
        q: (T, 7) joint positions, rad.
        qd: (T, 7) joint velocities, rad/s.
        qdd: (T, 7) joint accelerations, rad/s^2.
        q0: (7,) joint positions at t = 0, rad.
        ee_position: (T, 3) planned grasp-point positions, m.
        yaw: (T,) planned tool yaw, rad.
    """

    times: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    q0: np.ndarray
    ee_position: np.ndarray
    yaw: np.ndarray


def knot_times(plan: PlanSpec, knot_dt: float = KNOT_DT) -> np.ndarray:
    """Times (n,) s of the inverse-kinematics knots of :func:`joint_reference`."""
    duration = plan.duration
    n_knots = max(int(math.ceil(duration / knot_dt)), 4) + 1
    return np.linspace(0.0, duration, n_knots)


def solve_knots(plan: PlanSpec, solve_ik: object, *, knot_dt: float = KNOT_DT) -> np.ndarray:
    """Joint positions (n, 7) rad at the :func:`knot_times`, by inverse kinematics.

    Warm-started from the previous solution so the arm stays on one branch.

    Args:
        plan: the plan.
        solve_ik: callable ``(position (3,), quaternion (4,), seed q (7,)) -> q (7,)``.
        knot_dt: spacing of the knots, s.
    """
    knots = knot_times(plan, knot_dt)
    pos, yaw = cartesian_path(plan, knots)
    q = np.empty((knots.size, 7))
    seed = np.asarray(REST_POSE, dtype=float)
    for i in range(knots.size):
        # Two passes: the first from the seed, the second from its own answer, which removes
        # most of the residual of PyBullet's damped-least-squares solver.
        sol = solve_ik(pos[i], end_effector_quaternion(float(yaw[i])), seed)  # type: ignore[operator]
        sol = solve_ik(pos[i], end_effector_quaternion(float(yaw[i])), sol)  # type: ignore[operator]
        q[i] = seed = sol
    return q


def reference_from_knots(
    plan: PlanSpec, control_dt: float, knot_q: np.ndarray, *, knot_dt: float = KNOT_DT
) -> JointReference:
    """Spline the knot solutions (n, 7) rad of :func:`solve_knots` to the control steps.

    A cubic spline through the solutions gives positions, velocities and accelerations that
    are consistent with each other (finite differences of per-step IK solutions are noisy, and
    the computed-torque controller feeds the accelerations forward).
    """
    knots = knot_times(plan, knot_dt)
    q = np.asarray(knot_q, dtype=float)
    if q.shape != (knots.size, 7) or not np.all(np.isfinite(q)):
        raise ValueError(
            f"knot_q must be a finite ({knots.size}, 7) array for this plan, got shape {q.shape}"
        )
    spline = CubicSpline(knots, q, axis=0, bc_type="clamped")
    n_steps = int(round(plan.duration / control_dt))
    times = control_dt * np.arange(1, n_steps + 1)
    ee, yaws = cartesian_path(plan, times)
    return JointReference(
        times=times,
        q=spline(times),
        qd=spline(times, 1),
        qdd=spline(times, 2),
        q0=q[0].copy(),
        ee_position=ee,
        yaw=yaws,
    )


def joint_reference(
    plan: PlanSpec,
    control_dt: float,
    solve_ik: object,
    *,
    knot_dt: float = KNOT_DT,
) -> JointReference:
    """Solve the plan's inverse kinematics on a grid and spline it to the control steps.

    Inverse kinematics runs every ``knot_dt`` seconds (:func:`solve_knots`), and a cubic spline
    through the solutions gives the references (:func:`reference_from_knots`).

    Args:
        plan: the plan.
        control_dt: control period, s.
        solve_ik: callable ``(position (3,), quaternion (4,), seed q (7,)) -> q (7,)``.
        knot_dt: spacing of the IK knots, s.
    """
    knot_q = solve_knots(plan, solve_ik, knot_dt=knot_dt)
    return reference_from_knots(plan, control_dt, knot_q, knot_dt=knot_dt)


# ------------------------------------------------------------------ the knot cache on disk
#: Environment variable naming the folder of the on-disk plan cache; set it to an empty
#: string to keep the cache in memory only.
CACHE_ENV = "TOOLDESIGN_CACHE_DIR"

#: Bumped whenever what a cache file holds, or how the knots are solved, changes meaning.
CACHE_FORMAT = "tooldesign-plan-knots/1"


def cache_dir() -> Path | None:
    """The folder of the on-disk plan cache, or None when it is switched off.

    ``$TOOLDESIGN_CACHE_DIR`` if set (an empty value switches the disk cache off), else
    ``$XDG_CACHE_HOME/tooldesign``, else ``~/.cache/tooldesign``.
    """
    value = os.environ.get(CACHE_ENV)
    if value is not None:
        return Path(value).expanduser() if value.strip() else None
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "tooldesign"


@functools.cache
def source_digest(module: str) -> str:
    """A digest (16 hex) of the source file of ``module``, for the keys of cached results.

    A result kept across processes must be computed again when the code that computes it
    changes, whether or not a format number was bumped; any edit of the file (a comment too)
    costs one recomputation. ``"unknown"`` if the module has no readable source file.
    """
    spec = importlib.util.find_spec(module)
    if spec is None or not spec.origin:
        return "unknown"  # not a file named "None" in the working folder
    try:
        with open(spec.origin, "rb") as f:
            return hashlib.sha256(f.read()).hexdigest()[:16]
    except OSError:
        return "unknown"


def cache_key(material: dict[str, Any]) -> str:
    """A hex SHA-256 of everything a cached result depends on (JSON, sorted keys).

    Floats are written by ``repr``, so every bit of every number counts.
    """
    text = json.dumps({"format": CACHE_FORMAT, **material}, sort_keys=True, allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _cache_path(folder: Path, key: str) -> Path:
    return folder / f"plan-knots-{key[:40]}.npz"


def load_knots(key: str, shape: tuple[int, int], folder: Path | None = None) -> np.ndarray | None:
    """The cached knot solutions for ``key``, or None if absent or not to be trusted.

    A file is used only if it is a NumPy archive (no pickles) holding the full key and a
    finite float64 array of exactly ``shape``; anything else (truncated, corrupt, written for
    another key, NaN) counts as a miss, never as an error.
    """
    folder = cache_dir() if folder is None else folder
    if folder is None:
        return None
    path = _cache_path(folder, key)
    try:
        with np.load(path, allow_pickle=False) as archive:
            stored_key = bytes(np.asarray(archive["key"], dtype=np.uint8)).decode("ascii")
            q = np.array(archive["q"])
    except FileNotFoundError:
        return None
    except Exception:  # noqa: BLE001 - any unreadable file is a miss, and will be rewritten
        return None
    if stored_key != key or q.dtype != np.float64 or q.shape != shape:
        return None
    if not np.all(np.isfinite(q)):
        return None
    return q


#: Cache folders found unwritable in this process: each is warned about once.
_UNWRITABLE: set[str] = set()


def store_knots(key: str, q: np.ndarray, folder: Path | None = None) -> bool:
    """Write the knot solutions for ``key`` atomically; whether it was written.

    The archive is written to a temporary file in the same folder and renamed over the
    target, so a reader sees the old file, the new one, or none: never half a file. A folder
    that cannot be created or written leaves the cache in memory only (a warning says so,
    once per folder and process).
    """
    folder = cache_dir() if folder is None else folder
    if folder is None:
        return False
    q = np.asarray(q, dtype=np.float64)
    archive = io.BytesIO()
    np.savez(archive, key=np.frombuffer(key.encode("ascii"), dtype=np.uint8), q=q)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        write_atomic(_cache_path(folder, key), archive.getvalue())
        return True
    except OSError as err:
        if str(folder) not in _UNWRITABLE:  # once per folder and process, for any file
            _UNWRITABLE.add(str(folder))
            warnings.warn(
                f"the plan cache folder {str(folder)!r} cannot be written ({err}); what it "
                "would keep (the plan's inverse kinematics, its joint references splined to "
                "the control steps, the merged hand's mass properties, the floor guard's sweep "
                f"of the plan) is cached in memory only (set {CACHE_ENV} to a writable folder, "
                "or to an empty string to silence this)",
                RuntimeWarning,
                stacklevel=2,
            )
        return False
