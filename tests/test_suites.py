"""Tests of benchmarks.suites (declared suites, files, seeds), the smoke suites end to end and
the report rebuilt from a finished run folder."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import optimizers
from benchmarks.cli import main
from benchmarks.reports.suite import make_suite_report, tool_shape
from benchmarks.storage import ResultStore, read_designs
from benchmarks.suites import (
    BUILTIN_SUITES,
    SIZES,
    OptimizerSpec,
    SuiteConfig,
    Variant,
    builtin_suite,
    load_suite,
    save_suite,
    suite_from_json,
)
from benchmarks.suites.runner import run_suite

ROOT = Path(__file__).resolve().parents[1]
PAPER_SUITES = ("optimizers", "precision-sweep", "robustness", "mass-perturbation")
PEERS_INSTALLED = any(n in optimizers.available() for n in ("optuna-tpe", "nevergrad"))


def all_builtins() -> list[tuple[str, str]]:
    names = [n for n in BUILTIN_SUITES if n != "optimizer-peers" or PEERS_INSTALLED]
    return [(n, s) for n in names for s in SIZES]


# --- declared configs --------------------------------------------------------------------------


@pytest.mark.parametrize(("name", "size"), all_builtins())
def test_builtin_suites_validate_and_round_trip_through_files(
    name: str, size: str, tmp_path: Path
) -> None:
    suite = builtin_suite(name, size)
    assert isinstance(suite, SuiteConfig)
    runs = suite.runs()
    assert len(runs) == suite.n_seeds * len(suite.variants) * len(suite.optimizers)
    assert suite.evaluations() == len(runs) * suite.iterations * suite.batch_size
    for suffix in (".json", ".toml"):
        path = save_suite(suite, tmp_path / f"suite{suffix}")
        assert load_suite(path) == suite
    assert suite_from_json(json.loads(json.dumps(suite.to_json()))) == suite


def test_paper_budgets() -> None:
    full = builtin_suite("optimizers", "full")
    assert [o.name for o in full.optimizers] == ["cmaes", "bo", "pso", "random"]
    assert (full.batch_size, full.iterations, full.n_seeds, full.goal_precision) == (8, 15, 10, 20)
    sweep = builtin_suite("precision-sweep", "full")
    assert [v.goal_precision for v in sweep.variants] == [0, 10, 20, 30, 40, 50]
    robust = builtin_suite("robustness", "full")
    assert len(robust.variants) == 7 and robust.n_seeds == 10
    assert {v.label: v.goal_precision for v in robust.variants if v.label} == {
        "pure confidence": 0.0,
        "free energy": 20.0,
        "pure performance": 50.0,
    }
    assert robust.robustness_masses == (0.3, 0.5, 0.7, 0.9)
    masses = builtin_suite("mass-perturbation", "full")
    assert [v.goal_precision for v in masses.variants] == [0, 50] and masses.keep_paths
    for name in PAPER_SUITES:
        smoke = builtin_suite(name, "smoke")
        assert (smoke.n_seeds, smoke.iterations, smoke.batch_size) == (2, 2, 4)


def test_seeds_come_from_one_seed_sequence_and_every_run_sees_the_same_tasks() -> None:
    suite = builtin_suite("robustness", "smoke").replace(root_seed=7, n_seeds=4)
    expected = tuple(
        int(child.generate_state(1, dtype=np.uint32)[0])
        for child in np.random.SeedSequence(7).spawn(4)
    )
    assert suite.seeds() == expected
    tasks_of: dict[tuple[str, str], list[tuple[int, tuple[float, ...]]]] = {}
    for run in suite.runs():
        tasks_of.setdefault((run.variant.name, run.optimizer.column), []).append(
            (run.task.seed, run.task.goal)
        )
        assert run.design.seed == run.task.seed and run.design.goal == run.task.goal
    assert len({tuple(v) for v in tasks_of.values()}) == 1  # same tasks for everyone
    goals = np.array([t.goal for t in suite.tasks()])
    assert np.all((goals[:, 0] >= -0.5) & (goals[:, 0] <= 0.5))
    assert np.all((goals[:, 1] >= 0.5) & (goals[:, 1] <= 1.5)) and np.all(goals[:, 2] == 0.1)
    assert len(np.unique(goals[:, 0])) == 4
    # Same root, same tasks; another root, other tasks.
    assert suite.replace(workers=1).tasks() == suite.tasks()
    assert suite.replace(root_seed=8).tasks() != suite.tasks()
    # The first tasks do not change when more are added.
    assert suite.replace(n_seeds=6).tasks()[:4] == suite.tasks()


def test_a_suite_file_may_start_from_a_builtin_and_define_sizes(tmp_path: Path) -> None:
    path = tmp_path / "mine.toml"
    path.write_text(
        'base = "optimizers"\n'
        'name = "optimizers-p40"\n'
        "goal_precision = 40.0\n"
        "n_seeds = 5\n"
        "\n"
        "[[optimizers]]\n"
        'name = "cmaes"\n'
        "settings = { sigma0 = 0.2 }\n"
        'label = "cmaes-0.2"\n'
        "\n"
        "[[optimizers]]\n"
        'name = "random"\n'
        "\n"
        "[sizes.smoke]\n"
        "n_seeds = 2\n"
        "iterations = 2\n",
        encoding="utf-8",
    )
    full = load_suite(path)
    assert full.name == "optimizers-p40" and full.goal_precision == 40.0 and full.n_seeds == 5
    assert full.iterations == 15 and full.batch_size == 8  # from the base
    assert [o.column for o in full.optimizers] == ["cmaes-0.2", "random"]
    assert dict(full.optimizers[0].settings) == {"sigma0": 0.2}
    smoke = load_suite(path, size="smoke")
    assert (smoke.n_seeds, smoke.iterations) == (2, 2)
    with pytest.raises(ValueError, match="unknown size 'huge'"):
        load_suite(path, size="huge")
    assert load_suite(path, size="full") == full  # the default, whether or not a table names it


def test_a_size_the_file_cannot_apply_is_refused_not_ignored(tmp_path):
    """Without base or [sizes], --size smoke would run the file as it is under a smoke label."""
    path = tmp_path / "plain.toml"
    path.write_text('name = "plain"\niterations = 3\n[[optimizers]]\nname = "random"\n')
    assert load_suite(path, size="full") == load_suite(path)
    with pytest.raises(ValueError, match="defines no sizes, so --size smoke would change nothing"):
        load_suite(path, size="smoke")
    typo = tmp_path / "typo.toml"
    typo.write_text(
        'name = "typo"\n[[optimizers]]\nname = "random"\n[sizes.smoke]\nn_seed = 2\n'
    )
    with pytest.raises(ValueError, match=r"\[sizes.smoke\]: unknown keys \[n_seed\]"):
        load_suite(typo, size="smoke")


@pytest.mark.parametrize(
    ("changes", "error", "match"),
    [
        ({"name": ""}, ValueError, "name"),
        ({"env_id": "CartPole-v1"}, ValueError, "env_id"),
        ({"variants": ()}, ValueError, "at least one"),
        ({"variants": (Variant(name="a"), Variant(name="a"))}, ValueError, "unique"),
        (
            {"optimizers": (OptimizerSpec(name="cmaes"), OptimizerSpec(name="cmaes"))},
            ValueError,
            "unique",
        ),
        ({"n_seeds": 0}, ValueError, "n_seeds"),
        ({"iterations": 1.5}, TypeError, "iterations"),
        ({"goal_box": ((0, 1), (1, 0), (0, 0))}, ValueError, "goal_box y"),
        ({"figures": ("nope",)}, ValueError, "unknown figure"),
        ({"figures": ("mass-paths",)}, ValueError, "needs test_robustness and keep_paths"),
        ({"robustness_masses": (0.3, -1.0)}, ValueError, "robustness_masses"),
        ({"executor": "threads"}, ValueError, "executor"),
        ({"scheduler": "tcp://x:1"}, ValueError, "executor='dask'"),
        ({"goal_precision": -1.0}, ValueError, "goal_precision"),
        ({"test_robustness": "yes"}, TypeError, "test_robustness"),
    ],
)
def test_bad_configs_are_clear_errors(changes: dict, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        builtin_suite("optimizers", "smoke").replace(**changes)


def test_unknown_suite_and_size_are_clear_errors() -> None:
    with pytest.raises(ValueError, match="unknown suite 'nope'.*optimizers"):
        builtin_suite("nope")
    with pytest.raises(ValueError, match="unknown size 'tiny'"):
        builtin_suite("optimizers", "tiny")


@pytest.mark.parametrize(
    ("name", "text", "error", "match"),
    [
        ("bad.toml", "name = [unclosed\n", ValueError, "not valid TOML"),
        ("bad.json", "{not json", ValueError, "not valid JSON"),
        ("list.json", "[1, 2]", ValueError, "must hold a table"),
        ("bad.yaml", "name: x\n", ValueError, "must end in .toml or .json"),
        ("unknown.toml", 'name = "x"\nspeed = 3\n', ValueError, "unknown keys \\['speed'\\]"),
        ("type.toml", 'name = "x"\nn_seeds = "ten"\n', TypeError, "n_seeds"),
        ("base.toml", 'base = "nope"\n', ValueError, "unknown suite 'nope'"),
        (
            "variant.toml",
            'name = "x"\n[[variants]]\nname = "a"\ncolour = 1\n',
            ValueError,
            "variants\\[0\\]: unknown keys",
        ),
    ],
)
def test_bad_suite_files_are_clear_errors(
    tmp_path: Path, name: str, text: str, error: type, match: str
) -> None:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    with pytest.raises(error, match=match):
        load_suite(path)
    with pytest.raises(FileNotFoundError, match="does not exist"):
        load_suite(tmp_path / "missing.toml")
    # A folder was said "not to exist".
    with pytest.raises(IsADirectoryError, match="is a folder; give a .toml or .json file"):
        load_suite(tmp_path)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["bench", "nope", "--out", "{out}"], "unknown suite 'nope'"),
        (["bench", "optimizers", "--size", "tiny", "--out", "{out}"], "unknown size 'tiny'"),
        (["bench", "--out", "{out}"], "give a SUITE"),
        (["bench", "--config", "{missing}", "--out", "{out}"], "does not exist"),
        (["bench", "--config", "{empty}", "--out", "{out}"], r"suite file \S+ is a folder"),
        (["bench", "--config", "{bad}", "--out", "{out}"], "not valid TOML"),
        (["bench", "optimizers", "--workers", "0", "--out", "{out}"], "workers must be >= 1"),
        (["report", "{missing}"], "does not exist"),
        (["report", "{empty}"], "holds no results"),
    ],
)
def test_bad_command_lines_exit_2_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], match: str
) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("name = [\n", encoding="utf-8")
    (tmp_path / "empty").mkdir()
    values = {
        "out": tmp_path / "out",
        "missing": tmp_path / "missing",
        "bad": bad,
        "empty": tmp_path / "empty",
    }
    with pytest.raises(SystemExit) as exit_info:
        main([a.format(**values) for a in args])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and re.search(match, err), err
    assert not (tmp_path / "out").exists()  # nothing was made


def test_an_uninstallable_optimizer_stops_before_any_file(tmp_path: Path) -> None:
    suite = builtin_suite("optimizers", "smoke").replace(
        optimizers=(OptimizerSpec(name="no-such-optimizer"),)
    )
    with pytest.raises(ValueError, match="unknown optimizer 'no-such-optimizer'"):
        run_suite(suite, tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_dump_config_writes_a_file_that_loads_back(tmp_path: Path) -> None:
    target = tmp_path / "robustness.toml"
    args = ["bench", "robustness", "--size", "smoke", "--workers", "1", "--out", "unused"]
    assert main([*args, "--dump-config", str(target)]) == 0
    assert load_suite(target) == builtin_suite("robustness", "smoke").replace(workers=1)


@pytest.mark.parametrize(
    ("settings", "words"),
    [
        ("{ sigmaa0 = 0.3 }", "has no setting 'sigmaa0'; its settings: bounds, sigma0, "),
        ("{ sigma0 = -1.0 }", "sigma0 must be in [1e-06, 1] (a fraction of the box), got -1.0"),
    ],
)
def test_dump_config_refuses_bad_optimizer_settings_as_the_run_does(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], settings: str, words: str
) -> None:
    suite_file = tmp_path / "suite.toml"
    suite_file.write_text(
        f'base = "optimizers"\nname = "bad"\n\n[[optimizers]]\nname = "cmaes"\n'
        f"settings = {settings}\n"
    )
    args = ["bench", "--config", str(suite_file), "--size", "smoke", "--workers", "1"]
    target = tmp_path / "dumped.toml"
    errors = []
    for extra in (["--dump-config", str(target)], ["--no-progress"]):
        with pytest.raises(SystemExit) as exit_info:
            main([*args, "--out", str(tmp_path / "run"), *extra])
        assert exit_info.value.code == 2
        errors.append(capsys.readouterr().err)
    dumped, run = errors
    assert dumped == run and words in dumped and dumped.count("\n") == 1, dumped
    assert not target.exists() and not (tmp_path / "run").exists()


def test_dump_config_writes_a_suite_whose_optimizer_cannot_be_imported_here(
    tmp_path: Path,
) -> None:
    # Its settings cannot be checked without it: the file may be meant for another machine.
    suite_file = tmp_path / "suite.toml"
    suite_file.write_text(
        'base = "optimizers"\nname = "elsewhere"\n\n[[optimizers]]\n'
        'name = "no_such_module:Optimizer"\nsettings = { sigma0 = 0.1 }\n'
    )
    target = tmp_path / "dumped.toml"
    args = ["bench", "--config", str(suite_file), "--size", "smoke", "--out", "unused"]
    with pytest.warns(UserWarning, match="optimizer 'no_such_module:Optimizer' are not checked"):
        assert main([*args, "--dump-config", str(target)]) == 0
    assert load_suite(target).optimizers == (
        OptimizerSpec(name="no_such_module:Optimizer", settings={"sigma0": 0.1}),
    )


@pytest.mark.slow
@pytest.mark.parametrize("shape", ["square", "round"])
def test_bench_section_shape_sets_every_runs_tool(tmp_path: Path, shape: str) -> None:
    target = tmp_path / "optimizers.toml"
    args = ["bench", "optimizers", "--size", "smoke", "--out", "unused"]
    assert main([*args, "--section-shape", shape, "--dump-config", str(target)]) == 0
    suite = load_suite(target)
    assert suite == builtin_suite("optimizers", "smoke").replace(section_shape=shape)
    assert {run.design.tool_spec().section_shape for run in suite.runs()} == {shape}
    # Without the option the suite keeps its own section: the default tool's.
    assert main([*args, "--dump-config", str(target)]) == 0
    assert load_suite(target).section_shape == "round"


def test_bench_refuses_an_unknown_section_shape(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["bench", "optimizers", "--section-shape", "oval", "--out", str(tmp_path / "o")])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "--section-shape" in err and "'oval'" in err and "square" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_python_m_benchmarks_help_works() -> None:
    result = subprocess.run(
        [sys.executable, "-m", "benchmarks", "--help"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert "usage: tooldesign bench" in result.stdout and "--size" in result.stdout


def test_tool_shape_of_a_straight_and_a_bent_tool() -> None:
    straight = tool_shape((0.0, 0.0, 0.0))
    assert straight["straightness"] == pytest.approx(1.0)
    assert straight["turning_angle"] == pytest.approx(0.0, abs=1e-9)
    hook = tool_shape((0.0, -1.5, 0.5))
    assert hook["straightness"] < 0.91 and hook["turning_angle"] > 100.0
    assert hook["tip_offset"] < 0 < tool_shape((0.0, 1.5, 0.0))["tip_offset"]


# --- the smoke suites end to end ---------------------------------------------------------------


@pytest.fixture(scope="module")
def smoke_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Every paper suite at its smoke size, on the default process pool, in one folder each."""
    base = tmp_path_factory.mktemp("smoke")
    folders = {}
    for name in PAPER_SUITES:
        folders[name] = base / name
        run_suite(builtin_suite(name, "smoke"), folders[name], progress=False, size="smoke")
        make_suite_report(folders[name])  # what `tooldesign bench` does after the run
    return folders


EXPECTED_REPORTS = {
    "optimizers": ["convergence-optimizers.png"],
    "precision-sweep": ["tool-shapes.png", "tool-shapes-overlay.png", "tool-shapes.md"],
    "robustness": ["table1.csv", "table1.md", "robustness-scatter.png"],
    "mass-perturbation": ["mass-perturbation-p0.png", "mass-perturbation-p50.png"],
}


@pytest.mark.slow
@pytest.mark.parametrize("name", PAPER_SUITES)
def test_every_smoke_suite_runs_end_to_end(smoke_runs: dict[str, Path], name: str) -> None:
    folder = smoke_runs[name]
    suite = builtin_suite(name, "smoke")
    log = ResultStore(folder).read()
    assert len(log) == suite.evaluations()
    assert set(log["suite"]) == {suite.name}
    assert log["status"].isin(["ok", "invalid"]).all()
    designs = read_designs(folder)
    assert len(designs) == len(suite.runs())
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["extra"]["kind"] == "suite" and manifest["end_time"] is not None
    assert manifest["config"] == suite.to_json()
    assert manifest["simulation_time"] > 0 and manifest["wall_time"] > 0
    assert (folder / "evaluations.parquet").is_file() or (folder / "evaluations.csv").is_file()
    report = folder / "report"
    for file in ["summary.md", "pairwise.md", "designs.csv", *EXPECTED_REPORTS[name]]:
        assert (report / file).is_file(), file
    if suite.test_robustness:
        tests = [d["test"] for d in designs]
        assert all(t["error"] == "" and t["robustness"] <= 0 for t in tests)
    if suite.keep_paths:
        paths = [d["paths"] for d in designs]
        assert all(len(p["nominal"]) > 100 for p in paths)


@pytest.mark.slow
def test_table_one_marks_the_best_of_each_column(smoke_runs: dict[str, Path]) -> None:
    table = pd.read_csv(smoke_runs["robustness"] / "report" / "table1.csv")
    assert list(table["label"]) == ["pure confidence", "free energy", "pure performance"]
    assert table.loc[table["robustness_best"], "robustness"].iloc[0] == table["robustness"].max()
    assert table.loc[table["accuracy_best"], "accuracy"].iloc[0] == table["accuracy"].max()
    best = table.loc[table["control_deviation_best"], "control_deviation"].iloc[0]
    assert best == table["control_deviation"].min()
    assert (table["robustness_low"] <= table["robustness"]).all()
    assert (table["robustness"] <= table["robustness_high"]).all()
    # One bold mean per column, more only where means tie exactly (variants that found the same
    # design in a run this small).
    flags = table[["robustness_best", "accuracy_best", "control_deviation_best"]]
    assert (flags.sum() >= 1).all()
    bold = (smoke_runs["robustness"] / "report" / "table1.md").read_text().count("**")
    assert bold == 2 * int(flags.to_numpy().sum())


@pytest.mark.slow
@pytest.mark.parametrize("name", PAPER_SUITES)
def test_report_regenerates_identical_tables_from_the_stored_results(
    smoke_runs: dict[str, Path], name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = smoke_runs[name]
    report = folder / "report"
    before = {p.name: p.read_bytes() for p in report.iterdir() if p.suffix in (".csv", ".md")}
    # From the run folder as it is ...
    assert main(["report", str(folder)]) == 0
    assert "report files written" in capsys.readouterr().out
    after = {p.name: p.read_bytes() for p in report.iterdir() if p.suffix in (".csv", ".md")}
    assert after == before
    # ... and from a copy without the part files: manifest, consolidated log and designs only.
    shared = tmp_path / "shared"
    shared.mkdir()
    for item in ("manifest.json", "evaluations.parquet", "evaluations.csv"):
        if (folder / item).is_file():
            (shared / item).write_bytes((folder / item).read_bytes())
    for design in (folder / "designs").rglob("*.json"):
        target = shared / design.relative_to(folder)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(design.read_bytes())
    files = make_suite_report(shared)
    rebuilt = {p.name: p.read_bytes() for p in files if p.suffix in (".csv", ".md")}
    assert rebuilt == before


def test_a_size_of_the_files_own_works_over_a_base(tmp_path):
    """[sizes.quick] over base = "optimizers": the base at full size, then the file's quick."""
    path = tmp_path / "quick.toml"
    path.write_text('base = "optimizers"\nname = "q"\n[sizes.quick]\nn_seeds = 2\niterations = 2\n')
    quick = load_suite(path, size="quick")
    assert (quick.n_seeds, quick.iterations) == (2, 2)
    assert quick.batch_size == load_suite(path).batch_size  # the rest from the base's full size


def test_a_null_setting_cannot_go_to_toml_and_the_message_says_where_and_what_instead(tmp_path):
    from benchmarks.suites.config import OptimizerSpec
    from benchmarks.suites.files import save_suite

    suite = builtin_suite("optimizers", "smoke").replace(
        optimizers=(OptimizerSpec(name="cmaes", settings={"x0": None}),)
    )
    with pytest.raises(ValueError, match=r"optimizers\[0\]\.settings\.x0 = null .* as \.json"):
        save_suite(suite, tmp_path / "s.toml")
    assert not (tmp_path / "s.toml").exists()
    assert load_suite(save_suite(suite, tmp_path / "s.json")) == suite
