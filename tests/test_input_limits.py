"""Size limits of every numeric input: refused where given, with the value and what is allowed.

Each refused case below used to be accepted and then gave NaN, inf, a hang, a MemoryError or a
traceback deep inside the simulation or an optimizer (docs/reliability.md, section 1).
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

import optimizers
from benchmarks.cli import main
from tooldesign_env import ToolDesignEnv
from tooldesign_env.geometry import ToolSpec
from tooldesign_env.specs import (
    PLAN_DURATION_MAX,
    PLAN_DURATION_MIN,
    ControllerSpec,
    ObjectiveSpec,
    PlanSpec,
    SceneSpec,
)

ROOT = Path(__file__).resolve().parents[1]

SPECS = {
    "SceneSpec": SceneSpec,
    "PlanSpec": PlanSpec,
    "ControllerSpec": ControllerSpec,
    "ObjectiveSpec": ObjectiveSpec,
    "ToolSpec": ToolSpec,
}


@pytest.mark.parametrize(
    ("spec", "field", "value"),
    [
        ("SceneSpec", "time_step", 1e-9),  # MemoryError (53 GiB)
        ("SceneSpec", "time_step", 1e308),  # "not JSON compliant"
        ("SceneSpec", "solver_iterations", 10**12),  # OverflowError in PyBullet
        ("SceneSpec", "box_size", (1e308, 0.1, 0.2)),
        ("SceneSpec", "box_size", (1e-300, 1e-300, 1e-300)),
        ("SceneSpec", "box_position", (1e308, 0.0)),  # F = inf
        ("SceneSpec", "box_position", (0.0, -100.0)),
        ("SceneSpec", "box_yaw", 1e20),
        ("SceneSpec", "box_friction", 1e308),
        ("SceneSpec", "floor_friction", 11.0),
        ("SceneSpec", "tool_friction", 1e308),
        ("SceneSpec", "box_settle_time", 1e9),  # hang
        ("SceneSpec", "rest_speed", 1e308),
        ("SceneSpec", "rest_time", 1e308),  # "cannot convert float infinity to integer"
        ("PlanSpec", "reach", 1e308),  # hang
        ("PlanSpec", "pull_to", 3.0),
        ("PlanSpec", "height", 2.0),
        ("PlanSpec", "lift", 1e308),
        ("PlanSpec", "hold_duration", 1e9),  # MemoryError (373 GiB)
        ("PlanSpec", "sweep_duration", 61.0),
        ("PlanSpec", "yaw_end", 90.0),  # degrees given for radians
        ("ControllerSpec", "kp", 1e308),  # non-finite torques
        ("ControllerSpec", "kd", 1e308),
        ("ControllerSpec", "torque_limits", (1e308,) * 7),
        ("ControllerSpec", "control_period", 10**9),  # IndexError
        ("ObjectiveSpec", "eps", 1e-320),  # reward +inf, F -inf
        ("ObjectiveSpec", "eps", 1e308),
        ("ObjectiveSpec", "ridge", 1e308),
        ("ObjectiveSpec", "window", 10**9),
        ("ObjectiveSpec", "horizon", 10**9),
        ("ObjectiveSpec", "response_time", 1e308),  # OverflowError
        ("ObjectiveSpec", "slip_speed", 1e308),
        ("ObjectiveSpec", "perturbation", 1e308),
        ("ObjectiveSpec", "invalid_penalty", 1e308),
        ("ObjectiveSpec", "expected_masses", (1e308,)),
        ("ObjectiveSpec", "expected_masses", (0.5,) * 65),
        ("ToolSpec", "arc_length", 1e308),
        ("ToolSpec", "handle_length", 1e308),  # non-finite torques
        ("ToolSpec", "section", 1e308),
        ("ToolSpec", "section", 1e-300),  # non-finite torques
        ("ToolSpec", "density", 1e308),  # non-finite torques
        ("ToolSpec", "density", 1e-300),
        ("ToolSpec", "n_segments", 10**7),  # MemoryError
        ("ToolSpec", "degree", 10**6),  # hang
    ],
)
def test_absurd_magnitudes_are_refused_naming_the_field(spec, field, value):
    with pytest.raises(ValueError, match=rf"{spec}\.{field} must be") as info:
        SPECS[spec](**{field: value})
    assert len(str(info.value).splitlines()) == 1


def test_a_plan_too_short_or_too_long_in_all_is_refused():
    short = dict.fromkeys(("lower_duration", "sweep_duration", "pull_duration"), 0.1)
    with pytest.raises(ValueError, match=r"PlanSpec: the plan must last 1 to 60 s"):
        PlanSpec(**short, settle_duration=0.0, hold_duration=0.0)
    with pytest.raises(ValueError, match=r"PlanSpec: the plan must last 1 to 60 s"):
        PlanSpec(hold_duration=55.0)


@pytest.mark.parametrize(
    ("spec", "kwargs"),
    [
        (SceneSpec, {"time_step": 2.5e-4, "solver_iterations": 1000}),
        (SceneSpec, {"time_step": 0.02, "solver_iterations": 1}),
        (SceneSpec, {"time_step": 1 / 960}),  # perf/studies/confidence_convergence.py
        (SceneSpec, {"time_step": 1 / 120}),  # docs/performance.md
        (SceneSpec, {"box_size": (1e-3, 2.0, 1e-3), "box_position": (-2.5, 2.5)}),
        (SceneSpec, {"box_yaw": -2 * math.pi, "box_friction": 10.0, "floor_friction": 0.0}),
        (SceneSpec, {"box_settle_time": 10.0, "rest_speed": 1.0, "rest_time": 60.0}),
        (SceneSpec, {"box_position": [-0.3, 1.1]}),  # docs/results/cage
        (PlanSpec, {"reach": 2.5, "pull_to": 2.5, "height": 1.0, "lift": 1.0}),
        (PlanSpec, {"hold_duration": PLAN_DURATION_MAX - PlanSpec().duration + 6.0}),
        (PlanSpec, {"yaw_start": 2 * math.pi, "yaw_end": -2 * math.pi}),
        (ControllerSpec, {"kp": 1e6, "kd": 1e4, "torque_limits": (1e4,) * 7}),
        (ControllerSpec, {"control_period": 50}),
        (ObjectiveSpec, {"eps": 1e-12, "ridge": 1e3, "window": 10_000, "horizon": 10_000}),
        (ObjectiveSpec, {"eps": 1.0, "response_time": 1.0, "slip_speed": 1.0}),
        (ObjectiveSpec, {"perturbation": 100.0, "invalid_penalty": 1e15}),
        (ObjectiveSpec, {"expected_masses": (1000.0,) * 64}),
        (ToolSpec, {"arc_length": 0.01, "handle_length": 0.01, "section": 0.001}),
        (ToolSpec, {"arc_length": 5.0, "handle_length": 2.0, "section": 0.5}),
        (ToolSpec, {"density": 1.0, "n_segments": 500, "degree": 20}),
        (ToolSpec, {"density": 30000.0, "n_segments": 1, "degree": 1}),
    ],
)
def test_the_limits_themselves_are_accepted(spec, kwargs):
    spec(**kwargs)


@pytest.mark.slow
def test_the_coarsest_control_of_the_shortest_plan_simulates_finite():
    # The limits are chosen so that every plan has a control step: a 1 s plan at a 1 s control
    # step (time_step 0.02 s, 50 physics steps per control step).
    durations = {"lower_duration": 0.1, "sweep_duration": 0.8, "pull_duration": 0.1}
    plan = PlanSpec(**durations, settle_duration=0.0, hold_duration=0.0)
    assert plan.duration == PLAN_DURATION_MIN
    env = ToolDesignEnv(
        scene=SceneSpec(time_step=0.02, arm_floor_contacts=True),
        controller=ControllerSpec(control_period=50),
        plan=plan,
    )
    env.reset(seed=0)
    _, reward, _, _, info = env.step(np.zeros(3))
    assert math.isfinite(reward) and math.isfinite(info["free_energy"])
    env.close()


@pytest.mark.slow
def test_every_suite_and_run_folder_of_the_repo_still_loads():
    from benchmarks.rl.suite import SIZES as RL_SIZES
    from benchmarks.rl.suite import rl_suite_config
    from benchmarks.suites import BUILTIN_SUITES, builtin_suite, load_suite, suite_of_manifest
    from benchmarks.suites.builtin import SIZES
    from benchmarks.suites.retest import default_config

    suites = [builtin_suite(name, size) for name in BUILTIN_SUITES for size in SIZES]
    suites += [load_suite(path) for path in sorted((ROOT / "docs").rglob("suite*.toml"))]
    for path in sorted((ROOT / "docs" / "results").rglob("manifest.json")):
        manifest = json.loads(path.read_text(encoding="utf-8"))
        if manifest.get("kind") == "suite":
            suites.append(suite_of_manifest(manifest))
    assert len(suites) > len(BUILTIN_SUITES) * len(SIZES)
    for suite in suites:
        default_config(suite)
        for run in suite.runs():
            run.design.task()
    for size in RL_SIZES:
        rl_suite_config(size)


# --- optimizers -----------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize(
    ("settings", "match"),
    [
        ({"n_initial_points": 10**9}, "n_initial_points must be an int from 1 to 10000"),
        ({"n_initial_points": 2**63}, "n_initial_points must be an int from 1 to 10000"),
        ({"n_points": 10**9}, "n_points must be an int from 1 to 100000"),
        ({"gp_restarts": 10**6}, "gp_restarts must be an int from 0 to 100"),
    ],
)
def test_bo_refuses_settings_that_exhaust_memory_or_time(settings, match):
    pytest.importorskip("skopt")
    with pytest.raises(ValueError, match=match):
        optimizers.make("bo", bounds=[[-1.0, 1.0]] * 3, batch_size=4, seed=0, **settings)


def test_bo_accepts_its_largest_cheap_settings():
    pytest.importorskip("skopt")
    optimizers.make(
        "bo", bounds=[[-1.0, 1.0]] * 3, batch_size=4, seed=0, n_points=100_000, gp_restarts=100
    )


@pytest.mark.parametrize("sigma0", [1e-320, 1e-300, 1e-7])
def test_cmaes_refuses_a_step_lost_in_rounding(sigma0):
    with pytest.raises(ValueError, match=r"sigma0 must be in \[1e-06, 1\]"):
        optimizers.make("cmaes", bounds=[[-1.0, 1.0]] * 3, batch_size=4, seed=0, sigma0=sigma0)


@pytest.mark.slow
def test_cmaes_runs_with_its_smallest_step():
    optimizer = optimizers.make(
        "cmaes", bounds=[[-1.0, 1.0]] * 3, batch_size=4, seed=0, sigma0=1e-6
    )
    for _ in range(5):
        batch = optimizer.ask()
        optimizer.tell(batch.ids, [float(np.sum(x**2)) for x in batch.x])


# --- the rl suite and probes ----------------------------------------------------------------


def test_rl_counts_and_seeds_have_upper_limits():
    from benchmarks.rl.agents import run_random
    from benchmarks.rl.suite import rl_suite_config
    from benchmarks.rl.tuning import probe

    with pytest.raises(ValueError, match="seeds must be an int >= 1 and <= 10000"):
        rl_suite_config("smoke", seeds=10**9)
    with pytest.raises(ValueError, match="seeds must be an int >= 1 and <= 10000"):
        rl_suite_config("smoke", seeds=10**20)
    with pytest.raises(ValueError, match="workers must be an int >= 1 and <= 1024"):
        rl_suite_config("smoke", workers=100_000)
    with pytest.raises(ValueError, match="total_episodes must be an int from 1 to 100000"):
        run_random(total_episodes=10**20, seed=0)
    with pytest.raises(TypeError, match=r"seed must be an int from 0 to 2\^63 - 1"):
        run_random(total_episodes=1, seed=10**20)
    with pytest.raises(TypeError, match="overrides must be a table"):
        probe("ppo", episodes=1, seed=0, overrides=[1])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="random sampling has no config fields"):
        probe("random", episodes=1, seed=0, overrides={"n_steps": 16})


def _one_line_exit_2(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    return err


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["bench", "rl", "--size", "smoke", "--seeds", "1000000000"], "seeds must be an int"),
        (["bench", "rl", "--size", "smoke", "--seeds", "1" + "0" * 20], "seeds must be an int"),
        (["bench", "rl", "--size", "smoke", "--workers", "100000"], "<= 1024"),
        (["rl", "probe", "random", "--episodes", "1" + "0" * 20], "from 1 to 100000"),
        (["rl", "probe", "random", "--episodes", "1", "--seed", "1" + "0" * 20], r"2\^63"),
        (["rl", "probe", "ppo", "--episodes", "1", "--set", "[1]"], "overrides must be a"),
    ],
)
def test_rl_commands_refuse_huge_counts_in_one_line(argv, match, tmp_path, capsys):
    if argv[0] == "bench":
        argv = [*argv, "--out", str(tmp_path / "rl")]
    assert re.search(match, _one_line_exit_2(argv, capsys))
    assert not (tmp_path / "rl").exists()


# --- retest and dense-search ----------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--workers", "100000"], "--workers must be from 1 to 1024, got 100000"),
        (["--workers", "0"], "--workers must be from 1 to 1024, got 0"),
        (["--repeats", "100000000"], "--repeats must be from 1 to --nudges (5), got 100000000"),
        (["--nudges", "3", "--repeats", "4"], "--repeats must be from 1 to --nudges (3), got 4"),
        (["--nudges", "-1"], "--nudges must be from 2 to 100, got -1"),
        (["--nudges", "101"], "--nudges must be from 2 to 100, got 101"),
        (["--masses", ""], "expected one or more comma-separated numbers"),
        (["--masses", "0.2,,0.3"], "expected one or more comma-separated numbers"),
        (["--frictions", "0.2,"], "expected one or more comma-separated numbers"),
    ],
)
def test_retest_refuses_flags_out_of_range(flags, message, tmp_path, capsys):
    err = _one_line_exit_2(["retest", str(tmp_path), *flags], capsys)
    assert message in err
    assert not any(tmp_path.iterdir())


@pytest.mark.slow
def test_retest_without_repeats_takes_the_default_or_the_nudges():
    import argparse

    from benchmarks.cli.retest import _check_counts

    def namespace(**kwargs: object) -> argparse.Namespace:
        return argparse.Namespace(**{"repeats": None, "workers": None, **kwargs})

    assert _check_counts(namespace(nudges=5)) == 3
    assert _check_counts(namespace(nudges=2)) == 2
    assert _check_counts(namespace(nudges=9, repeats=9, workers=1024)) == 9


@pytest.mark.slow
@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--points", "2", "--workers", "100000"], "workers must be an int from 1 to 1024"),
        (["--points", "1000000"], "points must be an integer from 2 to 50"),
        (["--points", "51"], "points must be an integer from 2 to 50"),
        (["--points", "2", "--batch", "100000"], "batch must be an int from 1 to 10000"),
    ],
)
def test_dense_search_refuses_sizes_out_of_range(flags, message, tmp_path, capsys):
    out = tmp_path / "out"
    err = _one_line_exit_2(["dense-search", *flags, "--out", str(out)], capsys)
    assert message in err
    assert not out.exists()


@pytest.mark.slow
def test_dense_search_never_replaces_earlier_results(tmp_path, capsys):
    from benchmarks.suites.dense_search import dense_search

    earlier = tmp_path / "dense_search.csv"
    earlier.write_text("c1,c2,c3\n0,0,0\n", encoding="utf-8")
    err = _one_line_exit_2(["dense-search", "--points", "2", "--out", str(tmp_path)], capsys)
    assert "exists and is not empty" in err
    with pytest.raises(ValueError, match="exists and is not empty"):
        dense_search(tmp_path, points=2, executor="serial")
    assert earlier.read_text(encoding="utf-8") == "c1,c2,c3\n0,0,0\n"
    assert [p.name for p in tmp_path.iterdir()] == ["dense_search.csv"]


def test_a_design_config_of_more_coefficients_than_a_tool_can_have_is_refused_at_once() -> None:
    from benchmarks.design.config import DesignConfig
    from tooldesign_env.geometry.tool import DEGREE_MAX

    DesignConfig(bounds=[[-1.0, 1.0]] * DEGREE_MAX)  # the most a tool can have
    with pytest.raises(ValueError, match=f"at most {DEGREE_MAX} rows"):
        DesignConfig(bounds=[[-1.0, 1.0]] * (DEGREE_MAX + 1))


@pytest.mark.parametrize(
    "argv",
    [
        ["bench", "optimizers", "--size", "smoke"],
        ["design"],
        ["evaluate", "--coeffs", "0", "0", "0"],
        ["dense-search"],
        ["rl", "suite", "--size", "smoke"],
    ],
)
def test_an_empty_out_is_refused_not_taken_as_the_current_folder(argv, capsys):
    err = _one_line_exit_2([*argv, "--out", ""], capsys)
    assert "argument --out: must name a folder, got ''" in err


def _public_calls():
    from benchmarks.reports.suite import designs_table
    from benchmarks.storage import (
        csv_text,
        file_sha256,
        part_checksums,
        status_counts,
        timing_totals,
    )
    from benchmarks.suites import builtin_suite

    return [
        (lambda: status_counts(None), TypeError, "evaluations must be a pandas DataFrame"),
        (lambda: timing_totals("log"), TypeError, "evaluations must be a pandas DataFrame"),
        (lambda: csv_text([1, 2]), TypeError, "frame must be a pandas DataFrame"),
        (lambda: part_checksums("folder"), TypeError, "store must be a ResultStore"),
        (lambda: file_sha256(True), TypeError, "path must be a str or os.PathLike"),
        (lambda: file_sha256(1), TypeError, "path must be a str or os.PathLike"),  # stdout's fd
        (lambda: designs_table("abc"), TypeError, "designs must be a sequence"),
        (lambda: designs_table([1, 2]), TypeError, "design records"),
        (lambda: builtin_suite(["x"]), ValueError, "unknown suite"),
        (lambda: builtin_suite("optimizers", ["smoke"]), ValueError, "unknown size"),
    ]


@pytest.mark.parametrize("case", range(10))
def test_public_storage_suite_and_report_functions_name_a_value_of_the_wrong_kind(case):
    call, error, match = _public_calls()[case]
    with pytest.raises(error, match=match):
        call()
