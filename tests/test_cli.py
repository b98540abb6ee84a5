"""The dispatcher: light top-level help and version, help texts that say what is accepted."""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import warnings
from pathlib import Path

import pandas as pd
import pytest

from benchmarks.cli import COMMANDS, build_parser, main
from benchmarks.cli._warnings import warnings_as_lines
from optimizers import registry


def _subparsers(parser: argparse.ArgumentParser) -> argparse._SubParsersAction:
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))


@pytest.mark.slow
def test_top_level_help_and_version_import_no_heavy_module():
    code = (
        "import sys\nfrom benchmarks.cli import main\n"
        "for argv in (['--help'], ['--version']):\n"
        "    try:\n        main(argv)\n    except SystemExit as e:\n        assert e.code == 0\n"
        "print(sorted(m for m in ('pybullet', 'matplotlib', 'pandas', 'scipy', 'torch')"
        " if m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.rstrip().endswith("[]"), out.stdout
    assert "tooldesign 0." in out.stdout
    for name in COMMANDS:
        assert name in out.stdout


@pytest.mark.slow
@pytest.mark.parametrize("command", list(COMMANDS))
def test_every_subcommands_help_imports_no_simulation_plotting_or_torch(command):
    # Each took 2-5 s: its module imported PyBullet and Matplotlib to build its arguments (an
    # audit of issue 11). Checked by what is imported, which does not depend on the machine.
    code = (
        "import sys\nfrom benchmarks.cli import main\n"
        f"try:\n    main([{command!r}, '--help'])\nexcept SystemExit as e:\n"
        "    assert e.code == 0, e.code\n"
        "print(sorted(m for m in ('pybullet', 'matplotlib', 'torch') if m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert f"usage: tooldesign {command}" in out.stdout
    assert out.stdout.rstrip().endswith("[]"), out.stdout.splitlines()[-1]


@pytest.mark.slow
def test_the_help_constants_agree_with_the_suites_they_name():
    from benchmarks.cli import _common
    from benchmarks.rl import RL_SUITE_NAME, SIZES
    from benchmarks.suites import BUILTIN_SUITES
    from benchmarks.suites import SIZES as SUITE_SIZES
    from benchmarks.suites.retest import RetestConfig

    assert _common.BUILTIN_SUITES == BUILTIN_SUITES
    assert _common.SIZES == SUITE_SIZES
    assert _common.RL_SUITE_NAME == RL_SUITE_NAME
    assert _common.RL_SIZES == tuple(SIZES)
    defaults = RetestConfig()
    assert (_common.RETEST_NUDGES, _common.RETEST_REPEATS) == (defaults.nudges, defaults.repeats)


def test_the_stub_help_lines_match_the_subcommands_own():
    full = _subparsers(build_parser())
    lines = {a.dest: a.help for a in full._choices_actions}
    assert lines == {name: help_line for name, (_, help_line) in COMMANDS.items()}


def test_build_parser_refuses_an_unknown_command():
    with pytest.raises(ValueError, match="unknown command 'frob'"):
        build_parser("frob")


@pytest.mark.slow
def test_design_help_lists_every_available_optimizer(capsys):
    with pytest.raises(SystemExit):
        main(["design", "--help"])
    # argparse wraps at hyphens ("optuna-" / "cmaes"): undo the wrapping before looking.
    text = re.sub(r"-\s+", "-", " ".join(capsys.readouterr().out.split()))
    for name in registry.available():
        assert name in text


@pytest.mark.slow
def test_evaluate_help_has_no_raw_markup(capsys):
    with pytest.raises(SystemExit):
        main(["evaluate", "--help"])
    text = capsys.readouterr().out
    assert "``" not in text and "--outside-bounds" in text


@pytest.mark.slow
@pytest.mark.parametrize("error", ["lost", "mismatch"])
def test_a_lost_or_mismatched_dask_cluster_is_one_line(monkeypatch, capsys, error):
    # Neither is a design's failure: the command stops with exit 1 and one line, no traceback.
    import benchmarks.cli.evaluate as evaluate
    from benchmarks.cli import main
    from benchmarks.execution.errors import ClusterLost, ClusterMismatch

    def fail(args):
        raise ClusterLost("scheduler gone") if error == "lost" else ClusterMismatch("worker w")

    monkeypatch.setattr(evaluate, "_run", fail)
    with pytest.raises(SystemExit) as exit_info:
        main(["evaluate", "--coeffs", "0", "0", "0", "--out", "unused"])
    assert exit_info.value.code == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "error:" in err


@pytest.mark.slow
def test_a_design_run_whose_every_evaluation_fails_ends_in_one_line(
    tmp_path, monkeypatch, capsys
):
    # It ended in a RuntimeError traceback (an audit of issue 10).
    from tooldesign_env import ToolDesignEnv

    def broken(self, action):
        raise RuntimeError("no simulation survives this setting")

    monkeypatch.setattr(ToolDesignEnv, "step", broken)
    out = tmp_path / "run"
    argv = ["design", "--iterations", "1", "--batch-size", "2", "--executor", "serial"]
    with pytest.raises(SystemExit) as excinfo, pytest.warns(RuntimeWarning, match="failed"):
        main([*argv, "--no-progress", "--out", str(out)])
    assert excinfo.value.code == 1
    err = capsys.readouterr().err
    assert "no design of the run could be evaluated" in err and "Traceback" not in err
    log = pd.read_csv(next(out.rglob("*.csv")))
    assert set(log["status"]) == {"failed"} and len(log) == 2  # the log says why


@pytest.mark.slow
def test_design_refuses_an_empty_optimizer_name(tmp_path, capsys):
    # "" ran CMA-ES without a word (an audit of issue 11).
    out = tmp_path / "z"
    with pytest.raises(SystemExit) as excinfo:
        main(["design", "--optimizer", "", "--iterations", "1", "--out", str(out)])
    assert excinfo.value.code == 2
    err = capsys.readouterr().err
    assert "--optimizer" in err and "''" in err and "cmaes" in err
    assert not out.exists()


@pytest.mark.slow
@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--goal", "nan", "1", "0.1"], "--goal x must be a finite number in [-2.5, 2.5] m"),
        (["--goal", "inf", "1", "0.1"], "--goal x must be a finite number in [-2.5, 2.5] m"),
        (["--box-mass", "nan"], "--box-mass must be a finite mass in kg, > 0 and <= 1000"),
    ],
)
def test_design_with_a_policy_names_a_bad_goal_or_mass_as_without(
    flags, message, tmp_path, capsys
):
    # With --policy they were refused as "optimizer_settings['goal'] must be a JSON value"
    # (an audit of issue 11).
    policy = Path(__file__).resolve().parents[1] / "docs/results/square/rl/policies/ppo.json"
    for designer in (["--policy", str(policy)], []):
        with pytest.raises(SystemExit) as excinfo:
            main(["design", *designer, *flags, "--out", str(tmp_path / "x")])
        assert excinfo.value.code == 2
        err = capsys.readouterr().err
        assert message in err and "optimizer_settings" not in err, err
    assert not (tmp_path / "x").exists()


def test_warnings_as_lines_changes_only_the_format_and_only_within_the_block():
    before = warnings.formatwarning
    with warnings_as_lines("tooldesign x"):
        shown = warnings.formatwarning("a bad value", UserWarning, "/src/f.py", 3, "warn(...)")
        assert shown == "tooldesign x: warning: a bad value\n"
        # Which warnings are raised, and recording them, are as before.
        with pytest.warns(UserWarning, match="still a warning"):
            warnings.warn("still a warning", UserWarning, stacklevel=1)
    assert warnings.formatwarning is before
    assert "f.py:3: UserWarning: m" in warnings.formatwarning("m", UserWarning, "f.py", 3, "")
    with pytest.raises(KeyError), warnings_as_lines("tooldesign x"):
        raise KeyError("boom")
    assert warnings.formatwarning is before


_WORKER_WARNS = """\
import functools, sys, warnings
from benchmarks.cli._warnings import warnings_as_lines
from benchmarks.execution import make_executor, map_robust

if __name__ == "__main__":
    warn = functools.partial(warnings.warn, "from a worker", RuntimeWarning)
    with warnings_as_lines("tooldesign x"), make_executor("process", workers=1) as pool:
        assert map_robust(pool, warn, [1])[0].error is None
    print("--", file=sys.stderr, flush=True)
    with make_executor("process", workers=1) as pool:  # no one-line format in the parent
        assert map_robust(pool, warn, [1])[0].error is None
"""


@pytest.mark.slow
def test_process_pool_workers_write_a_warning_as_the_parents_one_line(tmp_path):
    # The workers (forkserver or spawn) do not inherit warnings.formatwarning: the pool hands
    # them the prefix. The worker's stderr is the test process's, so it runs in a subprocess.
    script = tmp_path / "worker_warns.py"
    script.write_text(_WORKER_WARNS)
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    in_block, _, outside = done.stderr.partition("--\n")
    assert in_block == "tooldesign x: warning: from a worker\n", done.stderr
    assert "RuntimeWarning: from a worker" in outside and "tooldesign" not in outside, outside


@pytest.mark.slow
def test_a_command_writes_a_warning_as_one_line_on_stderr(tmp_path):
    # A suite whose optimizer is not importable here is dumped with a warning (not in-process:
    # pytest records warnings instead of writing them).
    suite = tmp_path / "suite.toml"
    suite.write_text('name = "x"\n[[optimizers]]\nname = "no_such_module:Optimizer"\n')
    code = "import sys; from benchmarks.cli import main; sys.exit(main(sys.argv[1:]))"
    argv = ["bench", "--config", str(suite), "--out", "unused", "--dump-config"]
    done = subprocess.run(
        [sys.executable, "-c", code, *argv, str(tmp_path / "x.toml")],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    assert done.stderr.startswith("tooldesign bench: warning: the settings of optimizer ")
    assert done.stderr.count("\n") == 1 and "UserWarning" not in done.stderr, done.stderr
