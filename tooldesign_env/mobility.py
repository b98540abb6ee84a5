"""Contact mobility: the box's acceleration per unit joint torque through its contact with the tool.

What the contact estimator of control confidence reads (:class:`~tooldesign_env.objective.contact.
ContactEstimator`): :func:`contact_mobility` per contact point, from the arm's Jacobian and mass
matrix, and :func:`mobility_series` per control step of a rollout, from the contact manifolds a
control loop logged. Arithmetic only: the matrices come from the control loops
(:meth:`tooldesign_env.control_loop.ControlLoops.arm_matrices`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from tooldesign_env.native import LoopRecord

__all__ = ["contact_mobility", "mobility_series"]


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


def mobility_series(
    record: LoopRecord,
    n: int,
    arm_matrices: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    box_mass: float,
    box_size: tuple[float, float, float],
) -> np.ndarray:
    """(n, 3, 7) mean :func:`contact_mobility` over the manifold of each logged step.

    The mean, not the sum, so that a manifold that gains or loses a duplicate point does
    not change it. The Jacobians and the mass matrix are functions of q alone, so they are
    computed after the rollout, rather than inside the control loop.

    Args:
        record: a control loop's record with its logged contact manifolds.
        n: control steps of the whole episode (steps past the record stay zero).
        arm_matrices: (m, 7) joint positions -> the tool's centre-of-mass Jacobians
            (m, 2, 3, 7) and the mass matrices (m, 7, 7).
        box_mass: kg.
        box_size: the box's full extents (x, y, z), m.
    """
    out = np.zeros((n, 3, 7))
    logged = record.logged_steps
    steps = len(logged)
    if not steps:
        return out
    jacobians, mass = arm_matrices(record.q[logged])
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
        box_mass,
        box_size,
    )
    per_step = np.zeros((steps, 3, 7))
    np.add.at(per_step, owner, per_point)
    out[logged] = per_step / counts[:, None, None]
    return out
