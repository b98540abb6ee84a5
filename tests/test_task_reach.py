"""The reach of the tasks' goal ranges (``task_baselines --reach``) and what docs/tasks.md says.

The committed ``docs/results/tasks/reach.json`` holds the final box pose of the 64 random designs
of the baselines per task; ``reach-output.txt`` is what the study printed from it. No rerun
here: the output is printed again from the poses and compared, and the page's counts are
recomputed from them.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from benchmarks.protocol.instances import load_instances
from tooldesign_env.tasks import get_task

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results" / "tasks"
REACH = RESULTS / "reach.json"
PAGE = ROOT / "docs" / "tasks.md"
TASKS = ("push", "hook", "obstacle", "puck")

# Importing the study loads the suites and the optimizers (about 1 s): the slow tier.
pytestmark = pytest.mark.slow


def _reach() -> dict[str, dict[str, Any]]:
    return {e["task"]: e for e in json.loads(REACH.read_text(encoding="utf-8"))}


def _counts(task: str) -> dict[str, int]:
    from perf.studies.task_baselines import reach_successes

    entry, definition = _reach()[task], get_task(task)
    return {i.id: reach_successes(entry, definition, i.goal) for i in load_instances(task=task)}


def test_the_committed_output_is_what_the_stored_poses_print(capsys):
    from perf.studies.task_baselines import main

    assert list(_reach()) == list(TASKS)
    assert all(e["n"] == 64 and e["seed"] == 0 and len(e["designs"]) == 64
               for e in _reach().values())
    assert main(["--reach-from", str(REACH)]) == 0
    assert capsys.readouterr().out == (RESULTS / "reach-output.txt").read_text(encoding="utf-8")


def test_the_poses_give_the_baselines_random_successes_at_the_default_goal():
    from perf.studies.task_baselines import _random_designs, reach_successes

    baselines = {
        row["task"]: row
        for row in json.loads((RESULTS / "baselines.json").read_text(encoding="utf-8"))
    }
    designs = _random_designs(64, 0)
    for task, entry in _reach().items():
        definition = get_task(task)
        assert np.array_equal([row["design"] for row in entry["designs"]], designs)
        random = baselines[task]["random"]
        assert sum(row["valid"] for row in entry["designs"]) == random["usable"]
        successes = reach_successes(entry, definition, definition.goal)
        assert successes == round(random["success_rate"] * random["n"]), task


def test_every_hook_and_obstacle_instance_is_reached_and_the_page_names_the_puck_s_gaps():
    from perf.studies.task_baselines import REACH_MINIMUM, largest_reached_box, reach_grid

    page = re.sub(r"\s+", " ", PAGE.read_text(encoding="utf-8"))
    hook, obstacle, puck = (_counts(t) for t in ("hook", "obstacle", "puck"))
    assert min(hook.values()) >= REACH_MINIMUM and min(obstacle.values()) >= REACH_MINIMUM
    assert f"{min(hook.values())} to {max(hook.values())} of 64 succeed at each of its 16" in page
    assert f"{min(obstacle.values())} to {max(obstacle.values())} at each instance" in page
    none = [i for i, n in puck.items() if n == 0]
    one = [i for i, n in puck.items() if n == 1]
    assert f"{len(none)} of the 16 ({', '.join(none)}) have none" in page
    assert f"{len(one)} more ({', '.join(one)}) one" in page
    # The obstacle's range meets its rule at every goal of the grid; the hook's corner does not.
    obstacle_task = get_task("obstacle")
    xs, ys, counts = reach_grid(_reach()["obstacle"], obstacle_task, margin=0.0)
    assert counts.min() >= REACH_MINIMUM
    assert f"{counts.min()} to {counts.max()} at every goal of the grid" in page
    hook_task = get_task("hook")
    xs, ys, counts = reach_grid(_reach()["hook"], hook_task, margin=0.0)
    zero = [(float(xs[i]), float(ys[j])) for j, i in zip(*np.nonzero(counts == 0), strict=True)]
    assert zero == [(-0.4, 0.8), (-0.4, 0.85)]
    # No puck range holding the default goal meets the rule; the largest one without it.
    puck_task = get_task("puck")
    xs, ys, counts = reach_grid(_reach()["puck"], puck_task, margin=0.0)
    assert largest_reached_box(xs, ys, counts, puck_task) is None
    box = largest_reached_box(xs, ys, counts, puck_task, with_default_goal=False)
    assert box == ((-0.35, 0.75), (-0.1, 1.0))
    assert "x in [-0.35, -0.1], y in [0.75, 1] m" in page
    assert (int((counts == 0).sum()), int((counts < REACH_MINIMUM).sum())) == (256, 333)
    assert "441 goals of the grid, 256 have none and 333 fewer than 2" in page


def test_the_largest_reached_box():
    from perf.studies.task_baselines import largest_reached_box

    task = get_task("obstacle")  # x in [-0.35, -0.15], y in [0.7, 1], default (-0.25, 0.75)
    xs = np.round(np.arange(-0.35, -0.149, 0.05), 6)
    ys = np.round(np.arange(0.7, 1.001, 0.05), 6)
    counts = np.full((len(ys), len(xs)), 5)
    assert largest_reached_box(xs, ys, counts, task) == ((-0.35, 0.7), (-0.15, 1.0))
    counts[-1, :] = 1  # the row y = 1 falls below 2
    assert largest_reached_box(xs, ys, counts, task) == ((-0.35, 0.7), (-0.15, 0.95))
    counts[1, 2] = 0  # (-0.25, 0.75), the default goal, is reached by none
    assert largest_reached_box(xs, ys, counts, task) is None
    assert largest_reached_box(xs, ys, counts, task, with_default_goal=False) == (
        (-0.35, 0.8),
        (-0.15, 0.95),
    )


def test_reach_refuses_bad_input(tmp_path, capsys):
    from perf.studies.task_baselines import main, parse_args

    for argv, message in (
        (["--reach", "a.json", "--reach-from", "b.json"], "give one of them"),
        (["--reach", "a.json", "--json", "b.json"], "no --json or --noise-floor-only"),
        (["--merge"], "--merge needs --json FILE or --reach FILE"),
        (["--reach", "a.json", "--random", "0"], "--random must be at least 1, got 0"),
    ):
        with pytest.raises(SystemExit):
            parse_args(argv)
        assert message in capsys.readouterr().err
    missing = tmp_path / "none.json"
    assert main(["--reach-from", str(missing)]) == 2
    assert f"--reach-from {missing}:" in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps([{"task": "push"}]))
    assert main(["--reach-from", str(bad)]) == 2
    assert "not a list of --reach task entries" in capsys.readouterr().err
    assert main(["--reach-from", str(REACH), "--task", "hook"]) == 0
    assert capsys.readouterr().out.startswith("## hook: 64 random designs")
    one = tmp_path / "one.json"
    one.write_text(json.dumps([_reach()["push"]]))
    assert main(["--reach-from", str(one), "--task", "puck"]) == 2
    assert "no entry for puck; it holds push" in capsys.readouterr().err
