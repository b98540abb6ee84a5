r"""Evaluations at a physics preset, to be counted by valgrind's callgrind.

Instruction counts do not depend on the machine's load, so a preset's cost against the
defaults' is measured in them on a shared machine (``docs/performance.md``, "The preset,
measured"). The script makes ``ToolDesign-v0`` at ``--preset`` (``defaults``: the specs'
defaults), warms it with one evaluation (the plan, imports, caches), then evaluates the first
``--designs`` of the straight tool, the hook and uniform random cubics (seed ``--seed``).
Count it twice, with ``--designs N`` and ``--designs 0``: the difference over N is the cost of
an evaluation, without the imports and the warm-up::

    for n in 0 4; do valgrind --tool=callgrind --callgrind-out-file=/tmp/cg-$n.out \
        python -m perf.speed.preset_callgrind --preset lower-floor --designs $n; done
    callgrind_annotate --inclusive=yes /tmp/cg-4.out | grep -E "TOTALS|apply_and_step|eigvalsh"

Run it with the Python binary itself, not a shell shim such as pyenv's, which valgrind would
count instead (``python -c "import sys; print(sys.executable)"`` names it).
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from perf import _args
from tooldesign_env import ToolDesignEnv
from tooldesign_env.specs import PHYSICS_PRESETS, physics_preset


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--preset",
        choices=("defaults", *sorted(PHYSICS_PRESETS)),
        default="defaults",
        help="the physics preset (default: the specs' defaults)",
    )
    parser.add_argument(
        "--designs",
        type=_args.count(0),
        default=4,
        help="evaluations after the warm-up (0 counts the warm-up alone; default: %(default)s)",
    )
    parser.add_argument("--seed", type=_args.seed, default=0, help="the random designs' seed")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    """Evaluate and exit; the counting is valgrind's."""
    args = parse_args(argv)
    kwargs: dict[str, Any] = {}
    if args.preset != "defaults":
        kwargs = physics_preset(args.preset).specs()
    env = ToolDesignEnv(**kwargs)
    try:
        env.reset(seed=0)
        env.step(np.zeros(3))  # warm
        rng = np.random.default_rng(args.seed)
        designs = [np.zeros(3), np.array([0.0, 1.5, 0.0])]
        randoms = rng.uniform(
            [-1.5, -1.5, -0.5], [1.5, 1.5, 0.5], size=(max(args.designs - 2, 0), 3)
        )
        designs += list(randoms)
        for coefficients in designs[: args.designs]:
            env.step(coefficients)
    finally:
        env.close()
    print(f"{args.designs} evaluations at {args.preset} after one warm-up evaluation")


if __name__ == "__main__":
    main()
