"""The paper's robustness test: the same tool, plan and controller, a heavier box.

For a design, the box trajectory X(m, t) and torques U(m, t) at the nominal mass m are compared with
those at altered masses m_i (default 0.3, 0.5, 0.7, 0.9 kg):

* robustness = - sum_i sum_t |X(m_i, t) - X(m, t)|   (higher is better), m
* accuracy = - sum_i sum_t |X(m_i, t) - X^g|          (higher is better), m
* control deviation = sum_i sum_t |U(m_i, t) - U(m, t)| (lower is better), N m

The paper calls the accuracy a "sum of squared errors" but writes a norm; the norm is used here, as
in its equation. Sums run over control steps.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from numbers import Real

import numpy as np

from tooldesign_env.geometry import ToolGeometry
from tooldesign_env.schema import ROBUSTNESS_MASSES
from tooldesign_env.simulation import ToolSimulator, Trajectory
from tooldesign_env.specs import BOX_MASS_MAX

__all__ = ["DEFAULT_MASSES", "RobustnessResult", "evaluate_robustness", "robustness_metrics"]

#: The paper's altered box masses, kg (:data:`tooldesign_env.schema.ROBUSTNESS_MASSES`).
DEFAULT_MASSES = ROBUSTNESS_MASSES


@dataclass(frozen=True, eq=False)
class RobustnessResult:
    """Robustness of one design under box-mass changes.

    Attributes:
        robustness: - sum_i sum_t |X(m_i, t) - X(m, t)|, m.
        accuracy: - sum_i sum_t |X(m_i, t) - X^g|, m.
        control_deviation: sum_i sum_t |U(m_i, t) - U(m, t)|, N m.
        nominal_mass: m, kg.
        masses: the m_i, kg.
        nominal: the trajectory at m.
        perturbed: the trajectories at each m_i, in order.
    """

    robustness: float
    accuracy: float
    control_deviation: float
    nominal_mass: float
    masses: tuple[float, ...]
    nominal: Trajectory
    perturbed: tuple[Trajectory, ...]


def robustness_metrics(
    nominal: Trajectory, perturbed: Sequence[Trajectory], goal: Sequence[float]
) -> tuple[float, float, float]:
    """(robustness, accuracy, control deviation) from already simulated trajectories."""
    goal_arr = np.asarray(goal, dtype=float)
    robustness = accuracy = deviation = 0.0
    for traj in perturbed:
        if len(traj) != len(nominal):
            raise ValueError("trajectories must have the same number of steps")
        robustness -= float(
            np.sum(np.linalg.norm(traj.box_position - nominal.box_position, axis=1))
        )
        accuracy -= float(np.sum(np.linalg.norm(traj.box_position - goal_arr, axis=1)))
        deviation += float(np.sum(np.linalg.norm(traj.torques - nominal.torques, axis=1)))
    return robustness, accuracy, deviation


def evaluate_robustness(
    simulator: ToolSimulator,
    geometry: ToolGeometry,
    goal: Sequence[float],
    *,
    masses: Sequence[float] = DEFAULT_MASSES,
    nominal_mass: float | None = None,
) -> RobustnessResult:
    """Simulate a design at the nominal box mass and at each altered mass.

    Args:
        simulator: the world to use (its scene's box mass is the default nominal mass).
        geometry: the tool.
        goal: X^g (3,), m.
        masses: the altered masses m_i, kg; each finite, > 0 and at most ``BOX_MASS_MAX``
            (1000 kg), as every box mass.
        nominal_mass: m, kg; the scene's box mass if None.

    Raises:
        TypeError: masses that are not a sequence of real numbers (a scalar, bools).
        ValueError: bad masses, or a design that is not a usable tool (as ``env.step`` reports
            it invalid): one that cannot be built, or that overlaps the box where the sweep
            starts. Its numbers would describe a tool that cannot exist.
    """
    allowed = f"a non-empty sequence of finite masses > 0 and <= {BOX_MASS_MAX:g} kg"
    if isinstance(masses, (str, bytes)) or not isinstance(masses, Sequence | np.ndarray):
        raise TypeError(f"masses must be {allowed}, got {masses!r}")
    if any(isinstance(m, (bool, np.bool_)) or not isinstance(m, Real) for m in masses):
        raise TypeError(f"masses must be {allowed}, got {list(masses)!r}")
    masses = tuple(float(m) for m in masses)
    if not masses or not all(math.isfinite(m) and 0 < m <= BOX_MASS_MAX for m in masses):
        raise ValueError(f"masses must be {allowed}, got {masses}")
    m0 = simulator.scene.box_mass if nominal_mass is None else float(nominal_mass)
    if not geometry.buildable:
        raise ValueError(
            f"the design {geometry.coeffs.tolist()} cannot be built "
            f"({geometry.why_not_buildable}): it has no robustness"
        )
    built = simulator.build(geometry, box_mass=m0)
    if not built.usable:
        raise ValueError(
            f"the design {geometry.coeffs.tolist()} {built.reason}, so it is not a usable "
            "tool: it has no robustness"
        )
    nominal = simulator.run()
    perturbed = tuple(simulator.rollout(geometry, box_mass=m) for m in masses)
    rob, acc, dev = robustness_metrics(nominal, perturbed, goal)
    return RobustnessResult(
        robustness=rob,
        accuracy=acc,
        control_deviation=dev,
        nominal_mass=m0,
        masses=masses,
        nominal=nominal,
        perturbed=perturbed,
    )
