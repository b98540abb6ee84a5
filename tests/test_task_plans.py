"""The table logic of perf.studies.task_plans on hand-made rollouts (no simulation).

The sign test against known values, the pairing of designs, the successes at other goals from a
final pose, the row's figures, the verdict's rule (a variant better, worse, or one that lets the
straight tool succeed), the variants' plans (pi_0 first, the duration kept) and bad input.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import pytest

from perf.studies.task_plans import (
    OWN,
    VARIANTS,
    Rollout,
    paired,
    parse_args,
    sign_test,
    successes_at,
    summary,
    verdict,
)
from tooldesign_env.specs import PlanSpec
from tooldesign_env.tasks import get_task

HOOK = get_task("hook")


def _rollout(x: float, y: float, f: float, *, valid: bool = True, height: float = 0.1,
             tilt: float = 0.0) -> Rollout:
    distance = math.dist((x, y, height), HOOK.goal)
    return Rollout(
        design=(0.0, 0.0, 0.0), valid=valid, free_energy=f, final_distance=distance,
        success=valid and HOOK.succeeded(distance, height, final_tilt=tilt),
        end=(x, y, height), final_height=height, final_tilt=tilt,
    )


@pytest.mark.parametrize(
    ("gained", "lost", "p"),
    [(0, 0, 1.0), (3, 3, 1.0), (5, 0, 0.0625), (0, 6, 0.03125), (7, 1, 0.0703125)],
)
def test_the_sign_test_against_the_binomial(gained, lost, p):
    assert sign_test(gained, lost) == pytest.approx(p)


def test_paired_counts_designs_that_change():
    assert paired([True, True, False, False], [True, False, True, True]) == (2, 1, 1.0)
    with pytest.raises(ValueError, match="same designs, got 2 and 3"):
        paired([True, False], [True, False, True])
    with pytest.raises(ValueError, match="counts >= 0"):
        sign_test(-1, 2)


def test_successes_at_a_goal_need_the_box_standing_and_usable():
    goal = (-0.5, 0.9, 0.1)
    rows = [
        _rollout(-0.5, 0.95, 10.0),  # 0.05 m off, standing
        _rollout(-0.5, 0.95, 10.0, tilt=math.radians(90)),  # lying there
        _rollout(-0.5, 0.95, 10.0, height=0.05),  # fallen
        _rollout(-0.5, 0.95, 10.0, valid=False),  # unusable
        _rollout(-0.3, 0.9, 10.0),  # 0.2 m off
    ]
    assert successes_at(HOOK, rows, goal) == 1
    assert successes_at(HOOK, rows, (-0.3, 0.9, 0.1)) == 1


def test_a_row_of_figures():
    rows = [_rollout(-0.5, 0.9, 100.0), _rollout(-0.3, 0.9, 300.0), _rollout(-0.4, 1.2, 500.0),
            _rollout(0, 0, 1.0, valid=False)]
    row = summary(HOOK, rows, noise=2.0, goals=[(-0.5, 0.9, 0.1), (-0.6, 0.8, 0.1)])
    assert (row["designs"], row["usable"], row["successes"]) == (4, 3, 1)
    assert (row["f_min"], row["f_median"], row["f_max"]) == (100.0, 300.0, 500.0)
    assert row["gap_over_noise"] == pytest.approx(100.0)
    assert row["median_distance"] == pytest.approx(0.2)
    # (-0.6, 0.8): the box at (-0.5, 0.9) is 0.141 m off, so no design reaches it.
    assert (row["instance_mean_successes"], row["instances_unreached"]) == (0.5, 1)
    assert row["best"]["free_energy"] == 100.0
    assert row["best_success"]["free_energy"] == 100.0
    empty = summary(HOOK, [_rollout(0, 0, 1.0, valid=False)], noise=None)
    assert empty["best"] is None and empty["gap_over_noise"] is None
    assert empty["instance_mean_successes"] is None


def _row(successes: int, gained: int, lost: int, p: float, *, instances: float | None = 2.0,
         straight: bool = False) -> dict[str, Any]:
    return {"successes": successes, "gained": gained, "lost": lost, "p": p,
            "instance_mean_successes": instances, "straight": {"success": straight}}


def test_the_verdict_rule():
    own = _row(5, 0, 0, 1.0)
    assert verdict({OWN: own, "a": _row(6, 2, 1, 1.0)}).startswith("pi_0 confirmed")
    assert verdict({OWN: own, "a": _row(15, 10, 0, 0.002)}) == (
        "a better fixed plan: a (p 0.002)"
    )
    # Fewer instances reached, or the straight tool now succeeding: not better.
    assert verdict({OWN: own, "a": _row(15, 10, 0, 0.002, instances=1.0)}).startswith("pi_0")
    assert verdict({OWN: own, "a": _row(15, 10, 0, 0.002, straight=True)}).startswith("pi_0")
    worse = verdict({OWN: own, "a": _row(0, 0, 5, 0.0625), "b": _row(0, 0, 6, 0.03)})
    assert worse == "pi_0 confirmed: no variant has measurably more successes; measurably fewer "\
        "under b"
    # Push's straight tool succeeds under pi_0: a variant keeping it so may be better.
    push_own = _row(2, 0, 0, 1.0, instances=None, straight=True)
    assert verdict({OWN: push_own, "a": _row(12, 10, 0, 0.002, instances=None, straight=True)}
                   ).startswith("a better")


def test_every_task_compares_pi_0_with_variants_of_the_same_length():
    for task, plans in VARIANTS.items():
        labels = list(plans)
        assert labels[0] == OWN and plans[OWN] == get_task(task).plan == PlanSpec()
        assert 3 <= len(labels) <= 4
        for plan in plans.values():
            assert plan.duration == PlanSpec().duration
        assert len(set(plans.values())) == len(plans)
    assert replace(PlanSpec(), pull_to=0.45) in VARIANTS["push"].values()


def test_bad_command_lines(capsys):
    with pytest.raises(SystemExit):
        parse_args(["--designs", "0"])
    assert "--designs must be a count >= 1, got 0" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        parse_args(["--task", "nope"])
    assert "invalid choice: 'nope'" in capsys.readouterr().err


@pytest.mark.slow  # importing the picture study (the renderer's video module) takes about 1 s
def test_the_success_gifs_refuse_bad_input_before_rendering(tmp_path, capsys):
    import json

    from perf.studies.task_pictures import main as pictures

    with pytest.raises(SystemExit):
        pictures(["--out", str(tmp_path / "out")])
    assert "give --baselines FILE, --succeeding FILE or both" in capsys.readouterr().err
    plans = tmp_path / "plans.json"
    plans.write_text(json.dumps([{"task": "hook", "rows": {OWN: {"best_success": None}}}]))
    with pytest.raises(SystemExit, match="--task: nope not in"):
        pictures(["--succeeding", str(plans), "--out", str(tmp_path / "out"), "--task", "nope"])
    assert not (tmp_path / "out").exists()  # refused before anything is written
    # No design succeeded: said so, nothing rendered.
    assert pictures(["--succeeding", str(plans), "--out", str(tmp_path / "out")]) == 0
    assert "hook: no random design succeeds under pi_0" in capsys.readouterr().out
    assert list((tmp_path / "out").iterdir()) == []


def test_the_page_quotes_the_committed_plans_json():
    import json
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    results = json.loads((root / "docs" / "results" / "tasks" / "plans.json").read_text())
    page = (root / "docs" / "tasks.md").read_text()
    section = page.split("### Each task's plan, measured", 1)[1].split("\n## ", 1)[0]
    for result in results:
        task = result["task"]
        lines = [line for line in section.splitlines() if line.startswith(f"| {task}: ")]
        assert len(lines) == len(result["rows"]), task
        for line, (label, row) in zip(lines, result["rows"].items(), strict=True):
            cells = [c.strip() for c in line.strip("|").split("|")]
            assert (label == OWN) == cells[0].endswith("**pi_0**"), line
            assert cells[1] == str(row["successes"]), line
            if label != OWN:
                assert cells[2] == f"{row['gained']} / {row['lost']} ({row['p']:.2g})", line
            if row["instance_mean_successes"] is not None:
                assert cells[3] == (f"{row['instance_mean_successes']:.1f} "
                                    f"({row['instances_unreached']} of {row['instances']})"), line
            assert cells[4] == f"{row['f_min']:.0f} / {row['f_median']:.0f}", line
            assert cells[5] == f"{row['gap_over_noise']:.0f}", line
            straight = row["straight"]
            assert cells[6] == (f"{straight['final_distance']:.3f} m, "
                                f"{'yes' if straight['success'] else 'no'}"), line
        assert result["verdict"].startswith("pi_0 confirmed")  # what the page says


def test_the_page_names_each_succeeding_gif_design():
    import json
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    results = json.loads((root / "docs" / "results" / "tasks" / "plans.json").read_text())
    page = " ".join((root / "docs" / "tasks.md").read_text().split())
    for result in results:
        win = result["rows"][OWN]["best_success"]
        design = ", ".join(f"{c:.3f}" for c in win["design"])
        claim = (f"{result['task']} ({design}), F {win['free_energy']:.0f}, "
                 f"{win['final_distance']:.3f} m from the goal")
        assert claim in page
        assert win["success"]
        assert (root / "docs" / "images" / "tasks" / f"{result['task']}-success.gif").is_file()
