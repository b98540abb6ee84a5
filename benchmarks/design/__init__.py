"""Designing a tool: Algorithm 1 of the paper (ask a batch, evaluate it, tell, repeat).

- :mod:`~benchmarks.design.config`: :class:`DesignConfig`, what a run is; :class:`TaskConfig`,
  the task fields it shares with a suite.
- :mod:`~benchmarks.design.stepper`: :class:`DesignStepper`, one iteration at a time.
- :mod:`~benchmarks.design.loop`: :func:`run_design`, the whole resumable run into a run folder.
- :mod:`~benchmarks.design.evaluate`: :func:`evaluate_coefficients`, one given design's terms,
  trajectories, mesh and plots (``tooldesign evaluate``).
- :mod:`~benchmarks.design.video`: rollout GIFs rendered headless.

The figures of a run are drawn from its stored files by :mod:`benchmarks.reports`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from tooldesign_env.lazy import lazy_attribute

if TYPE_CHECKING:
    from benchmarks.design.config import DESIGN_SUITE, DesignConfig, TaskConfig
    from benchmarks.design.evaluate import evaluate_coefficients
    from benchmarks.design.loop import CARD_VERSION, DesignResult, run_design
    from benchmarks.design.stepper import DesignStepper, best_evaluation

#: Where each public name lives. They are imported on first use (PEP 562): the loop loads pandas
#: and the storage layer, which ``tooldesign design --help`` (reading DesignConfig's defaults)
#: does not need.
_LAZY: dict[str, str] = {
    "CARD_VERSION": "benchmarks.design.loop",
    "DESIGN_SUITE": "benchmarks.design.config",
    "DesignConfig": "benchmarks.design.config",
    "DesignResult": "benchmarks.design.loop",
    "DesignStepper": "benchmarks.design.stepper",
    "TaskConfig": "benchmarks.design.config",
    "best_evaluation": "benchmarks.design.stepper",
    "evaluate_coefficients": "benchmarks.design.evaluate",
    "run_design": "benchmarks.design.loop",
}

__all__ = [
    "CARD_VERSION",
    "DESIGN_SUITE",
    "DesignConfig",
    "DesignResult",
    "DesignStepper",
    "TaskConfig",
    "best_evaluation",
    "evaluate_coefficients",
    "run_design",
]


def __getattr__(name: str) -> Any:
    return lazy_attribute(__name__, _LAZY, name)


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
