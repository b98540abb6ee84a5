"""Per task: the noise floor of F on designs that move the box, relative to |F| and to F's span.

Issue 35 asks, for each task of docs/tasks.md, the noise floor of F under 0.1 mm / 1e-4 rad
nudges of the box's start (median <= 1 %). ``task_baselines``' floor set (the straight tool and
the first 8 usable random designs) holds, in hook, 7 designs that never touch the box: their F
is the untouched box settling, the same in every nudged scene, and the median is that trivial
case (review 43, item 4). This study measures the floor where it matters, on designs that MOVE
the box, for every built-in task (``--task``, default all four):

1. **Candidates**: the old floor set (the same draw as ``task_baselines``: seed 0, 64 random
   designs, the first 8 usable), the named designs of ``task_baselines.NAMED``, the task's
   committed CMA-ES design (docs/results/tasks/baselines.json), the random designs that
   succeed at the default goal (their final poses in reach.json, judged by the task's own test)
   and pi_0's lowest-F and lowest-F succeeding random designs (plans.json). Duplicates are
   merged, keeping every source.
2. **Moves the box**: each candidate is rolled out once in the task's own scene; it moves the
   box if the box's final centre is more than ``--moved`` (0.01 m) from its start in the
   horizontal plane. An untouched box settles by micrometres; the largest displacement below
   the threshold and the smallest above it are printed, so the split can be seen to be clear.
3. **Floor**: each box-moving candidate in the ``--nudges`` (5) scenes of ``tooldesign
   retest``'s nudges (``RetestConfig(nudges=...).scenes``, the first the task's own; the
   scenes of ``task_baselines``' floor), through ``benchmarks.execution.evaluate_batch``. Per
   design the range R = max - min of F over the scenes, and R relative to |mean F| (the
   issue's measure, ill-posed where F crosses 0, as hook's does) and to the task's F span S.
4. **Span**: S = (the ``--span-quantile`` quantile of F over the 64 random designs, default
   the median) - (the best F known: the lowest of task_baselines' 191 evaluations, CMA-ES's
   best F minus its regret). S is the scale on which an optimizer's progress is read (the
   protocol's normalized regret runs from F_random to F_ref over the same span), so R / S is
   the share of that scale the noise covers. Only the stored quartiles (0.25, 0.5, 0.75) are
   offered: baselines.json keeps no other quantile.
5. **Gap**: the page's "best vs typical random design" gap, median random F - CMA-ES's best F,
   over the median R of the box-moving designs and over the CMA-ES design's own R.

The old set's summary is recomputed from noise-floor.json (its committed per-design F), with
how many of its designs moved the box; its box-moving designs are measured again here, and
with the default nudges their F must equal noise-floor.json's to the bit (checked and printed).

Run: ``python -m perf.studies.task_floor [--task hook ...] [--moved 0.05] [--nudges 5]
[--span-quantile 0.5] [--workers 1] [--json FILE]``. Output: docs/results/tasks/floor-moving.json
and floor-moving-output.txt (docs/tasks.md). 81 to 121 rollouts a task with the defaults, 377 for
the four (one per candidate, ``--nudges`` - 1 more per box-moving one); not timed here.
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tooldesign_env.tasks import BUILTIN_TASKS, get_task

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "docs" / "results" / "tasks"

#: A design moves the box if its final centre is farther than this from its start (m,
#: horizontal): an untouched box settles by micrometres, and hook's bow (0, 0.6, 0), which
#: grazes the box, moves it 4.9 cm (a 5 cm threshold would call it untouched).
MOVED = 0.01

#: The quantile of the random designs' F that is the "typical" end of the span (the median).
SPAN_QUANTILE = 0.5

#: The quantiles baselines.json stores (min, quartiles, max), in order.
STORED_QUANTILES = (0.0, 0.25, 0.5, 0.75, 1.0)

#: The floor set of task_baselines: its first usable random designs (beside the straight tool).
FLOOR_DESIGNS = 8

#: The issue's bound on the median relative range.
BOUND = 0.01


def _load(name: str) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = json.loads((RESULTS / name).read_text(encoding="utf-8"))
    return rows


def committed_inputs() -> dict[str, dict[str, Any]]:
    """Per task, the committed rows this study reads: baselines, noise floor, reach, plans."""
    out: dict[str, dict[str, Any]] = {}
    for key, name in (
        ("baselines", "baselines.json"),
        ("floor", "noise-floor.json"),
        ("reach", "reach.json"),
        ("plans", "plans.json"),
    ):
        for row in _load(name):
            out.setdefault(row["task"], {})[key] = row
    return out


def span(baselines: dict[str, Any], quantile: float = SPAN_QUANTILE) -> dict[str, float]:
    """The task's F span: the ``quantile`` of the random designs' F minus the best F known.

    Args:
        baselines: The task's row of baselines.json.
        quantile: One of :data:`STORED_QUANTILES` but 0 and 1 (0.25, 0.5 or 0.75).

    Returns:
        ``typical`` (that quantile of F), ``best_known`` (CMA-ES's best F minus its regret: the
        lowest F of all the task's baseline evaluations) and ``span`` (their difference).

    Raises:
        ValueError: ``quantile`` is not 0.25, 0.5 or 0.75, or the span is not positive.
    """
    if quantile not in STORED_QUANTILES[1:-1]:
        raise ValueError(
            f"span quantile must be 0.25, 0.5 or 0.75 (the quartiles baselines.json stores), "
            f"got {quantile!r}"
        )
    typical = float(baselines["random"]["free_energy_quantiles"][STORED_QUANTILES.index(quantile)])
    cmaes = baselines["cmaes"]
    best = float(cmaes["best"]["free_energy"]) - float(cmaes["regret"])
    if not typical - best > 0:
        raise ValueError(
            f"{baselines['task']}: the span {typical} - {best} is not positive: the best F known "
            "is not below the typical random design's"
        )
    return {"typical": typical, "best_known": best, "span": typical - best}


def _key(design: Sequence[float]) -> tuple[float, ...]:
    return tuple(float(c) for c in design)


def candidates(inputs: dict[str, Any], *, floor_designs: int = FLOOR_DESIGNS
               ) -> list[dict[str, Any]]:
    """The designs whose floor may be measured, each with every source it comes from.

    Args:
        inputs: One task's entry of :func:`committed_inputs`.
        floor_designs: task_baselines' ``--floor-designs`` (the old set's random designs).

    Returns:
        ``{"design": [c1, c2, c3], "sources": [...], "old_set": bool}`` in first-seen order:
        the old floor set, the named designs, CMA-ES's design, the succeeding random designs,
        pi_0's lowest-F and lowest-F succeeding random designs.
    """
    # Imported here: task_baselines imports the optimizers, which the pure helpers do not need.
    from perf.studies.task_baselines import NAMED, _floor_set

    name = inputs["baselines"]["task"]
    task = get_task(name)
    reach = inputs["reach"]
    out: dict[tuple[float, ...], dict[str, Any]] = {}

    def add(design: Sequence[float], source: str, old: bool = False) -> None:
        row = out.setdefault(_key(design), {"design": list(_key(design)), "sources": [],
                                            "old_set": False})
        row["sources"].append(source)
        row["old_set"] = row["old_set"] or old

    usable = [{"design": r["design"]} for r in reach["designs"] if r["valid"]]
    for design in _floor_set(usable, floor_designs):
        add(design, "old floor set", old=True)
    for label, design in NAMED.items():
        add(design, label)
    add(inputs["baselines"]["cmaes"]["best"]["design"], "CMA-ES's design")
    goal = np.asarray(task.goal, dtype=float)
    for i, r in enumerate(reach["designs"]):
        if not r["valid"]:
            continue
        end = np.asarray(r["final_position"], dtype=float)
        if task.succeeded(float(np.linalg.norm(end - goal)), float(end[2]),
                          final_tilt=r["final_tilt"]):
            add(r["design"], f"random #{i} (succeeds)")
    own = inputs["plans"]["rows"]["pi_0"]
    add(own["best"]["design"], "lowest-F random design")
    if own.get("best_success"):
        add(own["best_success"]["design"], "lowest-F succeeding random design")
    return list(out.values())


def _check_reach_draw(inputs: dict[str, Any], random: int = 64, seed: int = 0) -> None:
    """reach.json's designs are task_baselines' draw (the old set comes from them)."""
    from perf.studies.task_baselines import _random_designs

    drawn = _random_designs(random, seed).tolist()
    stored = [r["design"] for r in inputs["reach"]["designs"]]
    if stored != drawn:
        raise RuntimeError(f"{inputs['baselines']['task']}: reach.json's designs are not "
                           f"task_baselines' draw (seed {seed}, {random} designs)")


def settings(name: str, scene: Any) -> Any:
    """The TaskSettings of task ``name`` at its default goal, p^X = 20, in ``scene``."""
    from benchmarks.execution import TaskSettings

    task = get_task(name)
    return TaskSettings(goal=task.goal, box_mass=scene.box_mass,
                        env_kwargs={"task": name, "scene": scene})


def summary(rows: list[dict[str, Any]], span_value: float) -> dict[str, Any]:
    """Medians and largest values of the per-design floors ``rows``.

    Each row has ``range`` and ``free_energy`` (F per scene); the floors are given in F units,
    relative to |mean F| and relative to ``span_value``.

    Raises:
        ValueError: ``rows`` is empty or ``span_value`` is not positive.
    """
    if not rows:
        raise ValueError("no design to summarize: the floor needs at least one")
    if not (math.isfinite(span_value) and span_value > 0):
        raise ValueError(f"span must be a finite number > 0, got {span_value!r}")
    ranges = np.array([r["range"] for r in rows])
    relative = np.array([r["range"] / abs(float(np.mean(r["free_energy"]))) for r in rows])
    return {
        "designs": len(rows),
        "median_range": float(np.median(ranges)),
        "max_range": float(np.max(ranges)),
        "median_relative_range": float(np.median(relative)),
        "max_relative_range": float(np.max(relative)),
        "above_bound": int(np.sum(relative > BOUND)),
        "median_span_relative": float(np.median(ranges) / span_value),
        "max_span_relative": float(np.max(ranges) / span_value),
    }


def measure(name: str, inputs: dict[str, Any], executor: Any, *, moved: float = MOVED,
            nudges: int = 5, quantile: float = SPAN_QUANTILE,
            limit: int | None = None) -> dict[str, Any]:
    """Every figure of one task (see the module docstring).

    Args:
        name: A built-in task.
        inputs: Its entry of :func:`committed_inputs`.
        executor: From ``benchmarks.execution.make_executor``.
        moved: The box-moving threshold, m.
        nudges: Scenes per design (the first the task's own), 2 to 100.
        quantile: The span's quantile of the random designs' F.
        limit: Measure only the first ``limit`` candidates (tests).
    """
    if not (math.isfinite(moved) and moved > 0):
        raise ValueError(f"moved must be a distance > 0 in m, got {moved!r}")
    from benchmarks.execution import evaluate_batch
    from benchmarks.storage import platform_id
    from benchmarks.suites.retest import RetestConfig

    task = get_task(name)
    _check_reach_draw(inputs)
    the_span = span(inputs["baselines"], quantile)
    pool = candidates(inputs)[:limit]
    scenes = RetestConfig(nudges=nudges).scenes(task.scene)
    designs = np.array([c["design"] for c in pool])
    nominal = evaluate_batch(executor, designs, settings(name, scenes[0]), keep_trajectory=True)
    start = task.box_start()[:2]
    for cand, row in zip(pool, nominal, strict=True):
        cand["status"] = row["status"]
        cand["free_energy"] = [float(row["free_energy"])]
        path = np.asarray(row.get("box_trajectory", np.zeros((0, 3))), dtype=float)
        cand["displacement"] = (
            float(np.linalg.norm(path[-1][:2] - start)) if row["status"] == "ok" and len(path)
            else None
        )
        cand["final_distance"] = float(row["final_distance"])
        cand["succeeds"] = row["status"] == "ok" and task.succeeded(
            float(row["final_distance"]), float(row["final_height"]),
            final_tilt=float(row["final_tilt"]),
        )
        cand["moves_box"] = cand["displacement"] is not None and cand["displacement"] > moved
    movers = [c for c in pool if c["moves_box"]]
    for scene in scenes[1:]:
        rows = evaluate_batch(executor, np.array([c["design"] for c in movers]),
                              settings(name, scene))
        for cand, row in zip(movers, rows, strict=True):
            if row["status"] != "ok":
                cand["invalid_in_scene"] = row["message"] or row["status"]
            cand["free_energy"].append(float(row["free_energy"]))
    still = [c["displacement"] for c in pool if c["displacement"] is not None
             and not c["moves_box"]]
    measured = [c for c in movers if "invalid_in_scene" not in c]
    for c in measured:
        c["range"] = max(c["free_energy"]) - min(c["free_energy"])
        c["relative_range"] = c["range"] / abs(float(np.mean(c["free_energy"])))
        c["span_relative"] = c["range"] / the_span["span"]
    # The old set, as committed (noise-floor.json), and how many of its designs move the box.
    old_rows = inputs["floor"]["noise_floor"]["per_design"]
    by_key = {_key(c["design"]): c for c in pool}
    old_moved = [by_key[_key(r["design"])]["moves_box"] for r in old_rows
                 if _key(r["design"]) in by_key]
    same = None
    if nudges == inputs["floor"]["noise_floor"]["scenes"]:
        again = [(by_key[_key(r["design"])], r) for r in old_rows
                 if _key(r["design"]) in by_key and "range" in by_key[_key(r["design"])]]
        same = all(c["free_energy"] == r["free_energy"] for c, r in again) if again else None
    result: dict[str, Any] = {
        "task": name,
        "platform": platform_id(),
        "moved_threshold": moved,
        "nudges": nudges,
        "span_quantile": quantile,
        "span": the_span,
        "old_set": {
            **summary(old_rows, the_span["span"]),
            "moved_box": int(sum(old_moved)),
            "remeasured_identical": same,
        },
        "candidates": pool,
        "moving": {
            **summary(measured, the_span["span"]),
            "succeeding": sum(c["succeeds"] for c in measured),
        } if measured else None,
        "largest_displacement_unmoved": max(still) if still else None,
        "smallest_displacement_moved": min(c["displacement"] for c in movers) if movers else None,
        "invalid_in_a_scene": sum("invalid_in_scene" in c for c in movers),
        "rollouts": len(pool) + len(movers) * (len(scenes) - 1),
    }
    cma_key = _key(inputs["baselines"]["cmaes"]["best"]["design"])
    cma = by_key.get(cma_key)
    gap = float(inputs["baselines"]["random"]["free_energy_quantiles"][2]) - float(
        inputs["baselines"]["cmaes"]["best"]["free_energy"]
    )
    result["gap"] = {
        "gap": gap,
        "over_moving_median_range": gap / result["moving"]["median_range"]
        if result["moving"] else None,
        "cmaes_range": cma.get("range") if cma else None,
        "over_cmaes_range": gap / cma["range"] if cma and cma.get("range") else None,
    }
    return result


def _pct(value: float) -> str:
    return f"{100 * value:.2f} %"


def report(result: dict[str, Any]) -> list[str]:
    """The printed lines of one task's result."""
    s, old, mov, gap = result["span"], result["old_set"], result["moving"], result["gap"]
    lines = [
        f"## {result['task']}",
        f"platform: {result['platform']}",
        f"span: F quantile {result['span_quantile']:g} of the random designs {s['typical']:.1f} "
        f"- best F known {s['best_known']:.1f} = {s['span']:.1f}",
        f"old set ({old['designs']} designs: straight + first {old['designs'] - 1} usable random;"
        f" {old['moved_box']} move the box > {result['moved_threshold']:g} m): median "
        f"{_pct(old['median_relative_range'])} of |F| (max {_pct(old['max_relative_range'])}), "
        f"{_pct(old['median_span_relative'])} of the span, median range {old['median_range']:.1f}"
        f"; re-measured box-moving designs identical to noise-floor.json: "
        f"{ {True: 'yes', False: 'NO', None: 'not checked'}[old['remeasured_identical']] }",
    ]
    pool = result["candidates"]
    n_moving = sum(c["moves_box"] for c in pool)
    if mov is None:
        lines.append(f"box-moving designs: none of {len(pool)} candidates")
    else:
        lines.append(
            f"box-moving designs ({mov['designs']} of {len(pool)} candidates move the box > "
            f"{result['moved_threshold']:g} m, {mov['succeeding']} of them succeed; "
            f"{sum(c['status'] != 'ok' for c in pool)} unusable; "
            f"{n_moving - mov['designs']} invalid in a nudged scene) x {result['nudges']} "
            f"scenes: median range {mov['median_range']:.1f} "
            f"(max {mov['max_range']:.1f}); of |F| median {_pct(mov['median_relative_range'])} "
            f"(max {_pct(mov['max_relative_range'])}, {mov['above_bound']} above 1 %); of the "
            f"span median {_pct(mov['median_span_relative'])} (max "
            f"{_pct(mov['max_span_relative'])})"
        )
    low, high = result["largest_displacement_unmoved"], result["smallest_displacement_moved"]
    lines.append(
        "box displacement: "
        + ("no unmoved design" if low is None else f"largest of the unmoved {low:.2g} m")
        + ("; no moving design" if high is None else f"; smallest of the moving {high:.3f} m")
    )
    over = gap["over_moving_median_range"]
    own = gap["over_cmaes_range"]
    lines.append(
        f"gap median random F - CMA-ES's F {gap['gap']:.1f}: "
        + (f"{over:.0f} x the box-moving median range" if over else "no box-moving floor")
        + (f", {own:.0f} x the CMA-ES design's own range {gap['cmaes_range']:.1f}"
           if own else "")
    )
    for c in pool:
        design = ", ".join(f"{v:.3f}" for v in c["design"])
        moved = "n/a" if c["displacement"] is None else f"{c['displacement']:.3f} m"
        text = (f"  ({design}) [{'; '.join(c['sources'])}]: moved {moved}, final distance "
                f"{c['final_distance']:.3f} m{', succeeds' if c['succeeds'] else ''}, F "
                f"{c['free_energy'][0]:.1f}")
        if "range" in c:
            text += (f", range {c['range']:.1f} ({_pct(c['relative_range'])} of |F|, "
                     f"{_pct(c['span_relative'])} of the span)")
        elif "invalid_in_scene" in c:
            text += f", invalid in a nudged scene: {c['invalid_in_scene']}"
        lines.append(text)
    lines.append(f"{result['rollouts']} rollouts")
    return lines


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line of :func:`main`."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--task", action="append", choices=BUILTIN_TASKS, default=None)
    parser.add_argument("--moved", type=float, default=MOVED,
                        help="a design moves the box if its final centre is farther than this "
                        "from its start, m (default %(default)s)")
    parser.add_argument("--nudges", type=int, default=5,
                        help="scenes per design, the first the task's own (default 5)")
    parser.add_argument("--span-quantile", type=float, default=SPAN_QUANTILE,
                        help="the quantile of the random designs' F that ends the span: 0.25, "
                        "0.5 or 0.75 (default %(default)s)")
    parser.add_argument("--workers", type=int, default=1,
                        help="worker processes (default 1: the serial executor)")
    parser.add_argument("--json", default=None, help="also write the results to this JSON file")
    args = parser.parse_args(argv)
    if not (math.isfinite(args.moved) and args.moved > 0):
        parser.error(f"--moved must be a distance > 0 in m, got {args.moved}")
    if not 2 <= args.nudges <= 100:
        parser.error(f"--nudges must be from 2 to 100, got {args.nudges}")
    if args.span_quantile not in STORED_QUANTILES[1:-1]:
        parser.error(f"--span-quantile must be 0.25, 0.5 or 0.75, got {args.span_quantile}")
    if args.workers < 1:
        parser.error(f"--workers must be at least 1, got {args.workers}")
    return args


def main(argv: list[str] | None = None) -> int:
    """Measure and print each task's box-moving floor; write ``--json`` atomically."""
    from benchmarks.execution import make_executor

    args = parse_args(argv)
    inputs = committed_inputs()
    results = []
    kind = "serial" if args.workers == 1 else "process"
    with make_executor(kind, workers=None if kind == "serial" else args.workers) as executor:
        for name in args.task or BUILTIN_TASKS:
            results.append(measure(name, inputs[name], executor, moved=args.moved,
                                   nudges=args.nudges, quantile=args.span_quantile))
            print("\n".join(report(results[-1])), flush=True)
    if args.json:
        from benchmarks.storage.atomic import atomic_write_text

        atomic_write_text(args.json, json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
