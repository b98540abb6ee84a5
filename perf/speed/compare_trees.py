"""Run evaluation_speed.py against two source trees in turn and print their figures side by side.

Each round runs this folder's ``evaluation_speed.py`` once with ``PYTHONPATH`` set to the first
tree and once to the second (alternating which goes first), so that both see the same load on a
shared machine; the table shows the median of each figure over the rounds. The script measured
is always this one, so both trees are measured the same way (the floor, the parts, the ratio).
It prints the control loop each tree ran and warns when they differ: a worktree made with
``git worktree add`` has no compiled C loop, and silently runs the slower Python one (copy
``tooldesign_env/native/_control_loop*.so`` into it when the C source is the same). A run
that fails stops the script with the run's error output, one line naming the run, and the run's
exit code.

Run, e.g. main against this worktree, one core:
``taskset -c 0 python -m perf.speed.compare_trees /work/main . --rounds 3 -- --designs 12
--repeats 2 --reference 0``.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from perf import _args

SCRIPT = Path(__file__).with_name("evaluation_speed.py")
#: The ``perf`` package this script belongs to: the child measures with it, whatever the tree.
PERF = Path(__file__).resolve().parents[1]
#: The child: ``perf`` from this checkout, everything else from PYTHONPATH (the tree measured);
#: its working folder is one with no package in it, since ``python -c`` puts that first.
_CHILD = (
    "import importlib.util, runpy, sys; "
    "spec = importlib.util.spec_from_file_location('perf', sys.argv.pop(1)); "
    "perf = importlib.util.module_from_spec(spec); sys.modules['perf'] = perf; "
    "spec.loader.exec_module(perf); "
    "runpy.run_module('perf.speed.evaluation_speed', run_name='__main__', alter_sys=True)"
)

#: The lines of the first evaluation of a fresh process, and its figure in medians.
_COLD = r"empty plan cache:\s+"
_WARM = r"plan cache on disk:\s+"
_MEDIANS = r"construction \+ first step median [0-9.]+ s \(([0-9.]+) medians"

#: (label, regular expression with one group) of the figures read from the script's output.
FIGURES = (
    ("evaluation (env.step), median s", r"evaluation of F \(env.step\):\s+median ([0-9.]+)"),
    ("build, median s", r"build world .*median ([0-9.]+)"),
    ("rollout + contact log, median s", r"controlled rollout \+ contact log:\s+median ([0-9.]+)"),
    ("objective, median s", r"objective \(mobility.*median ([0-9.]+)"),
    ("floor, median s", r"floor \(build .*median ([0-9.]+) s"),
    ("us per physics step (floor)", r"s, ([0-9.]+) us per physics step"),
    ("ratio: median of per-design ratios", r"median of per-design ratios ([0-9.]+);"),
    ("ratio of medians", r"ratio of medians ([0-9.]+)"),
    ("ratio: median per-design CPU ratio", r"CPU-time ratios ([0-9.]+)"),
    # The first evaluation of a fresh process: the env's construction + its first env.step.
    ("first evaluation, empty cache, s", _COLD + r"construction \+ first step median ([0-9.]+) s"),
    ("first evaluation, empty cache, medians", _COLD + _MEDIANS),
    ("  construction, empty cache, s", _COLD + r".*construction median ([0-9.]+) s"),
    ("  first step, empty cache, s", _COLD + r".*first step median ([0-9.]+) s"),
    (
        "first evaluation, cache on disk, s",
        _WARM + r"construction \+ first step median ([0-9.]+) s",
    ),
    ("first evaluation, cache on disk, medians", _WARM + _MEDIANS),
    ("  construction, cache on disk, s", _WARM + r".*construction median ([0-9.]+) s"),
    ("  first step, cache on disk, s", _WARM + r".*first step median ([0-9.]+) s"),
)


LOOP = re.compile(r"control loop: ([^;\n]*)")


def run(tree: Path, extra: list[str]) -> tuple[dict[str, float], str]:
    """One run of evaluation_speed.py with ``tree`` first on PYTHONPATH: figures, loop run.

    A run that fails ends this script: its error output is shown, then one line naming the run,
    and the exit code is the run's (1 for a run killed by a signal).
    """
    env = dict(os.environ, PYTHONPATH=str(tree))
    with tempfile.TemporaryDirectory(prefix="compare-trees-") as empty:
        done = subprocess.run(
            [sys.executable, "-c", _CHILD, str(PERF / "__init__.py"), *extra],
            env=env,
            cwd=empty,
            check=False,
            capture_output=True,
            text=True,
        )
    if done.returncode != 0:
        sys.stderr.write(done.stderr)
        how = (
            f"exit code {done.returncode}"
            if done.returncode > 0
            else f"killed by signal {-done.returncode}"
        )
        print(
            f"{Path(__file__).name}: {SCRIPT.name} {' '.join(extra)} failed ({how}) with "
            f"PYTHONPATH={tree}",
            file=sys.stderr,
        )
        raise SystemExit(done.returncode if done.returncode > 0 else 1)
    out = done.stdout
    figures = {}
    for label, pattern in FIGURES:
        match = re.search(pattern, out)
        if match:
            figures[label] = float(match.group(1))
    loop = LOOP.search(out)
    if loop is None:
        return figures, "not printed"
    # "native", or "Python loop: <why>", whose reason may name the tree's own files.
    return figures, "C" if loop.group(1).strip() == "native" else "Python"


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it.

    ``args.extra`` is then the arguments after ``--``, for evaluation_speed.py.
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", type=Path, help="source tree measured as 'before'")
    parser.add_argument("after", type=Path, help="source tree measured as 'after'")
    parser.add_argument(
        "--rounds", type=_args.count(1), default=3, help="runs of each tree (default: %(default)s)"
    )
    parser.usage = "%(prog)s before after [--rounds N] [-- arguments of evaluation_speed.py]"
    argv = sys.argv[1:] if argv is None else argv
    cut = argv.index("--") if "--" in argv else len(argv)
    args = parser.parse_args(argv[:cut])
    args.extra = argv[cut + 1 :]
    for name in ("before", "after"):
        tree = getattr(args, name).resolve()
        if not (tree / "tooldesign_env" / "__init__.py").is_file():
            parser.error(f"{name} tree {str(tree)!r} has no tooldesign_env package")
    return args


def main(argv: list[str] | None = None) -> None:
    """Measure and print."""
    args = parse_args(argv)
    extra = args.extra
    trees = {"before": args.before.resolve(), "after": args.after.resolve()}
    results: dict[str, list[dict[str, float]]] = {"before": [], "after": []}
    loops: dict[str, set[str]] = {"before": set(), "after": set()}
    for i in range(args.rounds):
        order = ("before", "after") if i % 2 == 0 else ("after", "before")
        for name in order:
            figures, loop = run(trees[name], extra)
            results[name].append(figures)
            loops[name].add(loop)
    for name in ("before", "after"):
        print(f"{name + ':':7s} {trees[name]} (control loop: {'; '.join(sorted(loops[name]))})")
    if loops["before"] != loops["after"]:
        print("WARNING: the trees ran different control loops; their times are not comparable")
    print(f"rounds: {args.rounds}, script arguments: {' '.join(extra) or '(defaults)'}")
    print(f"load average at the end: {os.getloadavg()[0]:.2f}")
    print(f"{'figure (median over rounds)':42s} {'before':>9s} {'after':>9s}")
    for label, _ in FIGURES:
        cells = []
        for name in ("before", "after"):
            values = [r[label] for r in results[name] if label in r]
            cells.append(f"{statistics.median(values):9.3f}" if values else f"{'-':>9s}")
        print(f"{label:42s} {cells[0]} {cells[1]}")


if __name__ == "__main__":
    main()
