"""Designing a tool: Algorithm 1 of the paper (ask a batch, evaluate it, tell, repeat).

- :mod:`~benchmarks.design.config`: :class:`DesignConfig`, what a run is.
- :mod:`~benchmarks.design.stepper`: :class:`DesignStepper`, one iteration at a time.
- :mod:`~benchmarks.design.loop`: :func:`run_design`, the whole resumable run into a run folder.
- :mod:`~benchmarks.design.evaluate`: :func:`evaluate_coefficients`, one given design's terms,
  trajectories, mesh and plots (``tooldesign evaluate``).
- :mod:`~benchmarks.design.video`: rollout GIFs rendered headless.

The figures of a run are drawn from its stored files by :mod:`benchmarks.reports`.
"""

from __future__ import annotations

from benchmarks.design.config import DESIGN_SUITE, DesignConfig
from benchmarks.design.loop import CARD_VERSION, DesignResult, run_design
from benchmarks.design.stepper import DesignStepper, best_evaluation

__all__ = [
    "CARD_VERSION",
    "DESIGN_SUITE",
    "DesignConfig",
    "DesignResult",
    "DesignStepper",
    "best_evaluation",
    "run_design",
]
