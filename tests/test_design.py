"""Tests of benchmarks.design (Algorithm 1, the run folder, resume) and benchmarks.execution."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_kill import run_until

from benchmarks.cli import main
from benchmarks.design import DESIGN_SUITE, DesignConfig, run_design
from benchmarks.design import loop as design_loop
from benchmarks.design import stepper as design_stepper
from benchmarks.execution import (
    EvaluationRequest,
    SerialExecutor,
    TaskSettings,
    evaluate_batch,
    evaluate_design,
    make_executor,
    map_robust,
)
from benchmarks.reports import write_design_report
from benchmarks.storage import (
    DESIGN_RUN_FILES as FILES,
)
from benchmarks.storage import (
    PART_CHECKSUMS,
    ResultStore,
    ResumeError,
    Unit,
    file_sha256,
)

CONFIG = DesignConfig(optimizer="cmaes", seed=0, iterations=2, batch_size=4, executor="serial")
TIMING = ["eval_time", "opt_time"]
ROOT = Path(__file__).resolve().parents[1]

# A straight tool, a hook, a curve that misses, and a tool that overlaps the box at the start.
DESIGNS = [(0.0, 0.0, 0.0), (1.0, -1.0, 0.3), (-1.2, 0.8, -0.2), (1.5, 1.5, 0.5)]


def cli_args(out: Path, *extra: str) -> list[str]:
    return [
        "design",
        "--optimizer",
        CONFIG.optimizer,
        "--seed",
        str(CONFIG.seed),
        "--iterations",
        str(CONFIG.iterations),
        "--batch-size",
        str(CONFIG.batch_size),
        "--executor",
        "serial",
        "--out",
        str(out),
        "--no-progress",
        *extra,
    ]


def _unit(iteration: int) -> Unit:
    return Unit(
        suite=DESIGN_SUITE, optimizer=CONFIG.optimizer, seed=CONFIG.seed, iteration=iteration
    )


def without_timings(frame: pd.DataFrame) -> pd.DataFrame:
    return frame.drop(columns=TIMING).reset_index(drop=True)


def card(folder: Path) -> dict:
    return json.loads((folder / FILES["card"]).read_text())


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    out = tmp_path_factory.mktemp("design") / "reference"
    result = run_design(CONFIG, out, progress=False)
    write_design_report(out)  # what `tooldesign design` does after the run
    return out, result


# --- the run folder ----------------------------------------------------------------------------


@pytest.mark.slow
def test_short_run_writes_every_file(reference) -> None:
    out, result = reference
    for key, name in FILES.items():
        if key == "video":  # only with video=True (tooldesign design without --no-video)
            continue
        path = out / name
        assert path.is_file() and path.stat().st_size > 0, name
    assert (out / "manifest.json").is_file()
    for key in ("fig3", "fig3a", "fig3b", "fig3c", "fig3d", "robustness_png"):
        assert (out / FILES[key]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (out / FILES["obj"]).read_text().startswith("# tooldesign tool")
    assert "<robot" in (out / FILES["urdf"]).read_text()
    # Binary STL: 80-byte header, triangle count, 50 bytes per triangle.
    stl = (out / FILES["stl"]).read_bytes()
    assert len(stl) == 84 + 50 * int.from_bytes(stl[80:84], "little")

    log = pd.read_csv(out / FILES["evaluations"])
    assert len(log) == CONFIG.iterations * CONFIG.batch_size
    assert list(log.columns[:9]) == [
        "suite",
        "optimizer",
        "seed",
        "iteration",
        "candidate",
        "eval_id",
        "c1",
        "c2",
        "c3",
    ]
    assert set(log["status"]) <= {"ok", "invalid", "failed"}
    assert (log["eval_time"] > 0).all() and (log["opt_time"] >= 0).all()
    ok = log["status"] == "ok"
    assert np.isfinite(log.loc[ok, ["free_energy", "goal_error", "confidence"]]).all().all()
    assert log["iteration"].tolist() == [0] * 4 + [1] * 4

    robustness = json.loads((out / FILES["robustness"]).read_text())
    assert robustness["masses"] == [0.3, 0.5, 0.7, 0.9]
    assert robustness["robustness"] < 0 and robustness["control_deviation"] > 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["end_time"] is not None and manifest["config"]["seed"] == 0


@pytest.mark.slow
def test_card_holds_the_lowest_free_energy_of_the_log(reference) -> None:
    out, result = reference
    log = ResultStore(out).read()
    ok = log[log["status"] == "ok"]
    best = ok.loc[ok["free_energy"].idxmin()]
    data = card(out)
    assert data["free_energy"] == ok["free_energy"].min() == result.free_energy
    assert data["coefficients"] == best[["c1", "c2", "c3"]].tolist()
    assert data["goal_error"] - data["confidence"] == pytest.approx(data["free_energy"])
    assert data["final_distance"] == best["final_distance"]
    assert data["seed"] == CONFIG.seed and data["config"]["optimizer"] == "cmaes"
    assert {"numpy", "gymnasium", "pybullet"} <= set(data["packages"])
    assert data["evaluations"]["total"] == len(log)
    assert log["best_so_far"].iloc[-1] == data["free_energy"]
    np.testing.assert_array_equal(result.coefficients, data["coefficients"])


# --- resume ------------------------------------------------------------------------------------


def _compare_runs(a: Path, b: Path) -> None:
    pd.testing.assert_frame_equal(
        without_timings(ResultStore(a).read()), without_timings(ResultStore(b).read())
    )
    for key in ("coefficients", "free_energy", "goal_error", "confidence", "final_distance"):
        assert card(a)[key] == card(b)[key], key
    assert json.loads((a / FILES["robustness"]).read_text()) == json.loads(
        (b / FILES["robustness"]).read_text()
    )
    assert json.loads((a / FILES["box_paths"]).read_text()) == json.loads(
        (b / FILES["box_paths"]).read_text()
    )
    if not (b / FILES["fig3"]).exists():
        write_design_report(b)  # the API run writes data; the figures are drawn from them
    for key in ("stl", "obj", "urdf", "fig3a", "fig3c", "fig3d", "robustness_png"):
        assert (a / FILES[key]).read_bytes() == (b / FILES[key]).read_bytes(), key


@pytest.mark.slow
def test_resume_after_sigkill_equals_uninterrupted_run(reference, tmp_path: Path) -> None:
    ref, _ = reference
    out = tmp_path / "killed"
    unit = _unit(0)
    parts = ResultStore(out)
    # Killed in the middle of the ask/tell loop, after iteration 0 was logged ...
    run_until(cli_args(out), parts.part_path(unit))
    assert not (out / FILES["card"]).exists()
    # ... and again while the finished run writes its files (after the last iteration).
    last = parts.part_path(dataclasses.replace(unit, iteration=CONFIG.iterations - 1))
    run_until(cli_args(out, "--resume"), last)
    assert not (out / FILES["card"]).exists()
    assert main(cli_args(out, "--resume")) == 0
    _compare_runs(ref, out)
    manifest = json.loads((out / "manifest.json").read_text())
    assert len(manifest["extra"]["sessions"]) == 3


@pytest.mark.slow
def test_resume_after_keyboard_interrupt_equals_uninterrupted_run(
    reference, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    ref, _ = reference
    out = tmp_path / "interrupted"
    real = design_loop.evaluate_batch
    calls = []

    def interrupt_second_batch(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(design_loop, "evaluate_batch", interrupt_second_batch)
    with pytest.raises(KeyboardInterrupt):
        run_design(CONFIG, out, progress=False)
    assert len(ResultStore(out).completed_units()) == 1
    monkeypatch.setattr(design_loop, "evaluate_batch", real)
    with pytest.raises(ValueError, match="--resume"):
        run_design(CONFIG, out, progress=False)
    run_design(CONFIG, out, resume=True, progress=False)
    _compare_runs(ref, out)


@pytest.mark.slow
def test_resume_refuses_a_log_the_optimizer_does_not_replay(reference, tmp_path: Path) -> None:
    ref, _ = reference
    out = tmp_path / "tampered"
    shutil.copytree(ref, out)
    part = ResultStore(out).part_path(_unit(0))
    frame = pd.read_csv(part, keep_default_na=False, na_values=[""])
    frame.loc[0, "c1"] = np.nextafter(frame.loc[0, "c1"], np.inf)  # one bit off
    part.write_text(frame.to_csv(index=False, float_format=lambda v: repr(float(v))))
    # A tamperer who also fixes the checksum in the manifest is caught by the replay.
    manifest = json.loads((out / "manifest.json").read_text())
    relative = part.relative_to(out).as_posix()
    manifest["extra"][PART_CHECKSUMS][relative] = file_sha256(part)
    (out / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(ResumeError, match="replaying iteration 0"):
        run_design(CONFIG, out, resume=True, progress=False)


def _folder_bytes(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


@pytest.mark.slow
@pytest.mark.parametrize(
    ("tamper", "match"),
    [
        ("edit F", "has changed since it was written"),
        ("truncate", "has changed since it was written"),
        ("delete", "missing"),
        ("extra parts", "does not record"),
        ("no checksums", "records no part checksums"),
        ("old version", "incompatible version"),
        # Shared without parts/: the consolidated table is then the only copy of the log, so
        # it is original data, not rebuilt (the parts the manifest lists are missing, or, with
        # their record removed too, the table itself is named).
        ("table without parts", "iteration=000000.csv is listed in the manifest but missing"),
        ("table without recorded parts", "evaluations.csv has changed since it was written"),
    ],
)
def test_resume_refuses_a_tampered_folder_and_changes_nothing(
    reference, tmp_path: Path, tamper: str, match: str
) -> None:
    ref, _ = reference
    out = tmp_path / "tampered"
    shutil.copytree(ref, out)
    store = ResultStore(out)
    part = store.part_path(_unit(0))
    manifest = json.loads((out / "manifest.json").read_text())
    if tamper == "edit F":
        frame = pd.read_csv(part, keep_default_na=False, na_values=[""])
        frame.loc[0, "free_energy"] = -1e9  # a better score than any design reached
        part.write_text(frame.to_csv(index=False, float_format=lambda v: repr(float(v))))
    elif tamper == "truncate":
        part.write_bytes(part.read_bytes()[:-10])
    elif tamper == "delete":
        part.unlink()
    elif tamper == "extra parts":
        for k in (7, 8):
            other = store.part_path(_unit(k))
            other.write_bytes(part.read_bytes())
    elif tamper == "no checksums":
        del manifest["extra"][PART_CHECKSUMS]
    elif tamper.startswith("table without"):
        shutil.rmtree(store.parts_dir)
        table = out / FILES["evaluations"]
        table.write_bytes(table.read_bytes()[:100])
        if tamper == "table without recorded parts":
            manifest["extra"][PART_CHECKSUMS] = {}
    else:
        manifest["format_version"] = 0
    (out / "manifest.json").write_text(json.dumps(manifest))
    before = _folder_bytes(out)
    with pytest.raises(ResumeError, match=match):
        run_design(CONFIG, out, resume=True, progress=False)
    assert _folder_bytes(out) == before


@pytest.mark.slow
@pytest.mark.parametrize("damage", ["truncate", "delete"])
def test_resume_rebuilds_a_damaged_table_from_intact_parts(
    reference, tmp_path: Path, damage: str
) -> None:
    """Audit item 3: evaluations.csv is derived from the checksummed parts; it must not block."""
    ref, _ = reference
    out = tmp_path / "damaged"
    shutil.copytree(ref, out)
    table = out / FILES["evaluations"]
    if damage == "truncate":
        table.write_bytes(table.read_bytes()[:100])
    else:
        table.unlink()
    parts = {k: v for k, v in _folder_bytes(out).items() if k.startswith("parts")}
    message = "had changed since it was written" if damage == "truncate" else "was missing"
    with pytest.warns(RuntimeWarning, match=f"evaluations.csv {message}; rebuilt as "):
        run_design(CONFIG, out, resume=True, progress=False)
    assert table.read_bytes() == (ref / FILES["evaluations"]).read_bytes()
    assert {k: v for k, v in _folder_bytes(out).items() if k.startswith("parts")} == parts
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["extra"]["file_sha256"]["evaluations.csv"] == file_sha256(table)
    _compare_runs(ref, out)


@pytest.mark.slow
def test_resume_refuses_other_settings_and_foreign_folders(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("not a run")
    # The Python API is told its own word too (an audit of issue 11).
    with pytest.raises(ValueError, match=r"pass --resume \(API: resume=True\) .* another folder"):
        run_design(CONFIG, tmp_path, progress=False)
    with pytest.raises(ResumeError, match="no manifest.json"):
        run_design(CONFIG, tmp_path, resume=True, progress=False)


# --- failures ----------------------------------------------------------------------------------


@pytest.mark.slow
def test_an_exception_in_the_worker_is_a_failed_row() -> None:
    # Outside the action space: the env raises ValueError before simulating anything.
    row = evaluate_design(EvaluationRequest(coeffs=(9.0, 0.0, 0.0)))
    assert row["status"] == "failed"
    assert all(math.isnan(row[k]) for k in ("free_energy", "goal_error", "confidence"))
    assert "ValueError" in row["message"] and row["eval_time"] >= 0
    rows = evaluate_batch(SerialExecutor(), [(9.0, 0.0, 0.0), (0.0, 9.0, 0.0)], TaskSettings())
    assert [r["status"] for r in rows] == ["failed", "failed"]


@pytest.mark.slow
def test_a_crashed_worker_process_fails_only_its_own_item() -> None:
    # eval is a picklable builtin: one item kills its worker process, the others are fine.
    items = ["abs(-2)", "__import__('os')._exit(3)", "abs(-5)"]
    with make_executor("process", workers=2) as executor:
        outcomes = map_robust(executor, eval, items)
        assert [o[0] for o in outcomes] == [2, None, 5]
        assert type(outcomes[1][1]).__name__ == "WorkerDied"  # a BrokenProcessPool
        assert map_robust(executor, eval, ["1 + 1"])[0][:2] == (2, None)  # pool replaced


@pytest.mark.slow
def test_failed_designs_are_logged_and_told_as_failures(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    real_batch = design_loop.evaluate_batch
    real_make = design_stepper._make_optimizer
    told = []

    def fail_first_candidate(executor, designs, task, **kwargs):
        rows = real_batch(executor, designs, task, **kwargs)
        if not kwargs.get("keep_trajectory"):
            rows[0] = dict.fromkeys(("free_energy", "goal_error", "confidence"), math.nan)
            rows[0].update(final_distance=math.nan, status="failed", eval_time=0.1, message="x")
        return rows

    class Spy:
        def __init__(self, optimizer):
            self._optimizer = optimizer

        def ask(self):
            return self._optimizer.ask()

        def tell(self, ids, values):
            told.append(np.array(values, dtype=float))
            return self._optimizer.tell(ids, values)

    monkeypatch.setattr(design_loop, "evaluate_batch", fail_first_candidate)
    monkeypatch.setattr(design_stepper, "_make_optimizer", lambda c: Spy(real_make(c)))
    config = dataclasses.replace(CONFIG, iterations=1, batch_size=3)
    with pytest.warns(RuntimeWarning, match="candidate 0 failed"):
        result = run_design(config, tmp_path / "run", progress=False)
    log = result.evaluations
    assert log["status"].tolist()[0] == "failed" and math.isnan(log["free_energy"].iloc[0])
    assert math.isnan(told[0][0]) and np.isfinite(told[0][1:]).all()
    assert result.candidate != 0


# --- executors ---------------------------------------------------------------------------------


@pytest.mark.slow
def test_executors_give_identical_rows() -> None:
    task = TaskSettings(goal=(0.0, 1.5, 0.1), goal_precision=20.0)
    results = {}
    for kind in ("serial", "process", "dask"):
        with make_executor(kind, workers=2) as executor:
            rows = evaluate_batch(executor, DESIGNS, task)
        results[kind] = [{k: v for k, v in r.items() if k != "eval_time"} for r in rows]
    assert [r["status"] for r in results["serial"]] == ["ok", "ok", "ok", "invalid"]
    assert results["serial"] == results["process"] == results["dask"]


# --- bad input ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("changes", "error", "match"),
    [
        ({"iterations": 0}, ValueError, "iterations must be >= 1"),
        ({"batch_size": 2.5}, TypeError, "batch_size must be an int"),
        ({"seed": -1}, ValueError, "seed must be >= 0"),
        ({"workers": 0}, ValueError, "workers must be >= 1"),
        ({"executor": "threads"}, ValueError, "executor must be one of"),
        ({"scheduler": "tcp://localhost:8786"}, ValueError, "needs executor='dask'"),
        ({"goal": (0.0, 1.5)}, ValueError, "goal must be 3 numbers"),
        ({"goal": (0.0, math.nan, 0.1)}, ValueError, "goal must be finite"),
        ({"goal_precision": -1.0}, ValueError, "goal_precision"),
        ({"box_mass": 0.0}, ValueError, "box_mass must be > 0"),
        ({"estimator": "magic"}, ValueError, "estimator must be one of"),
        ({"bounds": ((1.0, -1.0),)}, ValueError, "low < high"),
        ({"optimizer": ""}, ValueError, "optimizer must be a non-empty name"),
        ({"optimizer_settings": {"sigma0": object()}}, TypeError, "JSON value"),
        ({"robustness_masses": (0.3, -1.0)}, ValueError, "masses"),
        ({"robustness_masses": {0.3, 0.5}}, TypeError, "robustness_masses: .* in order"),
    ],
)
def test_bad_config_is_a_clear_error(changes: dict, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        DesignConfig(**{**dataclasses.asdict(CONFIG), **changes})


@pytest.mark.slow
def test_bad_arguments_of_run_design(tmp_path: Path) -> None:
    with pytest.raises(TypeError, match="config must be a DesignConfig"):
        run_design({"iterations": 2}, tmp_path)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="out_dir must be a path"):
        run_design(CONFIG, 42)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="unknown optimizer 'nope'; available"):
        run_design(dataclasses.replace(CONFIG, optimizer="nope"), tmp_path / "x")
    assert not (tmp_path / "x").exists()  # nothing written for a run that cannot start


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        (["--optimizer", "nope"], "unknown optimizer 'nope'"),
        (["--goal-precision", "-1"], "goal_precision"),
        (["--batch-size", "0"], "batch_size must be >= 1"),
        (["--scheduler", "tcp://localhost:8786"], "needs executor='dask'"),
    ],
)
def test_bad_command_line_is_one_clear_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], match: str
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(cli_args(tmp_path / "run", *extra))
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("tooldesign design: error: ") and match in err[-1]


def test_non_empty_out_without_resume_is_an_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "keep.txt").write_text("x")
    with pytest.raises(SystemExit) as exit_info:
        main(cli_args(tmp_path))
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "pass --resume" in err and "choose another folder" in err
    assert sorted(os.listdir(tmp_path)) == ["keep.txt"]


@pytest.mark.slow
def test_bad_executor_arguments() -> None:
    with pytest.raises(ValueError, match="executor kind must be one of"):
        with make_executor("gpu"):
            pass
    with pytest.raises(ValueError, match="workers must be >= 1"):
        with make_executor("process", workers=0):
            pass
    with pytest.raises(TypeError, match="coeffs must be"):
        EvaluationRequest(coeffs="abc")
    with pytest.raises(ValueError, match="estimator"):
        TaskSettings(estimator="none")


# --- every registered optimizer, on an analytic score ------------------------------------------


def _analytic_rows(executor, designs, task, **kwargs):
    """Rows of a fake evaluator: F = |C|^2 - 1, with one invalid design; no simulation."""
    rows = []
    for coeffs in np.asarray(designs, dtype=float):
        energy = float(np.sum(coeffs**2)) - 1.0
        row = {"free_energy": energy, "goal_error": energy + 1.0, "confidence": 1.0}
        row.update(final_distance=float(np.abs(coeffs).sum()), eval_time=0.001, message="")
        row["status"] = "invalid" if coeffs[0] > 1.4 else "ok"
        if kwargs.get("keep_trajectory"):
            row["box_trajectory"] = np.linspace([1.2, 0.7, 0.1], [0.0, 1.2, 0.1], 5)
        rows.append(row)
    return rows


def _fake_robustness(executor, fn, requests):
    path = np.linspace([1.2, 0.7, 0.1], [0.0, 1.2, 0.1], 5)
    result = {
        "robustness": -1.0,
        "accuracy": -2.0,
        "control_deviation": 3.0,
        "nominal_mass": 0.1,
        "masses": list(requests[0].masses),
        "nominal_box_trajectory": path,
        "box_trajectories": [path] * len(requests[0].masses),
    }
    return [(result, None, 0.0)]


def _optimizer_names() -> list[str]:
    import optimizers

    return optimizers.available()


@pytest.mark.slow
@pytest.mark.parametrize("name", _optimizer_names())
def test_every_optimizer_resumes_to_the_uninterrupted_run(
    name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(design_loop, "evaluate_batch", _analytic_rows)
    monkeypatch.setattr(design_loop, "map_robust", _fake_robustness)
    config = dataclasses.replace(CONFIG, optimizer=name, iterations=4, seed=3)
    whole = run_design(config, tmp_path / "whole", progress=False)

    calls = []

    def interrupt_third_batch(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return _analytic_rows(*args, **kwargs)

    monkeypatch.setattr(design_loop, "evaluate_batch", interrupt_third_batch)
    with pytest.raises(KeyboardInterrupt):
        run_design(config, tmp_path / "resumed", progress=False)
    monkeypatch.setattr(design_loop, "evaluate_batch", _analytic_rows)
    resumed = run_design(config, tmp_path / "resumed", resume=True, progress=False)
    pd.testing.assert_frame_equal(
        without_timings(whole.evaluations), without_timings(resumed.evaluations)
    )
    assert (
        whole.free_energy
        == resumed.free_energy
        == whole.evaluations.query("status == 'ok'")["free_energy"].min()
    )
    # Another seed asks other designs.
    other = run_design(dataclasses.replace(config, seed=4), tmp_path / "other", progress=False)
    assert not np.array_equal(
        other.evaluations[["c1", "c2", "c3"]], whole.evaluations[["c1", "c2", "c3"]]
    )


@pytest.mark.slow
def test_the_manifest_records_the_cards_and_tests_checksums(reference, tmp_path: Path) -> None:
    """design.json, robustness.json and box_paths.json are recorded; an edit is refused."""
    from benchmarks.cli import main

    ref, _ = reference
    recorded = json.loads((ref / "manifest.json").read_text())["extra"]["file_sha256"]
    for key in ("card", "robustness", "box_paths"):
        assert recorded[FILES[key]] == file_sha256(ref / FILES[key]), key
    out = tmp_path / "edited"
    shutil.copytree(ref, out)
    # A change that keeps the file's form: only the checksum can tell.
    robustness = json.loads((out / FILES["robustness"]).read_text())
    robustness["robustness"] = float(robustness["robustness"]) + 1.0
    (out / FILES["robustness"]).write_text(json.dumps(robustness))
    with pytest.raises(SystemExit) as exit_:
        main(["report", str(out)])
    assert exit_.value.code == 2
    with pytest.raises(ResumeError, match="robustness.json"):
        run_design(CONFIG, out, resume=True, progress=False)
    # A resumed session that writes them again records their new checksums.
    longer = tmp_path / "longer"
    shutil.copytree(ref, longer)
    run_design(dataclasses.replace(CONFIG, iterations=3), longer, resume=True, progress=False)
    recorded = json.loads((longer / "manifest.json").read_text())["extra"]["file_sha256"]
    for key in ("card", "robustness", "box_paths"):
        assert recorded[FILES[key]] == file_sha256(longer / FILES[key]), key
