"""A third-party plugin installed with pip is found through its entry point and conforms.

The fixture package ``tests/fixtures/external_plugin`` declares nothing but an entry point
``hillclimb = "tooldesign_hillclimb:HillClimb"`` in the group ``tooldesign.optimizers``.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FIXTURE = ROOT / "tests" / "fixtures" / "external_plugin"

CHECK = textwrap.dedent(
    """
    import functools, json, sys
    import optimizers
    from optimizers.testing import check_optimizer

    names = optimizers.available()
    loaded_before_make = "tooldesign_hillclimb" in sys.modules
    check_optimizer(functools.partial(optimizers.make, "hillclimb"))
    optimizer = optimizers.make("hillclimb", bounds=[[0.0, 1.0], [-1.0, 1.0]], seed=0, step=0.1)
    print(json.dumps({
        "names": names,
        "loaded_before_make": loaded_before_make,
        "class": type(optimizer).__module__ + ":" + type(optimizer).__name__,
    }))
    """
)


def install_plugin(tmp_path: Path) -> Path:
    """pip-install the fixture plugin into a private folder; returns the folder."""
    source = tmp_path / "external_plugin"
    shutil.copytree(FIXTURE, source)  # a build writes into the source folder: keep the repo clean
    site = tmp_path / "site"
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--quiet",
            "--no-deps",
            "--no-index",  # everything needed is installed: no network
            "--no-build-isolation",
            "--disable-pip-version-check",
            "--target",
            str(site),
            str(source),
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    return site


@pytest.mark.slow
def test_a_pip_installed_plugin_is_available_and_passes_the_conformance_suite(
    tmp_path: Path,
) -> None:
    site = install_plugin(tmp_path)
    result = subprocess.run(
        [sys.executable, "-c", CHECK],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": os.pathsep.join([str(site), str(ROOT)])},
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stderr
    out = json.loads(result.stdout)
    assert "hillclimb" in out["names"] and "cmaes" in out["names"]
    assert out["loaded_before_make"] is False  # listed from metadata, imported only when made
    assert out["class"] == "tooldesign_hillclimb:HillClimb"


@pytest.mark.slow
def test_a_pip_installed_plugin_runs_tooldesign_design_to_the_end(tmp_path: Path) -> None:
    site = install_plugin(tmp_path)
    out = tmp_path / "run"
    argv = [
        "design",
        "--optimizer",
        "hillclimb",
        "--seed",
        "0",
        "--iterations",
        "2",
        "--batch-size",
        "2",
        "--executor",
        "serial",
        "--no-progress",
        "--out",
        str(out),
    ]
    code = f"from benchmarks.cli import main; raise SystemExit(main({argv!r}))"
    result = subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": os.pathsep.join([str(site), str(ROOT)])},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    card = json.loads((out / "design.json").read_text())
    assert "hillclimb" in json.dumps(card)
    assert (out / "tool.stl").stat().st_size > 0
