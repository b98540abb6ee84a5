"""The fixed tool-use plan pi_0: a Cartesian path for the grasp point and its joint references.

The plan is the same for every tool (the tool hangs below the grasp point and does not change the
arm's kinematics), so its inverse kinematics is computed once per :class:`PlanSpec` and cached.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from tooldesign_env.specs import PlanSpec

__all__ = ["JointReference", "Phase", "cartesian_path", "min_jerk", "phases"]

#: A comfortable elbow-up posture that resolves the Panda's redundancy in inverse kinematics.
REST_POSE = (0.0, 0.2, 0.0, -2.0, 0.0, 2.2, 0.785)


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


def joint_reference(
    plan: PlanSpec,
    control_dt: float,
    solve_ik: object,
    *,
    knot_dt: float = 0.02,
) -> JointReference:
    """Solve the plan's inverse kinematics on a grid and spline it to the control steps.

    Inverse kinematics runs every ``knot_dt`` seconds, warm-started from the previous solution so
    the arm stays on one branch; a cubic spline through the solutions gives positions, velocities
    and accelerations that are consistent with each other (finite differences of per-step IK
    solutions are noisy, and the computed-torque controller feeds the accelerations forward).

    Args:
        plan: the plan.
        control_dt: control period, s.
        solve_ik: callable ``(position (3,), quaternion (4,), seed q (7,)) -> q (7,)``.
        knot_dt: spacing of the IK knots, s.
    """
    duration = plan.duration
    n_knots = max(int(math.ceil(duration / knot_dt)), 4) + 1
    knots = np.linspace(0.0, duration, n_knots)
    pos, yaw = cartesian_path(plan, knots)
    q = np.empty((n_knots, 7))
    seed = np.asarray(REST_POSE, dtype=float)
    for i in range(n_knots):
        # Two passes: the first from the seed, the second from its own answer, which removes
        # most of the residual of PyBullet's damped-least-squares solver.
        sol = solve_ik(pos[i], end_effector_quaternion(float(yaw[i])), seed)  # type: ignore[operator]
        sol = solve_ik(pos[i], end_effector_quaternion(float(yaw[i])), sol)  # type: ignore[operator]
        q[i] = seed = sol
    spline = CubicSpline(knots, q, axis=0, bc_type="clamped")
    n_steps = int(round(duration / control_dt))
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
