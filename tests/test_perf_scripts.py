"""The scripts of benchmarks/perf/ refuse bad arguments at parse time, naming the value.

Each script has a ``parse_args(argv)`` that its ``main`` calls first; these tests run only the
parsers (no simulation): a bad value must exit with argparse's code 2 and a message that names
the argument and the value, never a traceback or a quietly wrong run.
"""

from __future__ import annotations

import ast
import importlib
import json
import os
import re
import subprocess
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest

import tooldesign_env
from tooldesign_env import SceneSpec
from tooldesign_env.geometry import ToolSpec

ROOT = Path(__file__).resolve().parents[1]
PERF = ROOT / "benchmarks" / "perf"
#: Not a script (the shared argument types), or checked by its own tests (test_dask_cluster.py).
NOT_HERE = {"_args", "dask_cluster"}
SCRIPTS = sorted(p.stem for p in PERF.glob("*.py") if p.stem not in NOT_HERE)


def _script(name: str, monkeypatch: pytest.MonkeyPatch) -> ModuleType:
    monkeypatch.syspath_prepend(str(PERF))
    return importlib.import_module(name)


BAD = [
    # evaluation_speed.py: --designs 0 ran two designs and printed "0 x 1 (valid: 2)".
    ("evaluation_speed", ["--designs", "0"], "argument --designs: must be an int >= 1, got '0'"),
    ("evaluation_speed", ["--designs", "-1"], "argument --designs: must be an int >= 1, got '-1'"),
    ("evaluation_speed", ["--designs", "two"], "argument --designs: must be an int >= 1"),
    ("evaluation_speed", ["--repeats", "0"], "argument --repeats: must be an int >= 1, got '0'"),
    ("evaluation_speed", ["--reference", "-1"], "argument --reference: must be an int >= 0"),
    ("evaluation_speed", ["--first", "-1"], "argument --first: must be an int >= 0, got '-1'"),
    ("evaluation_speed", ["--seed", "-1"], "argument --seed: must be an int >= 0, got '-1'"),
    ("evaluation_speed", ["--section-shape", "hex"], "argument --section-shape: invalid choice"),
    ("evaluation_speed", ["--loop", "fortran"], "argument --loop: invalid choice: 'fortran'"),
    ("evaluation_speed", ["--scene", "bogus=1"], "scene has no field 'bogus'"),
    ("evaluation_speed", ["--scene", "box_mass=-1"], "--scene: SceneSpec.box_mass must be"),
    # physics_options.py: --option bogus was a ValueError traceback.
    ("physics_options", ["--option", "bogus"], "option 'bogus' must look like spec.field=value"),
    (
        "physics_options",
        ["--option", "scene.box_mass=-1"],
        "--option 'scene.box_mass=-1': SceneSpec.box_mass must be",
    ),
    ("physics_options", ["--option", "arm.x=1"], "spec must be one of"),
    ("physics_options", ["--base", "tool.n_segments=0", "--option", "scene.box_mass=1"], "--base"),
    ("physics_options", ["--designs", "0", "--option", "scene.box_mass=1"], "--designs: must be"),
    ("physics_options", ["--repeats", "0", "--option", "scene.box_mass=1"], "--repeats: must be"),
    ("physics_options", [], "give at least one --option"),
    # pool_speedup.py: --designs 0 printed "CPU share 5.31", --workers 0 failed after the
    # serial run, --repeats 0 a StatisticsError.
    ("pool_speedup", ["--designs", "0"], "argument --designs: must be an int >= 1, got '0'"),
    ("pool_speedup", ["--designs", "-1"], "argument --designs: must be an int >= 1, got '-1'"),
    ("pool_speedup", ["--workers", "0"], "argument --workers: must be an int >= 1, got '0'"),
    ("pool_speedup", ["--repeats", "0"], "argument --repeats: must be an int >= 1, got '0'"),
    ("pool_speedup", ["--seed", "-1"], "argument --seed: must be an int >= 0, got '-1'"),
    ("cli_startup", ["--repeat", "0"], "argument --repeat: must be an int >= 1, got '0'"),
    ("evaluation_memory", ["--evaluations", "-3"], "argument --evaluations: must be an int >= 1"),
    ("evaluation_memory", ["--evaluations", "0"], "argument --evaluations: must be an int >= 1"),
    ("evaluation_memory", ["--warmup", "-1"], "argument --warmup: must be an int >= 0"),
    ("optimizers_overhead", ["--time-cap", "-1"], "--time-cap: must be a finite number >= 0 s"),
    ("optimizers_overhead", ["--time-cap", "nan"], "--time-cap: must be a finite number >= 0 s"),
    ("optimizers_overhead", ["--time-cap", "inf"], "--time-cap: must be a finite number >= 0 s"),
    ("optimizers_overhead", ["--quality-seeds", "-1"], "--quality-seeds: must be an int >= 0"),
    ("optimizers_overhead", ["--quality-iterations", "0"], "--quality-iterations: must be"),
    ("compare_trees", [str(ROOT), str(ROOT), "--rounds", "0"], "--rounds: must be an int >= 1"),
    ("compare_trees", [str(ROOT), "/nonexistent"], "after tree '/nonexistent' has no"),
    ("against_baseline", [str(ROOT), "--designs", "1"], "--designs: must be an int >= 2"),
    ("against_baseline", [str(ROOT), "--rounds", "0"], "--rounds: must be an int >= 1"),
    ("against_baseline", [str(ROOT), "--repeats", "0"], "--repeats: must be an int >= 1"),
    ("against_baseline", [str(ROOT), "--variant", '"open'], "--variant '\"open'"),
    ("against_baseline", ["/nonexistent"], "give the root of a source tree"),
    ("floor_guard", ["--designs", "-1"], "argument --designs: must be an int >= 0, got '-1'"),
    ("floor_guard", ["--tasks", "x"], "argument --tasks: must be an int >= 0, got 'x'"),
    ("floor_guard", ["--mass-range", "0", "1"], "--mass-range: must be a finite number > 0"),
    ("floor_guard", ["--mass-range", "nan", "1"], "--mass-range: must be a finite number > 0"),
    ("floor_guard", ["--mass-range", "0.9", "0.1"], "must be LOW <= HIGH kg, got 0.9 0.1"),
    ("floor_guard", ["--seed", "-1"], "argument --seed: must be an int >= 0"),
    ("physics_noise", ["--nudges", "1"], "--nudges: must be an int >= 2 (a spread needs two"),
    ("physics_noise", ["--designs", "0"], "argument --designs: must be an int >= 1"),
    ("physics_noise", ["--goal-precision", "-1"], "--goal / --goal-precision:"),
    ("physics_noise", ["--goal-precision", "nan"], "--goal / --goal-precision:"),
    ("physics_noise", ["--goal", "9", "9", "9"], "goal [9.0, 9.0, 9.0] is outside the workspace"),
    ("physics_noise", ["--settings", "bogus"], "argument --settings: invalid choice"),
    ("physics_noise", ["--settings"], "argument --settings: expected at least one argument"),
    ("rl_random_actions", ["--episodes", "0"], "--episodes: must be an int from 1 to 100000"),
    ("rl_random_actions", ["--seed", "-1"], "--seed: must be an int from 0 to 4294967295"),
    ("rl_throughput", ["--num-envs", "0"], "argument --num-envs: must be an int >= 1, got '0'"),
    ("rl_throughput", ["--episodes", "0"], "argument --episodes: must be an int >= 1"),
    ("rl_throughput", ["--seed", "-1"], "argument --seed: must be an int >= 0"),
    ("rollout_breakdown", ["--designs", "0"], "argument --designs: must be an int >= 1"),
    ("rollout_breakdown", ["--repeats", "0"], "argument --repeats: must be an int >= 1"),
    ("rollout_breakdown", ["--seed", "-1"], "argument --seed: must be an int >= 0"),
    ("interval_coverage", ["--trials", "1"], "argument --trials: must be an int >= 10, got '1'"),
    ("interval_coverage", ["--sizes", "1"], "argument --sizes: must be an int from 2 to 1000"),
    ("interval_coverage", ["--n-boot", "5"], "argument --n-boot: must be an int >= 100"),
    ("interval_coverage", ["--seed", "-1"], "argument --seed: must be an int >= 0, got '-1'"),
    ("ratio_bound", ["--designs", "0"], "argument --designs: must be an int >= 1, got '0'"),
    ("ratio_bound", ["--repeats", "0"], "argument --repeats: must be an int >= 1, got '0'"),
    ("ratio_bound", ["--seed", "-1"], "argument --seed: must be an int >= 0, got '-1'"),
    ("rollout_callgrind", ["--designs", "0"], "argument --designs: must be an int >= 1"),
    ("rollout_callgrind", ["--seed", "-1"], "argument --seed: must be an int >= 0"),
    ("section_convergence", ["--designs", "0"], "argument --designs: must be an int >= 1"),
    ("section_convergence", ["--segments", "15"], "needs two different counts or more"),
    ("section_convergence", ["--segments", "15", "15"], "needs two different counts or more"),
    ("section_convergence", ["--segments", "15", "1000"], "--segments: ToolSpec.n_segments"),
    ("section_convergence", ["--seed", "-1"], "argument --seed: must be an int >= 0"),
    ("cage_scene", ["--random", "-1"], "argument --random: must be an int >= 0, got '-1'"),
    ("cage_scene", ["--masses", "0"], "argument --masses: must be a finite number > 0"),
    ("cage_scene", ["--xs", "nan"], "argument --xs: must be a finite number m, got 'nan'"),
    ("cage_scene", ["--seeds", "0"], "argument --seeds: must be an int >= 1"),
    ("cage_scene", ["--xs", "100"], "--xs / --ys / --pick: SceneSpec.box_position must be"),
    ("cage_scene", ["--pick", "0", "50"], "--xs / --ys / --pick: SceneSpec.box_position must"),
    ("cage_scene", ["--no-grid"], "--no-grid needs --pick X Y"),
    ("cage_scene", ["--scene", "box_position=(0, 1, 0)"], "the placements are the grid's"),
    ("cage_scene", ["--scene", "box_mass=-1"], "--scene: SceneSpec.box_mass must be"),
    ("confidence_convergence", ["--seed", "-1"], "argument --seed: must be an int >= 0"),
    ("confidence_convergence", ["--figure", "/nonexistent/f.png"], "its folder does not exist"),
    ("confidence_convergence", ["--scene", "time_step=0.1"], "the time steps are the study's"),
    ("confidence_noise", ["--seed", "-1"], "argument --seed: must be an int >= 0"),
    ("confidence_noise", ["--scene-samples", "0"], "--scene-samples: must be an int >= 1"),
    ("fuzz_inputs", ["--timeout", "0"], "argument --timeout: must be a finite number > 0 s"),
    ("fuzz_inputs", ["--random", "-1"], "argument --random: must be an int >= 0"),
    ("fuzz_inputs", ["--cli-files", "-1"], "argument --cli-files: must be an int >= 0"),
    ("fuzz_inputs", ["--seed", "-1"], "argument --seed: must be an int >= 0"),
    ("evaluation_at_floor", [str(ROOT), "--designs", "0"], "--designs: must be an int >= 1"),
    ("evaluation_at_floor", [str(ROOT), "--rounds", "0"], "--rounds: must be an int >= 1"),
    ("evaluation_at_floor", [str(ROOT), "--preset", "fast"], "--preset must be one of"),
    ("evaluation_at_floor", [str(ROOT), "--core", "4096"], "--core must be one of the CPUs"),
    ("evaluation_at_floor", ["/nonexistent"], "has no tooldesign_env package"),
    ("suite_throughput", ["--workers", "1"], "argument --workers: must be an int from 2 to"),
    ("suite_throughput", ["--size", "huge"], "argument --size: invalid choice: 'huge'"),
    ("suite_throughput", ["--batch-size", "1"], "the suite of --size full"),
    ("suite_throughput", ["--timeout", "0"], "argument --timeout: must be a finite number > 0"),
    ("dask_task_overhead", ["--tasks", "5"], "argument --tasks: must be an int >= 10, got '5'"),
    ("dask_task_overhead", ["--workers", "0"], "argument --workers: must be an int from 1 to"),
    ("dask_task_overhead", ["--sequential", "0"], "--sequential: must be an int >= 1"),
    ("dask_task_overhead", ["--repeats", "0"], "argument --repeats: must be an int >= 1"),
    ("preset_callgrind", ["--preset", "fast"], "argument --preset: invalid choice: 'fast'"),
    ("preset_callgrind", ["--designs", "-1"], "argument --designs: must be an int >= 0"),
    ("preset_callgrind", ["--seed", "-1"], "argument --seed: must be an int >= 0"),
]


@pytest.mark.parametrize(("script", "argv", "message"), BAD)
def test_a_bad_argument_is_an_argparse_error_naming_it(
    script: str,
    argv: list[str],
    message: str,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    module = _script(script, monkeypatch)
    with pytest.raises(SystemExit) as exit_:
        module.parse_args(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "error: " in err and "Traceback" not in err
    assert message in err, err


def test_every_script_is_checked_here() -> None:
    checked = {script for script, _, _ in BAD}
    assert checked == set(SCRIPTS), set(SCRIPTS) ^ checked


@pytest.mark.parametrize("script", SCRIPTS)
def test_main_parses_its_arguments_first(script: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """``main`` goes through ``parse_args`` before it measures anything."""
    module = _script(script, monkeypatch)

    class Parsed(Exception):
        pass

    def parse_args(argv: list[str] | None = None) -> None:
        raise Parsed(argv)

    monkeypatch.setattr(module, "parse_args", parse_args)
    with pytest.raises(Parsed) as parsed:
        module.main(["--a-bad-argument"])
    assert parsed.value.args == (["--a-bad-argument"],)


@pytest.mark.parametrize(
    ("script", "argv"),
    [
        ("evaluation_speed", []),
        ("evaluation_speed", ["--designs", "1", "--reference", "0", "--first", "0"]),
        ("physics_options", ["--option", "scene.solver_iterations=20+tool.n_segments=15"]),
        ("pool_speedup", ["--designs", "1", "--workers", "1"]),
        ("optimizers_overhead", ["--time-cap", "0"]),
        ("floor_guard", ["--designs", "0", "--tasks", "0", "--mass-range", "0.5", "0.5"]),
        ("section_convergence", ["--segments", "15", "30"]),
        ("compare_trees", [str(ROOT), str(ROOT), "--", "--designs", "2"]),
        ("against_baseline", [str(ROOT), "--designs", "2"]),
        ("evaluation_at_floor", [str(ROOT), "--designs", "1", "--preset", "062b3a0"]),
        ("suite_throughput", ["--size", "smoke", "--seeds", "1", "--iterations", "1"]),
        ("dask_task_overhead", ["--tasks", "10", "--sequential", "1"]),
    ],
)
def test_good_arguments_parse(
    script: str, argv: list[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    _script(script, monkeypatch).parse_args(argv)


@pytest.mark.parametrize("script", ["evaluation_speed", "physics_options"])
def test_designs_n_is_n_designs_the_straight_tool_and_the_hook_first(
    script: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    designs = _script(script, monkeypatch).designs
    assert len(designs(1, 0)) == 1 and not designs(1, 0)[0].any()  # the straight tool alone
    two = designs(2, 0)
    np.testing.assert_array_equal(np.stack(two), [[0.0, 0.0, 0.0], [0.0, 1.5, 0.0]])
    twelve = designs(12, 0)
    assert len(twelve) == 12
    # The same random designs as before n < 2 was cut: the first two, then the seed's draws.
    np.testing.assert_array_equal(np.stack(twelve[:2]), np.stack(two))
    expected = np.random.default_rng(0).uniform([-1.5, -1.5, -0.5], [1.5, 1.5, 0.5], (10, 3))
    np.testing.assert_array_equal(np.stack(twelve[2:]), expected)


def test_compare_trees_shows_the_scripts_error_and_exits_with_its_code() -> None:
    out = subprocess.run(
        [sys.executable, str(PERF / "compare_trees.py"), str(ROOT), str(ROOT), "--", "--bogus"],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        cwd=ROOT,
        timeout=300,
        check=False,
    )
    assert out.returncode == 2, out.stderr
    assert "Traceback" not in out.stderr
    # The child's own argparse message, then one line saying which run failed.
    assert "evaluation_speed.py: error: unrecognized arguments: --bogus" in out.stderr
    last = out.stderr.strip().splitlines()[-1]
    assert last.startswith("compare_trees.py: evaluation_speed.py --bogus failed (exit code 2)")


class _FakeEnv:
    """Stands for ToolDesignEnv in the first-evaluation child: records how it was made."""

    made: list[dict[str, object]] = []

    def __init__(self, **kwargs: object) -> None:
        _FakeEnv.made.append(kwargs)
        self.simulator = type("Simulator", (), {"native_status": "native"})()

    def reset(self, seed: int | None = None) -> None:
        pass

    def step(self, action: object) -> None:
        pass

    def close(self) -> None:
        pass


def test_the_first_evaluation_child_makes_the_parents_tool_and_scene(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    speed = _script("evaluation_speed", monkeypatch)
    options = {"tool": {"section_shape": "square"}, "scene": {"box_position": (0.1, 1.0)}}
    monkeypatch.setattr(tooldesign_env, "ToolDesignEnv", _FakeEnv)
    monkeypatch.setattr(sys, "argv", ["-c", repr(options)])
    _FakeEnv.made.clear()
    exec(speed._FIRST_EVALUATION, {"__name__": "__main__"})
    # Before: ToolDesignEnv(scene=...) with no tool, the round tool whatever --section-shape.
    assert _FakeEnv.made == [
        {
            "tool": ToolSpec(section_shape="square"),
            "scene": SceneSpec(box_position=(0.1, 1.0)),
        }
    ]
    printed = json.loads(capsys.readouterr().out)
    assert set(printed) == {"construction", "step", "loop"} and printed["loop"] == "native"
    # Without --scene the env is made as older trees make it: no scene argument.
    _FakeEnv.made.clear()
    monkeypatch.setattr(
        sys, "argv", ["-c", repr({"tool": {"section_shape": "round"}, "scene": {}})]
    )
    exec(speed._FIRST_EVALUATION, {"__name__": "__main__"})
    assert _FakeEnv.made == [{"tool": ToolSpec(section_shape="round")}]


@pytest.mark.parametrize("child_loop", ["the parent's", "another"])
def test_the_first_evaluation_figure_is_construction_plus_first_step(
    child_loop: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The parent passes its tool and scene to the child and counts construction + first step."""
    speed = _script("evaluation_speed", monkeypatch)
    envs: list[Any] = []

    class Recorded(speed.ToolDesignEnv):
        def __init__(self, **kwargs: object) -> None:
            super().__init__(**kwargs)
            envs.append(self)

    monkeypatch.setattr(speed, "ToolDesignEnv", Recorded)
    calls: list[list[str]] = []

    def run(argv: list[str], **kwargs: object) -> subprocess.CompletedProcess[str]:
        calls.append(argv)
        parent = envs[0].simulator.native_status
        loop = parent if child_loop == "the parent's" else "Python loop: elsewhere"
        out = {"construction": 0.05, "step": 0.10, "loop": loop}
        return subprocess.CompletedProcess(argv, 0, stdout=json.dumps(out) + "\n")

    monkeypatch.setattr(speed.subprocess, "run", run)
    speed.main(
        ["--designs", "1", "--repeats", "1", "--reference", "0", "--first", "1"]
        + ["--section-shape", "square", "--scene", "tool_friction=0.5"]
    )
    assert len(calls) == 3  # one cold, one to fill the cache, one warm
    for argv in calls:
        assert ast.literal_eval(argv[-1]) == {
            "tool": {"section_shape": "square"},
            "scene": {"tool_friction": 0.5},
        }
    out = capsys.readouterr().out
    median = float(re.search(r"evaluation of F \(env.step\):\s+median ([0-9.]+) s", out)[1])
    for label in ("empty plan cache:", "plan cache on disk:"):
        line = next(line for line in out.splitlines() if line.strip().startswith(label))
        assert "construction + first step median 0.150 s" in line
        assert f"({0.15 / median:.1f} medians)" in line
        assert "construction median 0.050 s, first step median 0.100 s" in line
    if child_loop == "another":
        assert "WARNING: the fresh processes ran the control loop ['Python loop: elsewhere']" in out
        return
    assert "WARNING" not in out
    # compare_trees.py reads every figure of this output, the new ones included.
    compare = _script("compare_trees", monkeypatch)
    figures = {
        label: float(match[1])
        for label, pattern in compare.FIGURES
        if (match := re.search(pattern, out)) is not None
    }
    assert set(figures) == {label for label, _ in compare.FIGURES}
    for cache in ("empty cache", "cache on disk"):
        assert figures[f"first evaluation, {cache}, s"] == 0.15
        assert figures[f"first evaluation, {cache}, medians"] == round(0.15 / median, 1)
        assert figures[f"  construction, {cache}, s"] == 0.05
        assert figures[f"  first step, {cache}, s"] == 0.1
    assert compare.LOOP.search(out) is not None


@pytest.mark.parametrize(
    ("time_cap", "measured", "lines"),
    [
        # The audit's run: --time-cap 2 and a 23.8 s ask at 50 observations. That first ask has
        # nothing to be projected from and is measured; the larger ones are skipped.
        (
            2.0,
            [50],
            [
                "100 0.30 0.40 skipped: projected 52.4 s > --time-cap 2 s",
                "200 0.30 0.40 skipped: projected 115.2 s > --time-cap 2 s",
            ],
        ),
        (0.0, [], ["50 0.30 0.40 skipped: --time-cap 0", "200 0.30 0.40 skipped: --time-cap 0"]),
        (60.0, [50, 100], ["200 0.30 0.40 skipped: projected 104.7 s > --time-cap 60 s"]),
        (400.0, [50, 100, 200], []),
    ],
)
def test_the_time_cap_bounds_projected_skopt_asks(
    time_cap: float,
    measured: list[int],
    lines: list[str],
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    overhead = _script("optimizers_overhead", monkeypatch)
    asks: list[int] = []

    def default_skopt_ask(n: int) -> tuple[float, float]:
        asks.append(n)
        return 1.0, 23.8 * n / 50  # (tell, ask): linear in n

    monkeypatch.setattr(overhead, "fast_bo_asks", lambda n: (0.3, 0.4))
    monkeypatch.setattr(overhead, "default_skopt_ask", default_skopt_ask)
    overhead.bo_timing(time_cap)
    assert asks == measured
    out = [" ".join(line.split()) for line in capsys.readouterr().out.splitlines()]
    for line in lines:
        assert line in out
    assert sum("skipped" in line for line in out) == 3 - len(measured)


@pytest.mark.slow
def test_ratio_bound_times_each_part_and_puts_the_originals_back(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Every part the bound counts is timed (non-zero) and no wrapper outlives the measurement."""
    bound = _script("ratio_bound", monkeypatch)
    originals = {name: getattr(np.linalg, name) for name in bound.LAPACK}
    arm_matrices = bound.ControlLoops.arm_matrices
    mass = bound.tool_module._mesh_mass_properties
    env = bound.ToolDesignEnv()
    env.reset(seed=0)
    try:
        parts = bound.measure(env, np.zeros(3))
    finally:
        env.close()
    assert parts is not None
    assert set(parts) == {
        "evaluation", "floor", "requests", "arm_matrices", "mass_properties", "lapack"
    }
    # The straight tool touches the box: its contact log has Jacobians and Pi_U eigenvalues.
    for name in ("arm_matrices", "mass_properties", "lapack", "floor", "evaluation"):
        assert parts[name] > 0.0, name
    assert {name: getattr(np.linalg, name) for name in bound.LAPACK} == originals
    assert bound.ControlLoops.arm_matrices is arm_matrices
    assert bound.tool_module._mesh_mass_properties is mass
