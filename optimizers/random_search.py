"""``random``: uniform random sampling in the box, the baseline of the paper's comparison."""

from __future__ import annotations

import numpy as np

from .base import Optimizer

__all__ = ["RandomSearch"]


class RandomSearch(Optimizer):
    """Independent uniform samples in the bounds; tells are recorded and otherwise ignored.

    Args:
        bounds: (d, 2) [low, high] per dimension in physical units.
        **kwargs: ``batch_size``, ``seed``, ``failure_policy``, ``low``/``high`` of
            :class:`~optimizers.base.Optimizer`.
    """

    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        return self._rng.random((len(ids), self.n_dims))

    def _tell(
        self, ids: tuple[int, ...], x: np.ndarray, values: np.ndarray, failed: np.ndarray
    ) -> None:
        pass  # uniform sampling learns nothing
