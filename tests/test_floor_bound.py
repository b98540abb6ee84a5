"""perf/speed/floor_bound.py: its reading of callgrind's output, its arithmetic, its arguments.

The default tier runs no valgrind: a small callgrind file written here, with hand-computed
counts, stands for one. The slow test counts one design at the defaults if valgrind is present.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from perf.speed import floor_bound, preset_callgrind
from perf.speed.floor_bound import (
    Profile,
    baseline_bound,
    breakdown,
    floor_bounds,
    parse_callgrind,
    per_evaluation,
)

ROOT = Path(__file__).resolve().parents[1]

#: A callgrind output as valgrind 3.19 writes it (names compressed, relative positions, a call
#: of a function to itself), with two events so that Ir is looked up, not assumed first.
SYNTHETIC = """\
# callgrind format
version: 1
creator: callgrind-3.19.0
pid: 1
cmd: python -m perf.speed.preset_callgrind
part: 1

positions: line
events: Dr Ir
summary: 0 1000

ob=(1) /usr/bin/python
fl=(1) ???
fn=(1) main
10 1 100
cob=(2) /lib/_control_loop.so
cfi=(2) control_loop.c
cfn=(2) executePluginCommand_tooldesign
calls=1 0
+2 0 600
cob=(3) /lib/pybullet.so
cfi=(3) pybullet.c
cfn=(3) pybullet_stepSimulation
calls=2 0
* 0 120
ob=(2)
fl=(2)
fn=(2)
0 5 50
cob=(3)
cfi=(3)
cfn=(4) btDiscreteDynamicsWorld::stepSimulation(double, int, double)
calls=10 0
-1 0 400
cfn=(5) PhysicsServerCommandProcessor::processRequestActualStateCommand(SharedMemoryCommand const&)
calls=20 0
0 0 150
ob=(3)
fl=(3)
fn=(3)
0 0 20
cfn=(4)
calls=2 0
0 0 100
fn=(4)
0 0 500
cfn=(4)
calls=1 0
0 0 7
cfn=(6) g::btDiscreteDynamicsWorld::stepSimulation
calls=1 0
0 0 3
fn=(5)
0 0 150
totals: 0 1000
"""


def test_parse_reads_totals_inclusive_counts_and_calls() -> None:
    profile = parse_callgrind(SYNTHETIC)
    assert profile.total == 1000
    assert profile.inclusive["main"] == 100 + 600 + 120
    assert profile.inclusive["executePluginCommand_tooldesign"] == 50 + 400 + 150
    assert profile.inclusive["pybullet_stepSimulation"] == 20 + 100
    step = "btDiscreteDynamicsWorld::stepSimulation(double, int, double)"
    # its own 500 and g::...'s 3; the call to itself is inside its own 500 already
    assert profile.inclusive[step] == 503
    assert profile.calls[step] == 10 + 2 + 1
    assert profile.calls["executePluginCommand_tooldesign"] == 1


def test_a_name_matches_with_or_without_arguments_only_itself() -> None:
    profile = parse_callgrind(SYNTHETIC)
    assert profile.count(("btDiscreteDynamicsWorld::stepSimulation",)) == 503  # not g::'s 3
    assert profile.count(("stepSimulation",)) == 0
    assert profile.count(("main", "pybullet_stepSimulation")) == 820 + 120


def test_without_totals_the_total_is_the_sum_of_own_costs() -> None:
    text = "\n".join(
        line for line in SYNTHETIC.splitlines() if not line.startswith(("totals", "summary"))
    )
    assert parse_callgrind(text).total == 100 + 50 + 20 + 500 + 150


def test_a_file_that_is_not_callgrinds_is_refused() -> None:
    with pytest.raises(ValueError, match="not a callgrind output"):
        parse_callgrind("fn=main\n10 20\n")
    with pytest.raises(ValueError, match="not a callgrind output"):
        parse_callgrind("hello\n")


def _profile(total: int, **parts: int) -> Profile:
    inclusive = {floor_bound.PARTS[part.replace("_", " ")][0]: n for part, n in parts.items()}
    return Profile(total=total, inclusive=inclusive, calls={})


def test_per_evaluation_is_the_count_over_n_and_a_clone_counts_as_its_function() -> None:
    profile = _profile(1800, stepping=1200, c_loop=1400)
    profile.inclusive["arm_state.isra.0"] = 300
    counts = per_evaluation(profile, 2)
    assert counts["total"] == 900
    assert counts["stepping"] == 600
    assert counts["c loop"] == 700
    assert counts["arm state"] == 150
    assert counts["solver"] == 0
    with pytest.raises(ValueError, match="n must be"):
        per_evaluation(profile, 0)


def _evaluation() -> dict[str, float]:
    return {
        "total": 1000.0,
        "stepping": 600.0,
        "solver": 200.0,
        "solver iterations": 120.0,
        "collision": 100.0,
        "python stepping": 20.0,
        "c loop": 800.0,
        "arm state": 40.0,
        "inverse dynamics": 12.0,
        "contact query": 30.0,
        "contact copy": 8.0,
        "jacobians": 10.0,
        "mass matrices": 6.0,
    }


def _floor() -> dict[str, float]:
    return {
        **{key: 0.0 for key in _evaluation()},
        "total": 700.0,
        "stepping": 600.0,
        "contact copy": 3.0,  # the world's build asks for closest points in both
    }


def test_breakdown_splits_the_c_loop_and_takes_the_floors_reads_off() -> None:
    rows = breakdown(_evaluation(), _floor())
    assert rows["stepping in the C loop"] == 580
    assert rows["c loop beside stepping"] == 800 - 580
    assert rows["outside the C loop"] == 200
    assert rows["arm state"] == 40
    assert rows["contact copy"] == 5
    assert rows["controller reads"] == 40 + 12
    assert rows["contact log"] == 30 + 5 + 10 + 6
    assert rows["rest of the C loop"] == 220 - 52 - 51
    assert rows["needed"] == 40 + 12 + 30 + 5 + 10 + 6
    assert rows["reads only"] == 40 + 30 + 5
    without = breakdown(_evaluation(), None)
    assert "floor" not in without and "arm state" not in without
    assert without["c loop beside stepping"] == 220


def test_the_bounds_are_the_hand_computed_ratios() -> None:
    rows = breakdown(_evaluation(), _floor())
    bounds = floor_bounds(rows)
    assert bounds["over the floor"] == pytest.approx((700 + 103) / 700)
    assert bounds["over the floor, reads only"] == pytest.approx((700 + 75) / 700)
    assert bounds["over the stepping"] == pytest.approx((600 + 103) / 600)
    assert baseline_bound(rows, 1000.0) == pytest.approx((600 - 100) / 1000)
    assert floor_bound.seconds_bound(rows, rows, 0.75) == pytest.approx(500 / 700 * 0.75)
    with pytest.raises(ValueError, match="must be > 0"):
        baseline_bound(rows, 0.0)


def test_the_report_prints_both_bounds_and_says_when_the_baseline_is_a_proxy() -> None:
    rows = breakdown(_evaluation(), _floor())
    cheap = breakdown({**_evaluation(), "stepping": 400.0, "collision": 50.0}, None)
    text = "\n".join(
        floor_bound.report({"defaults": rows, "most aggressive": cheap}, None, "most aggressive")
    )
    assert f"{(400 - 50) / 1000:.3f}" in text and "a proxy" in text
    assert f"{(700 + 103) / 700:.3f} over the floor" in text
    base = breakdown({**_evaluation(), "total": 2000.0}, None)
    text = "\n".join(
        floor_bound.report({"defaults": rows, "baseline": base}, "baseline", "defaults")
    )
    assert f"{(600 - 100) / 2000:.3f}" in text and "proxy" not in text
    alone = floor_bound.report({"lower-floor": rows}, None, "lower-floor", (0.07, 0.05))
    assert any("(a) not counted" in line for line in alone)
    assert any("(a) in time not estimated" in line for line in alone)


def test_the_variants_follow_the_settings_asked() -> None:
    chosen = floor_bound.variants(None, ["most aggressive", "defaults"])
    assert [v.label for v in chosen] == ["defaults", "most aggressive"]
    assert all(v.floor for v in chosen)
    assert "--scene=solver_iterations=10" in chosen[1].argv
    with_baseline = floor_bound.variants(ROOT, ["lower-floor"])
    assert [v.label for v in with_baseline] == ["lower-floor", "baseline"]
    assert with_baseline[1].argv == ()  # its defaults: what preset_callgrind counts in 062b3a0
    assert not with_baseline[1].floor


def test_good_arguments_parse() -> None:
    args = floor_bound.parse_args(
        [str(ROOT), "--designs", "2", "--settings", "defaults", "--valgrind", sys.executable]
    )
    assert args.baseline == ROOT and args.designs == 2 and args.settings == ["defaults"]
    assert floor_bound.parse_args(["--valgrind", sys.executable]).baseline is None


@pytest.mark.parametrize(
    "argv",
    [
        ["--designs", "0"],
        ["--designs", "13"],
        ["--settings", "fast"],
        ["/nonexistent-tree"],
        ["--valgrind", "no-such-valgrind-command"],
        ["--seconds", "0.07", "0.08"],  # a floor dearer than the evaluation
        ["--seconds", "0", "0.05"],
        ["--read", "/nonexistent-folder"],
    ],
)
def test_bad_arguments_exit_with_a_message(
    argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    if "--valgrind" not in argv:
        argv = [*argv, "--valgrind", sys.executable]
    with pytest.raises(SystemExit) as exited:
        floor_bound.parse_args(argv)
    assert exited.value.code == 2
    assert "error:" in capsys.readouterr().err


def test_keep_must_be_a_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    a_file = tmp_path / "f"
    a_file.write_text("")
    with pytest.raises(SystemExit):
        floor_bound.parse_args(["--keep", str(a_file), "--valgrind", sys.executable])
    assert "--keep must be a folder" in capsys.readouterr().err


def _callgrind(total: int, **functions: int) -> str:
    """A callgrind file in which each function (a key of PARTS) costs the given instructions."""
    lines = ["version: 1", "positions: line", "events: Ir", f"summary: {total}"]
    for i, (part, cost) in enumerate(functions.items(), 1):
        lines += [f"fn=({i}) {floor_bound.PARTS[part.replace('_', ' ')][0]}", f"1 {cost}"]
    return "\n".join([*lines, f"totals: {total}", ""])


def _fake_valgrind(tmp_path: Path, *, invalid: int = 0, extra_part: bool = False) -> str:
    """A stand-in for valgrind: writes the phases' files and prints preset_callgrind's line."""
    evaluations = _callgrind(
        2000,  # 2 designs
        stepping=1300,
        solver=900,
        collision=200,
        python_stepping=100,
        c_loop=1500,
        arm_state=80,
        inverse_dynamics=20,
        contact_query=4,
        contact_copy=60,
        jacobians=30,
        mass_matrices=16,
    )
    floors = _callgrind(1400, stepping=1300, python_stepping=100, c_loop=1100)
    phases = [_callgrind(10**9), evaluations, floors] + ([_callgrind(1)] if extra_part else [])
    (tmp_path / "phases.json").write_text(json.dumps(phases))
    fake = tmp_path / "valgrind"
    fake.write_text(
        f"#!{sys.executable}\n"
        "import json, sys\n"
        "args = sys.argv[1:]\n"
        "out = next(a.split('=', 1)[1] for a in args if a.startswith('--callgrind-out-file='))\n"
        "assert '--dump-before=getppid' in args and '--tool=callgrind' in args\n"
        "n = int(args[args.index('--designs') + 1])\n"
        "floor = '--floor' in args\n"
        f"phases = json.load(open({str(tmp_path / 'phases.json')!r}))\n"
        "if not floor: phases = phases[:2] + phases[3:]\n"
        "for i, text in enumerate(phases, 1):\n"
        "    open(f'{out}.{i}', 'w').write(text)\n"
        "open(out, 'w').write(phases[0])\n"
        f"print(f'{{n}} evaluations at x after one warm-up evaluation; valid {{n - {invalid}}}; '\n"
        "      f'floors {n if floor else 0}')\n"
    )
    fake.chmod(0o755)
    return str(fake)


def test_main_counts_each_variant_once_and_prints_its_bounds(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    fake = _fake_valgrind(tmp_path)
    keep = tmp_path / "kept"
    argv = ["--designs", "2", "--settings", "defaults", "--valgrind", fake, "--keep", str(keep)]
    floor_bound.main([str(ROOT), *argv])
    text = capsys.readouterr().out
    # per evaluation: total 1000, stepping 650, collision 100; the baseline (this tree, run
    # without --floor) the same 1000: (650 - 100) / 1000
    assert f": {0.55:.3f}; with the requests" in text and "proxy" not in text, text
    assert f": {0.655:.3f}   (target <= 0.5)" in text, text  # (650 - 100 + 105) / 1000
    # needed: 40 + 10 + 2 + 30 + 15 + 8 = 105 over a floor of 1400 / 2 = 700
    assert f"{(700 + 105) / 700:.3f} over the floor" in text, text
    assert f"{(700 + 72) / 700:.3f} with only" in text, text
    assert f"{(650 + 105) / 650:.3f} over the stepping" in text, text
    assert {p.name for p in keep.iterdir()} >= {"defaults.out.2", "defaults.out.3"}

    def printed(text: str) -> list[str]:
        return [
            line
            for line in text.splitlines()
            if line and not line.startswith(("counting", "(a) in time"))
        ]

    # the same figures again from the kept files, without counting; (a) also in time
    floor_bound.main([str(ROOT), *argv[:4], "--read", str(keep), "--seconds", "0.07", "0.05"])
    again = capsys.readouterr().out
    assert "counting" not in again
    assert printed(again) == printed(text)
    share = 0.05 / 0.07
    assert f": {550 / 700 * share:.3f}; with the requests: {655 / 700 * share:.3f}" in again


def test_main_refuses_invalid_designs_and_stray_phase_marks(tmp_path: Path) -> None:
    argv = ["--designs", "2", "--settings", "defaults", "--valgrind"]
    with pytest.raises(SystemExit, match="1 of the 2 designs are invalid"):
        floor_bound.main([*argv, _fake_valgrind(tmp_path, invalid=1)])
    with pytest.raises(SystemExit, match="something else in the run called getppid"):
        floor_bound.main([*argv, _fake_valgrind(tmp_path, extra_part=True)])


def test_preset_callgrind_takes_scene_fields_on_top_of_the_preset_and_a_floor() -> None:
    args = preset_callgrind.parse_args(
        ["--preset", "lower-floor", "--scene", "solver_iterations=10", "--floor", "--designs", "0"]
    )
    assert args.floor and args.designs == 0 and dict(args.scene) == {"solver_iterations": 10}
    assert preset_callgrind.parse_args([]).scene_spec is None


@pytest.mark.parametrize(
    "argv",
    [
        ["--preset", "no-such-preset"],
        ["--scene", "solver_iterations=0"],  # SceneSpec refuses it
        ["--scene", "no_such_field=1"],
        ["--designs", "-1"],
    ],
)
def test_preset_callgrind_refuses_bad_arguments(
    argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exited:
        preset_callgrind.parse_args(argv)
    assert exited.value.code == 2
    assert "error:" in capsys.readouterr().err


@pytest.mark.slow
def test_one_design_at_the_defaults_under_callgrind(tmp_path: Path) -> None:
    if shutil.which("valgrind") is None:
        pytest.skip("valgrind is not installed")
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "perf.speed.floor_bound",
            "--designs",
            "1",
            "--settings",
            "defaults",
            "--keep",
            str(tmp_path),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=1800,
        check=False,
    )
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    # the exit, then the phases: start-up and warm-up, the evaluation, its floor
    assert {p.name for p in tmp_path.iterdir()} == {
        "defaults.out",
        "defaults.out.1",
        "defaults.out.2",
        "defaults.out.3",
    }
    bounds = [line for line in out.stdout.splitlines() if line.startswith(("(a)", "(b)"))]
    assert len(bounds) == 2 and "a proxy" in bounds[0], out.stdout
    ratio = float(bounds[1].split(">=")[1].split()[0])
    assert 1.0 < ratio < 2.0, bounds[1]
