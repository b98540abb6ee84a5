"""Does evaluating many designs in one process leak memory or temporary files?

Evaluates N designs (default 1000) in one env and prints the resident memory after a warm-up
and at the end, the growth, and any file left in the temporary directory by the run.

Run: ``python -m perf.speed.evaluation_memory [--evaluations 1000]``.
Target: growth below 50 MB, no files left; the exit code is 1 when either is missed.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

import gymnasium as gym
import numpy as np

from perf import _args
from tooldesign_env import ToolDesignEnv


def rss_mb() -> float:
    """Resident set size of this process, MB (from /proc, Linux)."""
    with open(f"/proc/{os.getpid()}/status", encoding="ascii") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    raise RuntimeError("VmRSS not found")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--evaluations",
        type=_args.count(1),
        default=1000,
        help="evaluations measured (default: %(default)s)",
    )
    parser.add_argument(
        "--warmup",
        type=_args.count(0),
        default=20,
        help="evaluations before the first reading of the memory (default: %(default)s)",
    )
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    """Measure and print."""
    args = parse_args(argv)
    # A private temporary folder: whatever is left in it at the end was left by this run, not
    # by other programs on the machine.
    tmp = tempfile.mkdtemp(prefix="tooldesign-memory-")
    tempfile.tempdir = tmp
    os.environ["TMPDIR"] = tmp
    before_files = set(os.listdir(tmp))
    env = ToolDesignEnv()
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    box = env.action_space
    assert isinstance(box, gym.spaces.Box)
    lo, hi = box.low, box.high
    for _ in range(args.warmup):
        env.step(rng.uniform(lo, hi))
    start = rss_mb()
    t0 = time.perf_counter()
    for i in range(args.evaluations):
        env.step(rng.uniform(lo, hi))
        if (i + 1) % 100 == 0:
            print(f"  {i + 1:5d} evaluations: RSS {rss_mb():8.1f} MB", flush=True)
    end = rss_mb()
    env.close()
    left = sorted(set(os.listdir(tmp)) - before_files)
    print(f"evaluations: {args.evaluations} in {time.perf_counter() - t0:.0f} s")
    print(
        f"RSS after warm-up {start:.1f} MB, at the end {end:.1f} MB: growth {end - start:+.1f} MB"
    )
    print(f"files left in the run's temporary folder: {len(left)} {left[:5]}")
    if not left:
        os.rmdir(tmp)
    return 0 if end - start < 50.0 and not left else 1


if __name__ == "__main__":
    raise SystemExit(main())
