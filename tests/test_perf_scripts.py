"""The developer scripts of perf/ (not installed): what they compute and print, not their wording.

Each script has a ``parse_args(argv)`` that its ``main`` calls first; the argparse messages
themselves are the scripts' own business and not pinned here. What is pinned: every script
imports and parses its arguments before it measures anything, the designs the speed scripts
measure, the figures ``compare_trees`` reads, and the parts ``ratio_bound`` times.
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
PERF = ROOT / "perf"
#: Every script by name, with the folder of its purpose (speed or studies).
GROUPS = {
    p.stem: group
    for group in ("speed", "studies")
    for p in sorted((PERF / group).glob("*.py"))
    if p.stem != "__init__"
}
#: Checked by its own tests (test_dask_cluster.py).
NOT_HERE = {"dask_cluster"}
SCRIPTS = sorted(name for name in GROUPS if name not in NOT_HERE)


def _script(name: str, monkeypatch: pytest.MonkeyPatch) -> ModuleType:
    return importlib.import_module(f"perf.{GROUPS[name]}.{name}")


def test_the_scripts_are_sorted_by_purpose() -> None:
    assert not list((ROOT / "benchmarks").glob("perf/*.py"))  # out of the installed package
    assert {"evaluation_speed", "compare_trees", "dask_cluster"} <= {
        name for name, group in GROUPS.items() if group == "speed"
    }
    assert {"confidence_noise", "cage_scene", "interval_coverage"} <= {
        name for name, group in GROUPS.items() if group == "studies"
    }


@pytest.mark.slow
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


@pytest.mark.slow
def test_compare_trees_shows_the_scripts_error_and_exits_with_its_code() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "perf.speed.compare_trees", str(ROOT), str(ROOT), "--", "--bogus"],
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


@pytest.mark.slow
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


def test_the_asv_config_points_at_this_repository_and_its_benchmarks() -> None:
    # asv reads JSON with // comments; its paths are relative to the config's folder.
    text = (PERF / "asv.conf.json").read_text()
    lines = [line for line in text.splitlines() if not line.strip().startswith("//")]
    config = json.loads("\n".join(lines))
    assert (PERF / config["repo"]).resolve() == ROOT
    assert (PERF / config["benchmark_dir"] / "__init__.py").is_file()
    for key in ("env_dir", "results_dir", "html_dir"):
        assert (PERF / config[key]).resolve().parent == ROOT / ".asv"  # gitignored
    assert ".asv/" in (ROOT / ".gitignore").read_text().splitlines()


@pytest.mark.slow
def test_every_asv_benchmark_runs_once_as_asv_runs_it() -> None:
    """setup, each time_/track_ method, teardown: what asv does per parameter, once."""
    from perf.asv_benchmarks import evaluation

    ran = []
    for cls in (evaluation.Evaluation, evaluation.Construction):
        params = getattr(cls, "params", [None])
        for param in params:
            bench = cls()
            args = () if param is None else (param,)
            if hasattr(bench, "setup"):
                bench.setup(*args)
            try:
                for name in dir(bench):
                    if name.startswith(("time_", "track_")):
                        value = getattr(bench, name)(*args)
                        if name.startswith("track_"):
                            assert np.isfinite(value), (name, param)
                        ran.append(f"{cls.__name__}.{name}({param})")
            finally:
                if hasattr(bench, "teardown"):
                    bench.teardown(*args)
    assert len(ran) == 5, ran
