"""Algorithm 1 one iteration at a time: ask a batch, hand it out, tell the scores.

:class:`DesignStepper` owns the optimizer and the iteration count; the caller owns the executor
and the run folder. :func:`benchmarks.design.loop.run_design` drives one stepper; the suite runner
(:mod:`benchmarks.suites.runner`) drives many at once through the scheduler.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from benchmarks.design.config import DESIGN_SUITE, DesignConfig
from benchmarks.storage import ResumeError, Unit
from tooldesign_env.schema import GOAL_COLUMNS, METRICS, STANDING_COLUMNS, coefficient_columns


def _make_optimizer(config: DesignConfig) -> Any:
    import optimizers

    # Unknown names raise ValueError naming the available ones; a missing backend raises an
    # ImportError naming the pip extra.
    return optimizers.make(
        config.optimizer,
        bounds=np.asarray(config.bounds, dtype=np.float64),
        batch_size=config.batch_size,
        seed=config.seed,
        **dict(config.optimizer_settings),
    )


def _ask(optimizer: Any, config: DesignConfig) -> tuple[np.ndarray, np.ndarray]:
    batch = optimizer.ask()
    ids = np.asarray(batch.ids)
    x = np.ascontiguousarray(batch.x, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != config.degree or len(ids) != len(x) or len(x) == 0:
        raise RuntimeError(
            f"optimizer {config.optimizer!r} asked a batch of shape {x.shape} with {len(ids)} "
            f"ids; expected (batch, {config.degree}) with one id per row"
        )
    return ids.astype(np.int64), x


def _tell(optimizer: Any, ids: np.ndarray, values: np.ndarray, failed: np.ndarray) -> None:
    # Failed evaluations are told as failures (NaN): the optimizer decides what that means.
    told = np.where(failed, np.nan, values)
    optimizer.tell(ids.tolist(), told)


def _values(frame: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Scores to tell from logged rows: F for ``ok`` and ``invalid`` (the env's penalty F)."""
    failed = (frame["status"] == "failed").to_numpy() | ~np.isfinite(frame["free_energy"])
    return frame["free_energy"].to_numpy(dtype=np.float64), failed


def _replay(optimizer: Any, config: DesignConfig, logged: list[pd.DataFrame]) -> None:
    columns = coefficient_columns(config.degree)
    for iteration, part in enumerate(logged):
        ids, x = _ask(optimizer, config)
        expected = np.ascontiguousarray(part[columns].to_numpy(dtype=np.float64))
        same_ids = np.array_equal(ids, part["eval_id"].to_numpy(dtype=np.int64))
        if x.shape != expected.shape or x.tobytes() != expected.tobytes() or not same_ids:
            raise ResumeError(
                f"cannot resume: replaying iteration {iteration}, optimizer {config.optimizer!r} "
                "asked other designs than the log holds (another optimizer version, settings or "
                "seed?); start a new run folder instead"
            )
        values, failed = _values(part)
        _tell(optimizer, ids, values, failed)


def _stored(value: Any) -> float:
    """A row's optional float (``final_height``, ``final_tilt``): NaN where it has none."""
    return math.nan if value is None else float(value)


def _batch_frame(
    config: DesignConfig,
    iteration: int,
    ids: np.ndarray,
    x: np.ndarray,
    rows: Sequence[Mapping[str, Any]],
    opt_time: float,
    *,
    suite: str = DESIGN_SUITE,
    variant: str = "",
    optimizer: str | None = None,
) -> pd.DataFrame:
    n = len(rows)
    data: dict[str, Any] = {
        "suite": [suite] * n,
        "optimizer": [config.optimizer if optimizer is None else optimizer] * n,
        "seed": [config.seed] * n,
        "iteration": [iteration] * n,
        "candidate": list(range(n)),
        "eval_id": ids.tolist(),
    }
    for j, name in enumerate(coefficient_columns(config.degree)):
        data[name] = x[:, j]
    for name in METRICS:
        data[name] = [float(r[name]) for r in rows]
    for name in STANDING_COLUMNS:  # NaN in a row that lacks them (a caller's own rows)
        data[name] = [_stored(r.get(name)) for r in rows]
    data["status"] = [str(r["status"]) for r in rows]
    data["eval_time"] = [float(r["eval_time"]) for r in rows]
    data["opt_time"] = [opt_time] * n
    for axis, value in zip(GOAL_COLUMNS, config.goal, strict=True):
        data[axis] = [value] * n
    data["goal_precision"] = [config.goal_precision] * n
    data["box_mass"] = [config.box_mass] * n
    data["variant"] = [variant] * n
    return pd.DataFrame(data)


class DesignStepper:
    """Algorithm 1 one iteration at a time, for a caller that evaluates the batches itself.

    :func:`run_design` drives one stepper with :func:`~benchmarks.execution.evaluate_batch`;
    :mod:`benchmarks.suites.runner` drives many at once through the scheduler. The stepper owns the
    optimizer
    and the iteration count; the caller owns the executor and the store.

    Args:
        config: The run's designer, budget and task.
        suite: ``suite`` column of the rows it makes.
        variant: ``variant`` column of the rows it makes.
        label: ``optimizer`` column of the rows; ``config.optimizer`` if ``None``.

    Raises:
        ValueError: If the optimizer is unknown or its settings are invalid.
        ImportError: If the optimizer's backend is not installed (the message names the extra).
    """

    def __init__(
        self,
        config: DesignConfig,
        *,
        suite: str = DESIGN_SUITE,
        variant: str = "",
        label: str | None = None,
    ) -> None:
        self.config = config
        self.optimizer = _make_optimizer(config)
        self.iteration = 0
        self._suite, self._variant, self._label = suite, variant, label
        self._asked: tuple[np.ndarray, np.ndarray, float] | None = None

    def unit(self, iteration: int) -> Unit:
        """The part file (:class:`~benchmarks.storage.Unit`) of this run's ``iteration``."""
        return Unit(
            suite=self._suite,
            variant=self._variant,
            optimizer=self.config.optimizer if self._label is None else self._label,
            seed=self.config.seed,
            iteration=iteration,
        )

    def replay(self, logged: Sequence[pd.DataFrame]) -> None:
        """Ask and tell the logged iterations again, checking each ask against the log.

        Args:
            logged: The logged batches of iterations 0, 1, ..., in order.

        Raises:
            ResumeError: If the optimizer asks other designs than the log holds.
        """
        if self.iteration or self._asked is not None:
            raise RuntimeError("replay() must come before the first ask()")
        _replay(self.optimizer, self.config, list(logged))
        self.iteration = len(logged)

    def ask(self) -> np.ndarray:
        """The next batch: (batch_size, n) coefficients to evaluate, in order."""
        if self._asked is not None:
            raise RuntimeError("tell() the last batch before asking the next one")
        tick = time.perf_counter()
        ids, x = _ask(self.optimizer, self.config)
        self._asked = (ids, x, time.perf_counter() - tick)
        return x

    def tell(self, rows: Sequence[Mapping[str, Any]]) -> pd.DataFrame:
        """Tell the evaluated batch and return its rows of the evaluation log.

        Args:
            rows: One row of :func:`~benchmarks.execution.evaluate_design` per asked design, in
                the asked order.

        Returns:
            The batch's evaluation-log rows, ``opt_time`` = (ask + tell time) / batch size.
        """
        if self._asked is None:
            raise RuntimeError("ask() a batch before telling it")
        ids, x, ask_time = self._asked
        if len(rows) != len(ids):
            raise ValueError(f"expected {len(ids)} evaluated rows, got {len(rows)}")
        frame = _batch_frame(
            self.config,
            self.iteration,
            ids,
            x,
            rows,
            0.0,
            suite=self._suite,
            variant=self._variant,
            optimizer=self._label,
        )
        values, failed = _values(frame)
        tick = time.perf_counter()
        _tell(self.optimizer, ids, values, failed)
        frame["opt_time"] = (ask_time + time.perf_counter() - tick) / len(ids)
        self._asked = None
        self.iteration += 1
        return frame


def best_evaluation(evaluations: pd.DataFrame) -> pd.Series:
    """The design of a run: its lowest-F ``ok`` evaluation (the first in log order on ties).

    Args:
        evaluations: The evaluation-log rows of one run, in log order.

    Returns:
        That row; the lowest-penalty ``invalid`` row (with a warning) if none is ``ok``.

    Raises:
        RuntimeError: If every evaluation failed.
    """
    return _best_row(evaluations)


class NothingEvaluated(RuntimeError):
    """Every evaluation of a run failed, so it has no design to report.

    A setting that no simulation survives, for example; the evaluation log says why.
    """


def _best_row(evaluations: pd.DataFrame) -> pd.Series:
    """The lowest-F valid evaluation (the first in log order on ties)."""
    finite = evaluations[np.isfinite(evaluations["free_energy"])]
    ok = finite[finite["status"] == "ok"]
    if len(ok):
        return ok.loc[ok["free_energy"].idxmin()]
    if len(finite):
        warnings.warn(
            "no design of the run was valid; the design card holds the lowest-penalty invalid one",
            RuntimeWarning,
            stacklevel=3,
        )
        return finite.loc[finite["free_energy"].idxmin()]
    raise NothingEvaluated(
        "no design of the run could be evaluated (every evaluation failed); see the status "
        "column of the evaluation log and the warnings above"
    )


def iteration_bests(evaluations: pd.DataFrame) -> pd.DataFrame:
    """Per iteration, its lowest-F valid evaluation (iterations without one are left out)."""
    ok = evaluations[(evaluations["status"] == "ok") & np.isfinite(evaluations["free_energy"])]
    index = ok.groupby("iteration", sort=True)["free_energy"].idxmin()
    return ok.loc[index.to_numpy()].reset_index(drop=True)
