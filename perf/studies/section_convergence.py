"""Does F converge as the tool's polyline is refined? Square section against round.

The tool is a polyline of ``n_segments`` chords (``ToolSpec.n_segments``), each a collision box
(square section) or a capsule (round section). A well-posed model gives an F that settles as the
polyline is refined. For each section, this script evaluates the same random valid designs with
each number of segments and prints, against the finest, the median and largest relative change of
F over the designs.

Run: ``python -m perf.studies.section_convergence [--designs 16] [--seed 11]
[--segments 15 30 60 120]``.
"""

from __future__ import annotations

import argparse
import statistics

from perf import _args
from perf.studies.confidence_noise import valid_designs
from tooldesign_env import ToolDesignEnv, ToolSimulator, ToolSpec
from tooldesign_env.geometry import SECTION_SHAPES


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=_args.count(1), default=16, help="random valid designs")
    parser.add_argument("--seed", type=_args.seed, default=11, help="the random designs' seed")
    parser.add_argument(
        "--segments",
        type=_args.count(1),
        nargs="+",
        default=[15, 30, 60, 120],
        help="numbers of segments, two different ones or more (default: 15 30 60 120)",
    )
    args = parser.parse_args(argv)
    if len(set(args.segments)) < 2:
        parser.error(f"--segments needs two different counts or more, got {args.segments}")
    for n in args.segments:
        try:
            ToolSpec(n_segments=n)
        except ValueError as error:
            parser.error(f"--segments: {error}")
    return args


def main(argv: list[str] | None = None) -> None:
    """Measure and print."""
    args = parse_args(argv)
    segments = sorted(set(args.segments))
    finest = segments[-1]
    # Chosen by the square section's rules, as when docs/model.md's figures were measured; a
    # design the round section cannot build is left out of its rows.
    designs = valid_designs(
        args.designs, args.seed, ToolSimulator(), ToolSpec(section_shape="square")
    )
    print(
        f"{len(designs)} random valid designs (seed {args.seed}); F against {finest} segments: "
        "median / largest relative change over the designs valid at both"
    )
    for shape in SECTION_SHAPES:
        values: dict[int, list[float | None]] = {}
        for n in segments:
            env = ToolDesignEnv(tool=ToolSpec(section_shape=shape, n_segments=n))
            env.reset(seed=0)
            infos = [env.step(c)[4] for c in designs]
            env.close()
            values[n] = [info["free_energy"] if info["valid"] else None for info in infos]
        for n in segments[:-1]:
            pairs = [
                (a, b)
                for a, b in zip(values[n], values[finest], strict=True)
                if a is not None and b is not None
            ]
            change = [abs(a - b) / abs(b) for a, b in pairs]
            median = statistics.median(change)
            print(
                f"{shape:6s} section, {n:4d} segments: median {100 * median:5.2f} %, largest "
                f"{100 * max(change):6.2f} % ({len(change)} designs)",
                flush=True,
            )


if __name__ == "__main__":
    main()
