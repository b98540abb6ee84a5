"""A saved policy behind the ask/tell interface, so that it designs into an ordinary run folder.

``tooldesign design --policy PATH --goal X Y Z --out DIR`` runs the usual design loop
(:func:`benchmarks.design.run_design`) with this "optimizer" for one iteration of one design: the
policy's zero-shot tool for the goal. The run folder is the same as any design run's (evaluation
log, design card, meshes, figures, robustness test), and the manifest records the policy's path
and SHA-256 among the optimizer settings, so a resume with a changed policy is refused.

This module is not in :mod:`optimizers`: a policy needs the RL env to read its observation, and
optimizers never import the simulation.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np

from optimizers.base import Optimizer

__all__ = ["POLICY_DESIGNER", "PolicyDesigner"]

POLICY_DESIGNER = "benchmarks.rl.designer:PolicyDesigner"
"""The optimizer name (``module:Class``) of a design run made with a saved policy."""


def _check_in_bounds(c: np.ndarray, low: np.ndarray, high: np.ndarray) -> None:
    """Refuse a policy's design (physical coefficients) outside a run's bounds ``low``-``high``.

    Raises:
        ValueError: Another shape than the bounds', or a coefficient outside them.
    """
    if c.shape != low.shape or np.any(c < low) or np.any(c > high):
        raise ValueError(
            f"the policy's design {c.tolist()} is outside the run's bounds "
            f"{np.stack([low, high], axis=1).tolist()}; give the bounds it was trained with"
        )


class PolicyDesigner(Optimizer):
    """Asks the tool a saved policy designs for ``goal`` and ``box_mass``; learns nothing.

    Args:
        bounds: The run's coefficient bounds; the policy's design must lie inside them.
        batch_size: Must be 1: a deterministic policy has one design per task.
        seed: Unused (the policy is deterministic); accepted like every optimizer's.
        policy: Path of the policy card (:func:`benchmarks.rl.save_policy`).
        goal: (x, y, z) in m, the task's goal.
        box_mass: kg, the task's box mass (the observation of a mass-conditioned policy).
        sha256: :func:`benchmarks.rl.policy_digest` of the policy when the run began; checked
            before the policy is loaded.
        allow_pickle: Load a policy card of format 1, whose Stable-Baselines3 ``.zip`` runs code
            when it is unpickled (``--allow-pickle``; it warns).

    Raises:
        ValueError: A batch size other than 1, a policy whose digest is not ``sha256``, a bad
            card, goal or mass, or a design outside ``bounds``.
        FileNotFoundError: No such policy.
    """

    generational: ClassVar[bool] = False

    def __init__(
        self,
        bounds: Any = None,
        *,
        batch_size: int = 1,
        seed: Any = None,
        policy: str | os.PathLike[str],
        goal: Sequence[float],
        box_mass: float,
        sha256: str,
        allow_pickle: bool = False,
    ) -> None:
        if batch_size != 1 or isinstance(batch_size, bool):
            raise ValueError(
                f"a policy designs one tool per task: batch_size must be 1, got {batch_size!r}"
            )
        super().__init__(bounds, batch_size=1, seed=seed)
        from benchmarks.rl.policies import design_for_goal

        # The digest is checked on the bytes that are then loaded, before anything is parsed.
        design = design_for_goal(
            policy,
            goal,
            box_mass=box_mass,
            simulate=False,
            allow_pickle=allow_pickle,
            sha256=sha256,
        )
        c = np.asarray(design.coefficients, dtype=np.float64)
        _check_in_bounds(c, self._low, self._high)
        self.coefficients: np.ndarray = c
        self._unit = (c - self._low) / self._span

    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        return np.tile(self._unit, (len(ids), 1))

    def _to_physical(self, u: np.ndarray) -> np.ndarray:
        # The policy's own coefficients, bit for bit: the way through the unit box and back may
        # round the last digit, and a design run must simulate what `tooldesign rl design` does.
        if u.ndim == 1:
            return np.array(self.coefficients, dtype=np.float64)
        return np.repeat(self.coefficients[np.newaxis, :], len(u), axis=0)

    def _tell(
        self, ids: tuple[int, ...], x: np.ndarray, values: np.ndarray, failed: np.ndarray
    ) -> None:
        """A policy does not learn from its score."""
