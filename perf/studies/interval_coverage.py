"""How often the reports' 95 % intervals of a mean contain the true mean, by sample size.

The suites' reports give each mean over seeds, goals or designs (3 to 70 of them) with an
interval (``benchmarks.reports.stats.INTERVALS``): the Student t interval (the default) or the
percentile bootstrap. The script draws ``--trials`` samples of each size from a normal and from a
right-skewed (lognormal, sigma 0.5) distribution, computes both intervals of each sample's mean
with the reports' own functions, and prints the fraction that contain the true mean: the
interval's real coverage, to compare with its nominal 95 %.

Run: ``python -m perf.studies.interval_coverage [--trials 2000] [--sizes 3 5 10 20]``.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

import numpy as np

from benchmarks.reports.stats import INTERVALS, mean_interval
from perf import _args

#: name: (draw(rng, size), true mean)
DISTRIBUTIONS: dict[str, tuple[Callable[[np.random.Generator, int], np.ndarray], float]] = {
    "normal": (lambda rng, size: rng.normal(0.0, 1.0, size), 0.0),
    "lognormal (sigma 0.5)": (
        lambda rng, size: rng.lognormal(0.0, 0.5, size),
        math.exp(0.5**2 / 2.0),
    ),
}


def coverage(
    interval: str, size: int, distribution: str, trials: int, n_boot: int, seed: int
) -> float:
    """The fraction of ``trials`` samples whose 95 % ``interval`` contains the true mean."""
    draw, truth = DISTRIBUTIONS[distribution]
    rng = np.random.default_rng([seed, size, len(distribution)])
    hits = 0
    for _ in range(trials):
        ci = mean_interval(draw(rng, size), interval=interval, n_boot=n_boot, rng=rng)
        hits += ci.low <= truth <= ci.high
    return hits / trials


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--trials", type=_args.count(10), default=2000, help="samples per cell (default: 2000)"
    )
    parser.add_argument(
        "--sizes",
        type=_args.count(2, 1000),
        nargs="+",
        default=[3, 5, 10, 20],
        help="sample sizes (values per mean, 2 to 1000; default: 3 5 10 20)",
    )
    parser.add_argument(
        "--n-boot",
        type=_args.count(100),
        default=2000,
        help="bootstrap resamples per interval (default: 2000)",
    )
    parser.add_argument("--seed", type=_args.seed, default=0, help="the samples' seed")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    """Measure and print."""
    args = parse_args(argv)
    print(f"coverage of the 95 % interval of a mean, {args.trials} samples per cell")
    print(f"{'distribution':<24}{'n':>5}" + "".join(f"{name:>12}" for name in INTERVALS))
    for distribution in DISTRIBUTIONS:
        for size in args.sizes:
            cells = [
                coverage(name, size, distribution, args.trials, args.n_boot, args.seed)
                for name in INTERVALS
            ]
            print(f"{distribution:<24}{size:>5}" + "".join(f"{c:>12.3f}" for c in cells))


if __name__ == "__main__":
    main()
