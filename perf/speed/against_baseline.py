"""Time per episode of this tree against an older tree's own script, alternating, in one run.

``compare_trees.py`` measures two trees with this tree's ``evaluation_speed.py``, which needs
this tree's API. A tree from before that API (fb4a75c, issue 13's starting point) is measured
with its own ``evaluation_speed.py`` instead; both print the median wall time of one
evaluation of F ("evaluation of F ... median X s"), which is what this script compares. Each
round runs the baseline, then each variant of this tree (``--variant``, arguments added to this
tree's script), in turn, so all see the same load; the table shows every round and the median
of each variant's ratio to the baseline of its round.

Issue 13's comparison, one core, square section for all (fb4a75c had no other):
``git worktree add /tmp/fb4a75c fb4a75c`` then
``taskset -c 0 python -m perf.speed.against_baseline /tmp/fb4a75c --rounds 6
--variant "" --variant "--scene merge_fixed_links=False"``.
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import statistics
import subprocess
import sys
from pathlib import Path

from perf import _args

HERE = Path(__file__).resolve().parents[2]
#: Where a tree's script is: older trees kept the perf scripts in the benchmarks package.
SCRIPT = Path("benchmarks") / "perf" / "evaluation_speed.py"
#: Newer trees keep it in perf/speed/ and run it as a module from the tree's root.
MODULE = Path("perf") / "speed" / "evaluation_speed.py"
EVALUATION = re.compile(r"evaluation of F[^\n]*?median ([0-9.]+) s")


def _script(tree: Path) -> list[str] | None:
    """How to run ``tree``'s own evaluation_speed (from the tree's root), or None if it has none."""
    if (tree / SCRIPT).is_file():
        return [str(tree / SCRIPT)]
    if (tree / MODULE).is_file():
        return ["-m", "perf.speed.evaluation_speed"]
    return None


def _median_evaluation(tree: Path, args: list[str]) -> float:
    env = {**os.environ, "PYTHONPATH": str(tree)}
    script = _script(tree) or []
    out = subprocess.run(
        [sys.executable, *script, *args],
        env=env,
        cwd=tree,
        capture_output=True,
        text=True,
        check=False,
    )
    match = EVALUATION.search(out.stdout)
    if out.returncode != 0 or match is None:
        raise SystemExit(
            f"{' '.join(script)} in {tree} {' '.join(args)} failed (exit {out.returncode}):\n"
            f"{out.stdout[-2000:]}{out.stderr[-2000:]}"
        )
    return float(match.group(1))


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("baseline", type=Path, help="the older source tree (a git worktree)")
    parser.add_argument(
        "--rounds", type=_args.count(1), default=6, help="rounds (default: %(default)s)"
    )
    parser.add_argument(
        "--designs",
        type=_args.count(
            2, why=" (the baseline's script always runs the straight tool and the hook)"
        ),
        default=12,
        help="--designs of both scripts: the straight tool, the hook, then N - 2 random designs "
        "(N >= 2; default: %(default)s)",
    )
    parser.add_argument(
        "--repeats",
        type=_args.count(1),
        default=2,
        help="--repeats of both scripts (default: %(default)s)",
    )
    parser.add_argument(
        "--baseline-args",
        default="--reference 1",
        help="more arguments for the baseline's script (fb4a75c's cannot take --reference 0)",
    )
    parser.add_argument(
        "--this-args",
        default="--reference 0 --first 0 --section-shape square",
        help="arguments for this tree's script in every variant",
    )
    parser.add_argument(
        "--variant",
        action="append",
        help='arguments added to this tree\'s script, e.g. "--scene merge_fixed_links=False" '
        '(repeatable; default: one variant, "")',
    )
    args = parser.parse_args(argv)
    for name, texts in (
        ("--baseline-args", [args.baseline_args]),
        ("--this-args", [args.this_args]),
        ("--variant", args.variant or []),
    ):
        for text in texts:
            try:
                shlex.split(text)
            except ValueError as error:
                parser.error(f"{name} {text!r}: {error} (the arguments are split as a shell does)")
    baseline = args.baseline.resolve()
    if _script(baseline) is None:
        parser.error(f"{baseline} has no {SCRIPT} nor {MODULE}: give the root of a source tree")
    return args


def main(argv: list[str] | None = None) -> None:
    """Measure and print."""
    args = parse_args(argv)
    baseline = args.baseline.resolve()
    variants = args.variant or [""]
    common = ["--designs", str(args.designs), "--repeats", str(args.repeats)]
    times: dict[str, list[float]] = {"baseline": []} | {v: [] for v in variants}
    for k in range(args.rounds):
        times["baseline"].append(
            _median_evaluation(baseline, [*common, *shlex.split(args.baseline_args)])
        )
        for v in variants:
            extra = [*shlex.split(args.this_args), *shlex.split(v)]
            times[v].append(_median_evaluation(HERE, [*common, *extra]))
        print(
            f"round {k + 1}: baseline {times['baseline'][-1]:.3f} s; "
            + "; ".join(f"[{v or 'this tree'}] {times[v][-1]:.3f} s" for v in variants),
            flush=True,
        )
    print(f"\nmedian evaluation of F over {args.rounds} rounds ({baseline} = baseline):")
    print(f"  baseline: {statistics.median(times['baseline']):.3f} s")
    for v in variants:
        ratios = [t / b for t, b in zip(times[v], times["baseline"], strict=True)]
        print(
            f"  [{v or 'this tree'}]: {statistics.median(times[v]):.3f} s; per round / baseline: "
            f"{' '.join(f'{r:.2f}' for r in ratios)}; median {statistics.median(ratios):.3f}"
        )


if __name__ == "__main__":
    main()
