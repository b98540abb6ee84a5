"""A refused start leaves no run folder, and every refusal says what to do instead."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import benchmarks.reports as reports
from benchmarks.cli import main
from benchmarks.design import DESIGN_SUITE, DesignConfig, run_design
from benchmarks.reports.comparison import _pairwise_markdown
from benchmarks.storage import RunSession
from benchmarks.suites import builtin_suite
from benchmarks.suites.runner import run_suite


@pytest.fixture
def no_dask(monkeypatch):
    """dask.distributed as if it were not installed."""
    monkeypatch.setitem(sys.modules, "distributed", None)


def _run_script(tmp_path: Path, source: str) -> subprocess.CompletedProcess[str]:
    script = tmp_path / "script.py"
    script.write_text(textwrap.dedent(source))
    return subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=300
    )


# --- 1. the __main__ guard of run_suite --------------------------------------------------------


@pytest.mark.slow
def test_an_unguarded_suite_script_is_refused_naming_run_suite_and_leaves_no_folder(tmp_path):
    run = tmp_path / "run"
    source = f"""
    from benchmarks.suites import builtin_suite, run_suite
    run_suite(builtin_suite("optimizers", "smoke"), {str(run)!r}, progress=False)
    """
    out = _run_script(tmp_path, source)
    assert out.returncode != 0
    assert "has no 'if __name__ == \"__main__\":' guard" in out.stderr
    assert "run_suite(...)" in out.stderr
    assert "run_design" not in out.stderr
    assert not run.exists()


@pytest.mark.slow
def test_the_guard_message_names_the_function_called(tmp_path):
    source = """
    from benchmarks.execution import check_main_guard
    check_main_guard("process", function="run_rl_suite")
    """
    out = _run_script(tmp_path, source)
    assert "run_rl_suite(...)" in out.stderr
    assert "run_design" not in out.stderr


@pytest.mark.slow
def test_an_unguarded_rl_suite_script_with_workers_leaves_no_folder(tmp_path):
    run = tmp_path / "run"
    source = f"""
    import dataclasses
    from benchmarks.rl import rl_suite_config, run_rl_suite
    config = dataclasses.replace(rl_suite_config("smoke"), workers=2)
    run_rl_suite(config, {str(run)!r})
    """
    out = _run_script(tmp_path, source)
    assert out.returncode != 0
    assert "run_rl_suite(...)" in out.stderr
    assert not run.exists()


@pytest.mark.slow
def test_the_docs_run_suite_example_has_the_guard():
    text = (Path(__file__).resolve().parents[1] / "docs" / "benchmarks.md").read_text()
    start = text.index("from benchmarks.suites import OptimizerSpec")
    example = text[start : text.index("```", start)]
    guard = example.index('if __name__ == "__main__":')
    assert example.index("\n    result = run_suite(") > guard
    assert "\nresult = run_suite(" not in example


# --- 3. a missing dask leaves no folder ---------------------------------------------------------


@pytest.mark.slow
def test_a_design_run_without_dask_leaves_no_folder(tmp_path, no_dask):
    run = tmp_path / "run"
    config = DesignConfig(iterations=1, batch_size=2, executor="dask")
    with pytest.raises(ImportError, match="tooldesign\\[dask\\]"):
        run_design(config, run, progress=False)
    assert not run.exists()


@pytest.mark.slow
def test_a_suite_run_without_dask_leaves_no_folder(tmp_path, no_dask):
    run = tmp_path / "run"
    suite = builtin_suite("optimizers", "smoke").replace(executor="dask")
    with pytest.raises(ImportError, match="tooldesign\\[dask\\]"):
        run_suite(suite, run, progress=False)
    assert not run.exists()


@pytest.mark.slow
def test_the_design_command_without_dask_can_be_retried(tmp_path, capsys, no_dask):
    run = tmp_path / "run"
    args = ["design", "--iterations", "1", "--batch-size", "2", "--out", str(run)]
    with pytest.raises(SystemExit) as exit_:
        main([*args, "--executor", "dask", "--no-progress"])
    assert exit_.value.code == 2
    assert "tooldesign[dask]" in capsys.readouterr().err
    assert not run.exists()


# --- 2. report on a design folder ---------------------------------------------------------------


def _folder(path: Path, kind: str) -> Path:
    RunSession(path, kind=kind, config={"x": 1}, resume=False).checkpoint()
    return path


@pytest.mark.slow
def test_report_on_a_design_folder_redraws_its_own_figures(tmp_path, monkeypatch, capsys):
    import benchmarks.reports.design_figures as design_figures

    folder = _folder(tmp_path / "design", DESIGN_SUITE)
    calls = []
    checked = object()  # what the report checked first, handed on to the figures
    monkeypatch.setattr(design_figures, "read_design_run", lambda f: checked)
    monkeypatch.setattr(reports, "make_suite_report", lambda f, out_dir=None: [])
    monkeypatch.setattr(
        reports,
        "write_design_report",
        lambda f, checked=None: calls.append((Path(f), checked)) or [Path(f) / "x.png"],
    )
    assert main(["report", str(folder)]) == 0
    assert calls == [(folder, checked)]
    assert "design figures" in capsys.readouterr().out


@pytest.mark.slow
def test_report_on_a_real_design_folder_brings_back_its_figures_and_page(tmp_path, capsys):
    folder = tmp_path / "design"
    config = DesignConfig(iterations=1, batch_size=2, executor="serial")
    run_design(config, folder, progress=False)
    for name in ("figure3.png", "robustness.png", "fig3a_tool_curves.png"):
        assert not (folder / name).exists()  # run_design draws no figure
    assert main(["report", str(folder)]) == 0
    page = (folder / "report.html").read_text(encoding="utf-8")
    for name in ("figure3.png", "robustness.png", "fig3a_tool_curves.png"):
        assert (folder / name).is_file()
    assert "figure3" in page
    assert "retest` on the folder" not in (folder / "report" / "pairwise.md").read_text()


@pytest.mark.slow
def test_report_on_a_suite_folder_does_not_draw_design_figures(tmp_path, monkeypatch):
    folder = _folder(tmp_path / "suite", "suite")
    monkeypatch.setattr(reports, "make_suite_report", lambda f, out_dir=None: [])
    monkeypatch.setattr(reports, "write_design_report", lambda f: pytest.fail("drawn"))
    assert main(["report", str(folder)]) == 0


@pytest.mark.slow
def test_no_noise_floor_hint_does_not_send_a_design_folder_to_retest():
    import pandas as pd

    text = _pairwise_markdown(pd.DataFrame(), 0.05, None)
    assert "suite run folder" in text


# --- 4. folders of another kind -----------------------------------------------------------------


@pytest.mark.slow
def test_retest_on_a_design_folder_names_it_its_kind_and_the_command(tmp_path, capsys):
    folder = _folder(tmp_path / "design", DESIGN_SUITE)
    with pytest.raises(SystemExit):
        main(["retest", str(folder)])
    err = capsys.readouterr().err
    assert str(folder) in err
    assert "a design run folder" in err
    assert "tooldesign report" in err


@pytest.mark.slow
def test_retest_on_a_folder_without_manifest_says_it_is_no_suite_folder(tmp_path, capsys):
    folder = tmp_path / "evaluated"
    folder.mkdir()
    (folder / "terms.json").write_text("{}")
    with pytest.raises(SystemExit):
        main(["retest", str(folder)])
    err = capsys.readouterr().err
    assert f"{folder} has no manifest.json" in err
    assert "tooldesign bench" in err


@pytest.mark.slow
def test_design_resume_on_a_suite_folder_names_its_kind_and_another_folder(tmp_path):
    folder = _folder(tmp_path / "suite", "suite")
    config = DesignConfig(iterations=1, batch_size=2, executor="serial")
    with pytest.raises(ValueError) as error:
        run_design(config, folder, resume=True, progress=False)
    message = str(error.value)
    assert str(folder) in message
    assert "a suite run folder" in message
    assert "tooldesign bench" in message
    assert "choose another folder" in message


# --- 5. Ctrl-C says how to go on ----------------------------------------------------------------


@pytest.mark.parametrize(
    ("command", "module", "hint"),
    [
        (["design", "--out", "x"], "benchmarks.cli.design", "same command and --resume"),
        (["bench", "optimizers", "--out", "x"], "benchmarks.cli.bench", "it resumes"),
    ],
)
def test_an_interrupt_says_how_to_continue(monkeypatch, capsys, command, module, hint):
    import importlib

    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(importlib.import_module(module), "_run", interrupted)
    assert main(command) == 130
    err = capsys.readouterr().err
    assert "interrupted" in err
    assert hint in err


@pytest.mark.slow
def test_a_scheduler_that_does_not_answer_says_how_to_start_one(tmp_path, monkeypatch):
    distributed = pytest.importorskip("distributed")

    def no_answer(address, *args, **kwargs):
        raise OSError(f"Timed out trying to connect to {address} after 30 s")

    monkeypatch.setattr(distributed, "Client", no_answer)
    run = tmp_path / "run"
    config = DesignConfig(
        iterations=1, batch_size=2, executor="dask", scheduler="tcp://127.0.0.1:1"
    )
    with pytest.raises(OSError, match="start a scheduler with `dask scheduler`") as error:
        run_design(config, run, progress=False)
    assert "tcp://127.0.0.1:1" in str(error.value)
    assert not run.exists()
