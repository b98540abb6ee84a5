"""The equivalence rule (issue 31): its tests, its reference, its command and its judgements.

The slow tests run the check against the committed reference: they pass on any x86-64 CPU
because they compare within noise floors, not bits; one shows the rule rejecting a real change
of the physics, one accepting a change of nudge size.
"""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from benchmarks.cli import main
from benchmarks.execution import SerialExecutor
from benchmarks.reports.verdicts import compare_verdicts, read_report_tables, verdicts
from benchmarks.suites import equivalence as eq


def _reference(n: int = 64, floor: float = 10.0, f: float = 10_000.0) -> dict:
    """A reference of ``n`` designs with F = ``f`` and the same floor (relative: 0.1 %)."""
    designs = [
        {
            "label": f"d3-{i:02d}",
            "kind": "random",
            "task": "push",
            "degree": 3,
            "coefficients": [0.1 * i, 0.0, 0.0],
            "valid": True,
            "free_energy": f,
            "goal_error": f + 1000.0,
            "confidence": 1000.0,
            "final_distance": 0.3,
            "floor": floor,
            "relative_floor": floor / f,
        }
        for i in range(n)
    ]
    return {
        "format_version": eq.REFERENCE_VERSION,
        "tasks": {"push": eq.TASKS["push"].to_json()},
        "median_relative_floor": floor / f,
        "designs": designs,
    }


def _rows(values, valid=True):
    return [{"free_energy": float(v), "valid": valid} for v in values]


# --- tests 1 and 2 of the rule, on hand-made numbers -------------------------------------------


def test_identical_results_are_accepted():
    reference = _reference()
    result = eq.compare(reference, _rows([10_000.0] * 64))
    assert result.accepted
    assert result.within_fraction == 1.0
    assert result.mean_relative == result.low == result.high == 0.0
    assert result.bound == pytest.approx(0.5 * 10.0 / 10_000.0)
    assert "ACCEPTED" in eq.format_comparison(result)


def test_a_few_designs_outside_their_floor_pass_more_fail():
    reference = _reference()
    # Small changes of either sign (a mean near 0) inside the floor, then k of them beyond it.
    base = [10_000.0 + (3.0 if i % 2 else -3.0) for i in range(64)]
    six = base.copy()
    for i in range(6):  # 58 of 64 within: 90.6 %
        six[i] = 10_000.0 + (11.0 if i % 2 else -11.0)
    seven = six.copy()
    seven[6] = 10_011.0  # 57 of 64: 89.1 %
    assert eq.compare(reference, _rows(six)).accepted
    rejected = eq.compare(reference, _rows(seven))
    assert not rejected.accepted
    assert "57 of 64 designs" in rejected.reasons[0]
    table = eq.format_comparison(rejected)
    assert "REJECTED" in table and table.count(" NO") == 7


def test_a_shift_of_the_mean_inside_every_floor_is_rejected_by_the_interval():
    # Every design moves by 9 (inside its floor of 10) in the same direction: the mean
    # relative change, 0.09 %, is beyond half the median floor, 0.05 %.
    result = eq.compare(_reference(), _rows([10_009.0 + 0.1 * (i % 3) for i in range(64)]))
    assert result.within_fraction == 1.0
    assert not result.accepted
    assert "interval" in result.reasons[0]


def test_the_bound_comes_from_the_designs_floors_not_from_the_files_summary():
    # A reference whose summary was edited to a wide floor still bounds a shift of 2 % by the
    # floors its designs record (0.1 %): the shift is rejected.
    reference = _reference()
    reference["median_relative_floor"] = 1.0
    result = eq.compare(reference, _rows([10_200.0] * 64))
    assert result.bound == pytest.approx(0.5 * 10.0 / 10_000.0)
    assert not result.accepted


def test_unbounded_floors_count_as_within_and_a_design_turned_invalid_as_outside():
    reference = _reference()
    for d in reference["designs"][:10]:
        d["floor"] = d["relative_floor"] = None  # invalid in a nudge: the worst case
    now = _rows([10_000.0] * 64)
    for row in now[:10]:
        row.update(free_energy=1e5, valid=False)
    result = eq.compare(reference, now)
    assert result.within_fraction == 1.0 and result.accepted
    now[20].update(free_energy=1e5, valid=False)
    result = eq.compare(reference, now)
    assert not result.rows[20]["within"]
    assert result.rows[20]["relative"] is None  # left out of the mean, counted in test 1


def test_the_median_floor_counts_an_unbounded_floor_above_every_other():
    assert eq._median_floor([0.1, None, 0.3]) == 0.3
    assert eq._median_floor([0.1, None, None]) is None
    assert eq._median_floor([0.1, 0.2, 0.3, 0.4]) == pytest.approx(0.25)


def test_calibration_holds_each_nudge_out_against_the_range_of_the_others():
    reference = _reference()
    for d in reference["designs"]:
        d["scene_free_energy"] = [0.0, 1.0, 2.0, 3.0]  # 3 is outside the range 0-2 of the others
    reference["designs"][0]["floor"] = None  # unbounded: within, every time
    figures = eq.calibration(reference)
    assert figures["held_out_within"] == pytest.approx((63 * 2 + 3) / (64 * 3))
    # 58 of 64 designs must be within; each is with p = 0.672: a rule this would fail.
    assert figures["pass_probability"] < 0.01
    for d in reference["designs"]:
        d["scene_free_energy"] = [1.5, 0.0, 1.0, 2.0, 3.0, 1.4, 1.6, 0.5, 2.5]  # nominal central
    figures = eq.calibration(reference)
    assert figures["held_out_within"] == 1.0 and figures["pass_probability"] == 1.0
    # Test 2 on each nudge as a change of every design at once: all designs move alike, by
    # 0 %, -100 %, -33 %, +33 %, ..., so only a nudge equal to the nominal F passes (none here).
    assert figures["nudges_passing_test2"] == 0.0
    for d in reference["designs"]:
        d["scene_free_energy"] = [10_000.0, 10_001.0, 9_999.0]
    assert eq.calibration(reference)["nudges_passing_test2"] == 1.0  # 0.01 %, bound 0.05 %


def test_the_committed_reference_says_how_often_test_2_passes_a_nudge(reference):
    # Measured, not assumed: a nudge moves every design at once, and its mean relative change
    # (to 0.18 %) is of the size of the bound (0.30 %), so test 2 rejects some nudges (3 of 15
    # in the reference of 737061f). docs/performance.md quotes this figure.
    figures = eq.calibration(reference)
    assert 0.5 <= figures["nudges_passing_test2"] < 1.0


def test_compare_refuses_results_of_another_length():
    with pytest.raises(ValueError, match="one row per reference design \\(64\\), got 3"):
        eq.compare(_reference(), _rows([1.0, 2.0, 3.0]))


def test_format_comparison_refuses_an_unknown_rows_choice():
    result = eq.compare(_reference(), _rows([10_000.0] * 64))
    with pytest.raises(ValueError, match="rows must be 'all', 'outside' or 'none', got 'some'"):
        eq.format_comparison(result, rows="some")
    assert eq.format_comparison(result, rows="all").count("d3-") == 64


# --- the design set and the reference file ------------------------------------------------------


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("seed", -1, "seed must be an int >= 0"),
        ("scenes", 1, "nudges must be in \\[2, 100\\]"),
        ("random_designs", ((0, 5),), "random_designs must be"),
        ("random_designs", ((3, -1),), "random_designs must be"),
        ("random_designs", (3, 20), "random_designs must be"),
        ("tasks", ("pull",), "tasks must be one or more of \\['push'\\]"),
        ("tasks", (), "tasks must be one or more of"),
        ("shift", 0.5, "shift must be in \\[0, 0.01\\]"),
    ],
)
def test_design_set_spec_refuses_bad_input(field, value, match):
    with pytest.raises(ValueError, match=match):
        eq.DesignSetSpec(**{field: value})


def test_record_refuses_a_set_smaller_than_the_rule_asks():
    spec = eq.DesignSetSpec(random_designs=((3, 10),))
    with pytest.raises(ValueError, match="at least 64 designs, the spec gives 15"):
        eq.record(spec, executor=SerialExecutor())


def test_evaluate_refuses_changes_of_the_task_and_nudges_without_a_config():
    design = [{"task": "push", "degree": 3, "coefficients": (0.0, 0.0, 0.0)}]
    with pytest.raises(ValueError, match="changes must not set \\['goal'\\]"):
        eq.evaluate(design, changes={"goal": (0, 1, 0.1)}, executor=SerialExecutor())
    with pytest.raises(TypeError, match="changes must be a mapping"):
        eq.evaluate(design, changes=[("scene", None)], executor=SerialExecutor())  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="need a config"):
        eq.evaluate(design, scenes=(0, 1), executor=SerialExecutor())


def test_the_draw_is_fixed_by_its_seed_and_inside_the_default_bounds():
    from tooldesign_env.env import default_bounds

    first, again = eq._draw(eq.DesignSetSpec()), eq._draw(eq.DesignSetSpec())
    other = eq._draw(eq.DesignSetSpec(seed=32))
    assert set(first) == {3, 5, 8}
    for degree, draws in first.items():
        assert np.array_equal(draws, again[degree])
        assert not np.array_equal(draws, other[degree])
        bounds = default_bounds(degree)
        assert np.all((draws >= bounds[:, 0]) & (draws <= bounds[:, 1]))


def test_the_committed_reference_is_the_rules_design_set():
    reference = eq.read_reference()
    designs = reference["designs"]
    assert len(designs) >= eq.DESIGNS_MIN
    assert {d["degree"] for d in designs} == {3, 5, 8}
    labels = {d["label"]: d for d in designs}
    assert labels["straight"]["coefficients"] == [0.0, 0.0, 0.0]
    assert {n for n, _ in eq.NAMED_DESIGNS} <= set(labels)
    assert "062b3a0" in reference["note"]
    assert reference["spec"] == eq.DesignSetSpec().to_json()
    # The random designs are the spec's draws, in order, those invalid at nominal skipped.
    drawn = eq._draw(eq.DesignSetSpec())
    for degree, draws in drawn.items():
        kept = [
            d["coefficients"] for d in designs if d["kind"] == "random" and d["degree"] == degree
        ]
        rows = [list(r) for r in draws.tolist()]
        assert all(k in rows for k in kept)
        assert [rows.index(k) for k in kept] == sorted(rows.index(k) for k in kept)
    # Floors are measured, and the median is what the designs give.
    floors = [d["relative_floor"] for d in designs]
    assert sum(f is not None and f > 0 for f in floors) >= 0.9 * len(designs)
    assert reference["median_relative_floor"] == eq._median_floor(floors)
    assert 0 < reference["median_relative_floor"] < 0.05


def test_write_then_read_gives_the_reference_back(tmp_path):
    reference = _reference()
    path = eq.write_reference(reference, tmp_path / "ref.json")
    assert eq.read_reference(path) == json.loads(json.dumps(reference))
    assert not list(tmp_path.glob("*.tmp*"))  # written atomically, nothing left beside it


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda r: r.update(format_version=0), "'format_version' must be 1"),
        (lambda r: r["designs"].pop(), "at least 64 designs"),
        (lambda r: r.update(tasks={"pull": {}}), "task 'pull' must be one this code knows"),
        (lambda r: r["tasks"]["push"].update(goal_precision=10.0), "task 'push' must be one"),
        (lambda r: r["designs"][3].update(task="pull"), "design 3: field 'task'"),
        (lambda r: r["designs"][4].update(coefficients=[0.0, 1.0]), "design 4: 'coefficients'"),
        (lambda r: r["designs"][5].update(free_energy="x"), "design 5: field 'free_energy'"),
        (lambda r: r["designs"][6].update(floor=-1.0), "design 6: field 'floor'"),
        (lambda r: r["designs"][7].update(valid=False), "design 7: field 'valid'"),
        # The summary the bound could be read from: edited, or not a number.
        (lambda r: r.update(median_relative_floor=1.0), "'median_relative_floor' must be the"),
        (lambda r: r.update(median_relative_floor="0.1"), "'median_relative_floor' must be a"),
    ],
)
def test_a_damaged_reference_is_refused_naming_the_field(tmp_path, edit, match):
    reference = copy.deepcopy(_reference())
    edit(reference)
    path = tmp_path / "ref.json"
    path.write_text(json.dumps(reference))
    with pytest.raises(ValueError, match=match):
        eq.read_reference(path)
    with pytest.raises(ValueError, match=match):
        eq.write_reference(reference, tmp_path / "other.json")
    assert not (tmp_path / "other.json").exists()


def test_a_missing_or_non_json_reference_is_refused(tmp_path):
    with pytest.raises(FileNotFoundError, match="no equivalence reference at"):
        eq.read_reference(tmp_path / "none.json")
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(ValueError, match="not an equivalence reference: not JSON"):
        eq.read_reference(tmp_path / "bad.json")
    (tmp_path / "list.json").write_text("[]")
    with pytest.raises(ValueError, match="must hold a JSON object"):
        eq.read_reference(tmp_path / "list.json")


# --- test 3: verdicts and rankings of the smoke suites -----------------------------------------


_TABLES = {
    "report/summary.csv": [
        {"variant": "", "optimizer": "cmaes", "final_free_energy": "100.0", "auc": "5"},
        {"variant": "", "optimizer": "random", "final_free_energy": "90.0", "auc": "7"},
        {"variant": "", "optimizer": "pso", "final_free_energy": "", "auc": "6"},
    ],
    "report/pairwise.csv": [
        {
            "variant": "",
            "metric": "auc",
            "a": "cmaes",
            "b": "random",
            "significant": "False",
            "beyond_noise": "",
        },
    ],
    "report/table1.csv": [
        {"variant": "p0", "robustness_best": "True"},
        {"variant": "p20", "robustness_best": "False"},
    ],
    "report/tool-shapes.csv": [{"variant": "p0", "seed": "7"}],
    "report/mass-perturbation.csv": [
        {"variant": "p0", "seed": "7", "shown": "False"},
        {"variant": "p0", "seed": "9", "shown": "True"},
    ],
}


def test_verdicts_read_rankings_marks_and_choices():
    found = verdicts(_TABLES)
    assert found["ranking"]["- final_free_energy"] == "random < cmaes < pso"  # no value last
    assert found["ranking"]["- auc"] == "cmaes < pso < random"
    assert found["pairwise"]["- auc: cmaes vs random"] == "significant=False beyond_noise="
    assert found["best"]["table1.csv p0 robustness_best"] == "True"
    assert found["shown"] == {"tool-shapes.csv p0": "7", "mass-perturbation.csv p0": "9"}


def test_compare_verdicts_sees_a_swapped_ranking_and_a_new_verdict_not_a_moved_number():
    moved = copy.deepcopy(_TABLES)
    moved["report/summary.csv"][0]["final_free_energy"] = "95.0"  # cmaes moves, rank stays
    assert compare_verdicts(verdicts(_TABLES), verdicts(moved)) == []
    moved["report/summary.csv"][0]["final_free_energy"] = "80.0"
    moved["report/pairwise.csv"][0]["significant"] = "True"
    lines = compare_verdicts(verdicts(_TABLES), verdicts(moved))
    assert len(lines) == 2
    assert any("cmaes < random < pso" in line for line in lines)
    assert any("significant=True" in line for line in lines)


def test_the_smoke_fixtures_verdicts_are_not_empty():
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from smoke_results import SUITES, read_variants

    for fixture in read_variants().values():
        counted = {s: sum(map(len, verdicts(fixture[s]).values())) for s in SUITES}
        assert all(counted.values()), counted
        assert verdicts(fixture["optimizers"])["ranking"]


def test_read_report_tables_refuses_a_folder_without_a_report(tmp_path):
    with pytest.raises(FileNotFoundError, match="has no report tables"):
        read_report_tables(tmp_path)


# --- the command ------------------------------------------------------------------------------


def test_the_commands_defaults_are_the_modules():
    from benchmarks.cli import equivalence as cli

    assert cli.DEFAULT_REFERENCE == eq.REFERENCE.resolve()
    assert cli.DEFAULT_SCENES == eq.DesignSetSpec().scenes


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["check", "--workers", "0"], "--workers must be from 1 to"),
        (["check", "--reference", "{tmp}/none.json"], "no equivalence reference at"),
        (["check", "--reference", "{tmp}/bad.json"], "not JSON"),
        (["check", "--rows", "some"], "invalid choice: 'some'"),
        (["record", "--out", "{tmp}", "--workers", "1"], "is a folder"),
        (["record", "--out", "{tmp}/no/ref.json"], "does not exist"),
        (["record", "--out", "{tmp}/ref.json", "--scenes", "1"], "--scenes must be from 2 to 100"),
        (["record"], "the following arguments are required: --out"),
        (["verdicts", "{tmp}/none", "{tmp}"], "does not exist or is not a folder"),
        (["verdicts", "{tmp}", "{tmp}"], "neither a suite run folder"),
        ([], "the following arguments are required: ACTION"),
    ],
)
def test_the_command_refuses_bad_input_in_one_line(tmp_path, capsys, argv, message):
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(SystemExit) as exit_info:
        main(["equivalence", *[a.format(tmp=tmp_path) for a in argv]])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err


def test_verdicts_command_names_what_changed(tmp_path, capsys):
    import csv

    for name, tables in (("before", _TABLES), ("after", copy.deepcopy(_TABLES))):
        if name == "after":
            tables["report/summary.csv"][1]["final_free_energy"] = "120.0"
        for key, rows in tables.items():
            path = tmp_path / name / "optimizers" / key
            path.parent.mkdir(parents=True, exist_ok=True)
            with path.open("w", newline="") as f:
                writer = csv.DictWriter(f, fieldnames=list(rows[0]))
                writer.writeheader()
                writer.writerows(rows)
    assert (
        main(["equivalence", "verdicts", str(tmp_path / "before"), str(tmp_path / "before")]) == 0
    )
    assert "unchanged" in capsys.readouterr().out
    code = main(["equivalence", "verdicts", str(tmp_path / "before"), str(tmp_path / "after")])
    out = capsys.readouterr().out
    assert code == 1 and "CHANGED" in out and "cmaes < random < pso" in out


# --- the rule on the real simulation -------------------------------------------------------------


@pytest.fixture(scope="module")
def reference():
    return eq.read_reference()


@pytest.mark.slow
def test_record_draws_the_committed_designs_and_measures_them_within_their_floors(
    reference, monkeypatch
):
    # A small set (the rule's minimum lowered for the test): the 5 named designs and the first
    # 2 cubics, in 3 scenes. Same seed, same designs as the committed reference; their F in
    # each scene is within the committed floor of the nominal F (bits depend on the CPU).
    monkeypatch.setattr(eq, "DESIGNS_MIN", 7)
    spec = eq.DesignSetSpec(random_designs=((3, 2),), scenes=3)
    small = eq.record(spec, executor=SerialExecutor(), note="test")
    committed = {d["label"]: d for d in reference["designs"]}
    assert [d["label"] for d in small["designs"]] == [n for n, _ in eq.NAMED_DESIGNS] + [
        "d3-00",
        "d3-01",
    ]
    for design in small["designs"]:
        old = committed[design["label"]]
        assert design["coefficients"] == old["coefficients"]
        assert len(design["scene_free_energy"]) == 3
        assert design["floor"] == pytest.approx(float(np.ptp(design["scene_free_energy"])))
        for value in design["scene_free_energy"]:
            assert abs(value - old["free_energy"]) <= old["floor"], design["label"]
    assert small["note"] == "test" and small["spec"] == spec.to_json()


@pytest.mark.slow
def test_the_code_as_it_is_passes_the_check_against_the_committed_reference(reference):
    from platforms import assert_equivalent, platform_id

    result = eq.check(reference, workers=2)
    assert_equivalent(result, reference)
    if platform_id() == reference["platform"]:
        assert result.mean_relative == 0.0  # the same code on the recording CPU: the same F


@pytest.mark.slow
def test_a_box_five_percent_more_slippery_is_rejected(reference):
    from tooldesign_env import SceneSpec

    scene = SceneSpec(box_friction=1.05 * SceneSpec().box_friction)
    result = eq.check(reference, changes={"scene": scene}, workers=2)
    assert not result.accepted, eq.format_comparison(result)
    # Measured at 062b3a0: 55 of 72 within, mean -0.51 % [-0.81, -0.22] %: both tests fail.
    assert len(result.reasons) == 2, eq.format_comparison(result)


@pytest.mark.slow
def test_a_change_of_nudge_size_is_accepted(reference):
    # A start of the box 0.05 mm and 0.07 mm off and turned by 5e-5 rad, none of the recorded
    # nudges: what a change that leaves the motion alone (other rounding, another CPU) gives.
    from tooldesign_env import SceneSpec

    x, y = SceneSpec().box_position
    scene = SceneSpec(box_position=(x + 5e-5, y - 7e-5), box_yaw=5e-5)
    result = eq.check(reference, changes={"scene": scene}, workers=2)
    assert result.accepted, eq.format_comparison(result)
    assert sum(r["dF"] != 0.0 for r in result.rows) > len(result.rows) / 2  # a real change


@pytest.mark.parametrize(
    ("shift", "code", "verdict"), [(0.0, 0, "ACCEPTED"), (50.0, 1, "REJECTED")]
)
def test_check_command_prints_the_verdict_and_exits_with_it(
    tmp_path, capsys, monkeypatch, shift, code, verdict
):
    # The simulation is stood in for (the slow tests run it): the command's own part is read,
    # compare, print and exit code.
    reference = _reference()
    path = eq.write_reference(reference, tmp_path / "ref.json")

    def check(ref, **kwargs):
        return eq.compare(ref, _rows([10_000.0 + shift] * 64))

    monkeypatch.setattr(eq, "check", check)
    assert main(["equivalence", "check", "--reference", str(path), "--rows", "all"]) == code
    out = capsys.readouterr().out
    assert f"verdict:                  {verdict}" in out
    assert out.count("d3-") == 64
    assert "not calibrated" in out  # the hand-made reference keeps no F per scene
