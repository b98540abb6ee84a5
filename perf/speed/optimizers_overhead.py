"""What the optimizers cost per iteration, and the ``bo`` batch against scikit-optimize's default.

Prints, in one run:

* the ``bo`` plugin's batch ask (batch 8, d = 3) at 50, 100 and 200 observations, next to
  ``skopt.Optimizer`` with its default settings (``ask(n_points=8)``: constant liar, gp_hedge,
  L-BFGS over 10,000 candidates) on the same observations. ``--time-cap`` bounds the default's
  projected times, not measured ones: its ask at 50 observations is always measured (there is
  nothing to project it from; it took 24-48 s on the project's machines), and each larger size
  only while its time projected from the last measurement (2.2x per doubling of n: the time grows
  about linearly with n here) is within the cap. ``--time-cap 0`` skips these timings of the
  default (``--quality-seeds 0`` skips the quality comparison, which runs it too);
* the quality of both on analytic functions (shifted sphere and Rosenbrock in 3-D on the tool's
  coefficient box) at equal budget, median best value over seeds, with random sampling for
  scale;
* the optimizer overhead per iteration (ask + tell, batch 8, d = 3, 15 iterations on a shifted
  sphere) of every available plugin.

Run: ``python -m perf.speed.optimizers_overhead [--time-cap 90] [--quality-seeds 3]``.
Target: the ``bo`` batch under 2 s at 200 observations on a two-core machine.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
import warnings
from collections.abc import Callable
from typing import cast

import numpy as np

import optimizers
from optimizers.bo import BayesianOptimization
from perf import _args

BOUNDS = np.array([[-1.5, 1.5], [-1.5, 1.5], [-0.5, 0.5]])
SHIFT = np.array([0.4, -0.7, 0.2])
BATCH = 8


def sphere(x: np.ndarray) -> np.ndarray:
    """Shifted sphere, minimum 0 at SHIFT; (n, 3) -> (n,)."""
    return cast("np.ndarray", np.sum((x - SHIFT) ** 2, axis=1))


def rosenbrock(x: np.ndarray) -> np.ndarray:
    """Rosenbrock in 3-D; on BOUNDS its minimum is on the face x3 = 0.5; (n, 3) -> (n,)."""
    return cast(
        "np.ndarray",
        np.sum(100.0 * (x[:, 1:] - x[:, :-1] ** 2) ** 2 + (1.0 - x[:, :-1]) ** 2, axis=1),
    )


def observations(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Uniform points of the unit box, (n, 3), and their Rosenbrock values (physical units)."""
    u = np.random.default_rng(seed).random((n, 3))
    return u, rosenbrock(BOUNDS[:, 0] + u * (BOUNDS[:, 1] - BOUNDS[:, 0]))


def fast_bo_asks(n: int) -> tuple[float, float]:
    """Seconds of one ``bo`` batch ask with exactly n observations told: (warm, cold).

    Warm is the batch of a run in progress (the hyperparameter search starts from the previous
    batch's values); cold is a fresh optimizer's first model (with ``gp_restarts`` restarts).
    """
    u, y = observations(n)
    times = []
    for told_before in (n - BATCH, n):
        optimizer = BayesianOptimization(BOUNDS, batch_size=BATCH, seed=0, n_initial_points=1)
        # The public API tells only points it asked; to measure at exactly n observations (not a
        # multiple of 8) the first ones are handed to the plugin's hook, which is all that a
        # tell does for bo, with the initial design marked as used.
        optimizer._n_initial_used = 1
        optimizer._tell(
            tuple(range(told_before)),
            u[:told_before],
            y[:told_before],
            np.zeros(told_before, dtype=bool),
        )
        if told_before < n:
            batch = optimizer.ask()  # fits the hyperparameters the timed batch starts from
            optimizer.tell(batch.ids, rosenbrock(batch.x))
        start = time.perf_counter()
        optimizer.ask()
        times.append(time.perf_counter() - start)
    return times[0], times[1]


def default_skopt_ask(n: int) -> tuple[float, float]:
    """Seconds of skopt's default tell (one fit) and ask(n_points=8) with n observations."""
    from skopt import Optimizer

    optimizer = Optimizer([(0.0, 1.0)] * 3, random_state=0)
    u, y = observations(n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = time.perf_counter()
        optimizer.tell(u.tolist(), y.tolist())
        tell = time.perf_counter() - start
        start = time.perf_counter()
        optimizer.ask(n_points=BATCH)
    return tell, time.perf_counter() - start


#: The numbers of observations of the batch-ask timings, each twice the one before.
SIZES = (50, 100, 200)
#: The growth of skopt's default ask from one size to the next (about linear in n, with a margin).
GROWTH = 2.2


def bo_timing(time_cap: float) -> None:
    """Print the batch ask times of bo and of skopt's default at 50, 100, 200 observations.

    skopt's default ask is measured at the first size unless ``time_cap`` is 0, then at each
    larger size while its projected time (the last measured one, times :data:`GROWTH` per
    size since) is at most ``time_cap`` seconds.
    """
    print("\n== bo: one batch ask (batch 8, d = 3), seconds ==")
    header = ("observations", "bo warm", "bo cold", "skopt default ask", "(+ its tell)")
    print("{:>12} {:>8} {:>8} {:>18} {:>13}".format(*header))
    projected: float | None = None  # skopt's default ask at this size, from the last measured
    for n in SIZES:
        warm, cold = fast_bo_asks(n)
        if time_cap == 0.0:
            print(f"{n:>12} {warm:>8.2f} {cold:>8.2f}   skipped: --time-cap 0")
            continue
        if projected is not None and projected > time_cap:
            skipped = f"skipped: projected {projected:.1f} s > --time-cap {time_cap:g} s"
            print(f"{n:>12} {warm:>8.2f} {cold:>8.2f}   {skipped}")
            projected *= GROWTH
            continue
        tell, ask = default_skopt_ask(n)
        projected = ask * GROWTH  # the next size doubles n
        print(f"{n:>12} {warm:>8.2f} {cold:>8.2f} {ask:>18.2f} {tell:>13.2f}")
    print("bo warm: a batch of a run in progress; cold: a fresh optimizer's first model")
    if time_cap > 0.0:
        print(
            f"skopt default: always measured at {SIZES[0]} observations; --time-cap "
            f"{time_cap:g} s bounds the larger sizes' projected times (x{GROWTH:g} per doubling)"
        )


def quality_run(
    name: str, objective: Callable[[np.ndarray], np.ndarray], seed: int, iterations: int
) -> float:
    """Best value after ``iterations`` batches of 8 of a registered optimizer."""
    optimizer = optimizers.make(name, bounds=BOUNDS, batch_size=BATCH, seed=seed)
    for _ in range(iterations):
        batch = optimizer.ask()
        optimizer.tell(batch.ids, objective(batch.x))
    return optimizer.recommend().value


def quality_default(
    objective: Callable[[np.ndarray], np.ndarray], seed: int, iterations: int
) -> float:
    """Best value after ``iterations`` batches of 8 of skopt's default ``Optimizer``."""
    from skopt import Optimizer

    optimizer = Optimizer([tuple(row) for row in BOUNDS.tolist()], random_state=seed)
    best = np.inf
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for _ in range(iterations):
            x = np.array(optimizer.ask(n_points=BATCH))
            values = objective(x)
            optimizer.tell(x.tolist(), values.tolist())
            best = min(best, float(values.min()))
    return best


def quality(seeds: int, iterations: int) -> None:
    """Print median best values of bo, skopt's default and random sampling at equal budget."""
    budget = f"{iterations} iterations x 8"
    print(f"\n== quality at equal budget ({budget}), median best value over {seeds} seeds ==")
    header = ("function", "bo (this plugin)", "skopt default", "random", "time bo / default")
    print("{:>10} {:>17} {:>14} {:>10} {:>18}".format(*header))
    for label, objective in (("sphere", sphere), ("rosenbrock", rosenbrock)):
        fast, default, uniform, t_fast, t_default = [], [], [], 0.0, 0.0
        for seed in range(seeds):
            start = time.perf_counter()
            fast.append(quality_run("bo", objective, seed, iterations))
            t_fast += time.perf_counter() - start
            start = time.perf_counter()
            default.append(quality_default(objective, seed, iterations))
            t_default += time.perf_counter() - start
            uniform.append(quality_run("random", objective, seed, iterations))
        print(
            f"{label:>10} {statistics.median(fast):>17.3g} {statistics.median(default):>14.3g} "
            f"{statistics.median(uniform):>10.3g} {t_fast:>8.1f} s / {t_default:.1f} s"
        )


def overhead() -> None:
    """Print construction time and ask + tell time per iteration of every available plugin."""
    print("\n== optimizer overhead per iteration (ask + tell, batch 8, d = 3, 15 iterations) ==")
    print(f"{'optimizer':>14} {'construct s':>12} {'median ms':>10} {'max ms':>8} {'total s':>8}")
    for name in optimizers.available():
        start = time.perf_counter()
        try:
            optimizer = optimizers.make(name, bounds=BOUNDS, batch_size=BATCH, seed=0)
        except Exception as error:  # an installed third-party plugin may want other settings
            print(f"{name:>14} cannot be built with defaults: {error}")
            continue
        construct = time.perf_counter() - start
        times = []
        for _ in range(15):
            start = time.perf_counter()
            batch = optimizer.ask()
            optimizer.tell(batch.ids, sphere(batch.x))
            times.append(time.perf_counter() - start)
        print(
            f"{name:>14} {construct:>12.2f} {1e3 * statistics.median(times):>10.1f} "
            f"{1e3 * max(times):>8.1f} {sum(times):>8.2f}"
        )


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--time-cap",
        type=_args.number(0.0, unit="s"),
        default=90.0,
        help="the largest projected time, s, of one ask of skopt's default at 100 and 200 "
        "observations, projected from the last one measured; the ask at 50 is always measured "
        "(0 skips these timings of skopt's default; default: %(default)s)",
    )
    parser.add_argument(
        "--quality-seeds",
        type=_args.count(0),
        default=3,
        help="seeds of the quality comparison (0 skips it; default: %(default)s)",
    )
    parser.add_argument(
        "--quality-iterations",
        type=_args.count(1),
        default=6,
        help="batches of 8 per optimizer in the quality comparison (default: %(default)s)",
    )
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    """Measure and print."""
    args = parse_args(argv)
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    print(f"cpus: {os.cpu_count()}, load average: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    print(f"available: {', '.join(optimizers.available())}")
    overhead()
    bo_timing(args.time_cap)
    if args.quality_seeds > 0:
        quality(args.quality_seeds, args.quality_iterations)


if __name__ == "__main__":
    main()
