r"""How far the committed final designs move with the merged hand, and in the retest's nudges.

The committed suites under ``docs/results`` ran with 13 links (the hand merged into the last
arm link became the default later) and were retested in scenes nudged by at most 0.1 mm and
1e-4 rad. The reproduction page says what these two changes do to the outcome; this study
measures it on the committed final designs themselves. Every final design of every suite folder
under ``--results`` (``--section round``: the top-level suites, ``square``: those in
``square/``) is rolled out:

* in its own scene with the arm it ran with (13 links, ``arm = "13 links"``, ``nudge = 0``);
* in the same scene with the hand merged (``arm = "hand merged"``, ``nudge = 0``);
* with 13 links in the retest's nudged scenes 1 to 4 (``benchmarks.suites.retest``, the same
  nudges as ``tooldesign retest``; ``nudge = k``).

One CSV row per rollout: the suite, the design (variant, optimizer, seed), the arm and nudge,
F, goal error, confidence and final distance, the box's final position (x, y, m), ``error``
(why the design is invalid in that scene, as its retest says; its numbers are then empty), and
the F
stored in the design file (``stored_free_energy``): the 13-link rollout in the design's own
scene gives it bit for bit on a platform that reproduces the stored results (the page counts
them). The reproduction page reads the file
(``benchmarks.reports.reproduction.motion_figures``): the largest change of F with the merged
hand, and the median distance the box's final position moves between the nominal scene and
each nudged one.

Run from the repository's root (a few minutes on 2 cores for the round section's 144 designs)::

    python -m perf.studies.committed_motion --results docs/results --section round \
        --out docs/results/committed-motion/round.csv
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from perf import _args

SUITES = ("optimizers", "precision-sweep", "mass-perturbation", "robustness", "robust-design")
FIELDS = (
    "suite",
    "variant",
    "optimizer",
    "seed",
    "arm",
    "nudge",
    "free_energy",
    "goal_error",
    "confidence",
    "final_distance",
    "box_x",
    "box_y",
    "stored_free_energy",
    "error",
)


def _rollouts(item: tuple[Any, Any, tuple[float, ...], int]) -> list[dict[str, Any]]:
    """The 13-link rollouts in the nudged scenes and the merged hand's in the design's scene."""
    from benchmarks.suites.retest import _rollout
    task, config, coeffs, nudges = item
    base = task.task_scene()
    scenes = config.scenes(base)[:nudges]
    runs = [("13 links", k, scene) for k, scene in enumerate(scenes)]
    runs.append(("hand merged", 0, dataclasses.replace(base, merge_fixed_links=True)))
    rows = []
    for arm, k, scene in runs:
        try:
            info = _rollout(task, scene, coeffs)
        except ValueError as exc:  # invalid in this scene (as in its retest): an outcome, kept
            rows.append({"arm": arm, "nudge": k, "error": str(exc)})
            continue
        x = np.asarray(info["box_trajectory"], dtype=np.float64)
        rows.append(
            {
                "arm": arm,
                "nudge": k,
                **{m: float(info[m]) for m in ("free_energy", "goal_error", "confidence")},
                "final_distance": float(info["final_distance"]),
                "box_x": float(x[-1, 0]),
                "box_y": float(x[-1, 1]),
                "error": "",
            }
        )
    return rows


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line; a results folder without a suite of the section is an argparse error."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--results", type=Path, default=Path("docs/results"), help="the committed results"
    )
    parser.add_argument("--section", choices=("round", "square"), default="round")
    parser.add_argument(
        "--nudges",
        type=_args.count(2, 100),
        default=5,
        help="scenes per design, the first its own (the retest's nudges; default 5)",
    )
    parser.add_argument("--workers", type=_args.count(1), default=2)
    parser.add_argument("--out", type=Path, required=True, help="the CSV to write")
    args = parser.parse_args(argv)
    root = args.results / "square" if args.section == "square" else args.results
    if not any((root / suite / "manifest.json").is_file() for suite in SUITES):
        parser.error(
            f"argument --results: {root} holds none of the suites {', '.join(SUITES)} "
            f"(section {args.section})"
        )
    return args


def main(argv: list[str] | None = None) -> int:
    """Roll out every final design of a section's committed suites; write the CSV."""
    args = parse_args(argv)

    import pandas as pd

    from benchmarks.execution import make_executor, map_robust
    from benchmarks.storage import atomic_write_text, read_designs, read_manifest
    from benchmarks.suites.config import suite_of_manifest
    from benchmarks.suites.retest import default_config, retest_task

    root = args.results / "square" if args.section == "square" else args.results
    items, keys = [], []
    for suite_name in SUITES:
        folder = root / suite_name
        if not (folder / "manifest.json").is_file():
            continue
        suite = suite_of_manifest(read_manifest(folder))
        config = default_config(suite)
        read_designs(folder)  # checks the files against the manifest's checksums
        for path in sorted((folder / "designs").rglob("seed=*.json")):
            if path.name.endswith(".paths.json"):
                continue
            record = json.loads(path.read_text(encoding="utf-8"))
            if record.get("status") != "ok" or not record.get("coefficients"):
                continue
            task = retest_task(suite, record)
            items.append((task, config, tuple(record["coefficients"]), args.nudges))
            keys.append(
                {
                    "suite": suite_name,
                    "variant": record["variant"],
                    "optimizer": record["optimizer"],
                    "seed": record["seed"],
                    "stored_free_energy": float(record["free_energy"]),
                }
            )
    print(f"{len(items)} designs, {len(items) * (args.nudges + 1)} rollouts", file=sys.stderr)
    rows = []
    with make_executor("process", workers=args.workers) as pool:
        for key, (result, exc, _) in zip(keys, map_robust(pool, _rollouts, items), strict=True):
            if exc is not None:
                print(f"{key}: {type(exc).__name__}: {exc}", file=sys.stderr)
                continue
            rows += [{**key, **row} for row in result]
    table = pd.DataFrame(rows, columns=list(FIELDS))
    atomic_write_text(args.out, table.to_csv(index=False, float_format="%.17g"))
    print(f"wrote {args.out} ({len(table)} rollouts)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
