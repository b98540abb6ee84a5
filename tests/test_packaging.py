"""The generic import names resolve to this project, the wheel holds the packages and nothing
else (no developer script of perf/), and the docs build without warnings."""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("name", ["tooldesign_env", "optimizers", "benchmarks"])
def test_top_level_packages_are_this_projects(name):
    module = __import__(name)
    assert Path(module.__file__).resolve().parent == ROOT / name


def _packages_setuptools_installs(root: Path) -> list[str]:
    """The packages ``pip install`` takes from ``root``, found as pyproject.toml says."""
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - Python 3.10
        import tomli as tomllib
    from setuptools import find_packages

    find = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]
    return find_packages(where=str(root), **find["find"])


def test_the_perf_scripts_are_not_installed():
    """perf/ (the developer scripts) sits beside the packages but is no part of the wheel."""
    assert (ROOT / "perf" / "__init__.py").is_file()
    packages = _packages_setuptools_installs(ROOT)
    assert {"tooldesign_env", "optimizers", "benchmarks", "benchmarks.rl"} <= set(packages)
    tops = {"tooldesign_env", "optimizers", "benchmarks"}
    assert [p for p in packages if p.split(".")[0] not in tops] == []
    assert not any(p == "perf" or ".perf" in p or p.startswith("perf.") for p in packages)


def test_console_script_is_installed():
    exe = shutil.which("tooldesign")
    assert exe is not None, "pip install -e . should install the 'tooldesign' command"
    out = subprocess.run([exe, "--help"], capture_output=True, text=True, check=True)
    assert "evaluate" in out.stdout


@pytest.mark.slow
def test_docs_build_strict(tmp_path):
    out = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path)],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr


@pytest.mark.slow
def test_a_built_wheel_holds_every_file_the_packages_read(tmp_path):
    """A normal (not editable) install must carry the data files, e.g. the rl baselines' configs."""
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "setup.py", "README.md", "LICENSE"):
        shutil.copy2(ROOT / name, src / name)
    packages = ("tooldesign_env", "optimizers", "benchmarks")
    skip = shutil.ignore_patterns("__pycache__", "*.pyc", "*.so")
    for name in (*packages, "perf"):  # perf/ is beside the packages, as in a checkout
        shutil.copytree(ROOT / name, src / name, ignore=skip)
    command = [sys.executable, "-m", "pip", "wheel", str(src), "--no-deps", "-q"]
    command += ["-w", str(tmp_path / "wheel")]
    if importlib.util.find_spec("setuptools") is not None:
        command.append("--no-build-isolation")  # offline when the venv has setuptools
    subprocess.run(command, check=True, capture_output=True, cwd=tmp_path)
    (wheel,) = (tmp_path / "wheel").glob("*.whl")
    with zipfile.ZipFile(wheel) as archive:
        names = set(archive.namelist())
        archive.extractall(tmp_path / "installed")
    data = {
        path.relative_to(src).as_posix()
        for name in packages
        for path in (src / name).rglob("*")
        if path.is_file() and path.suffix != ".py"
    }
    assert "benchmarks/rl/configs/ppo.toml" in data
    assert data <= names, f"left out of the wheel: {sorted(data - names)}"
    # No developer script: the wheel holds the three packages and its own metadata, nothing else.
    tops = {name.split("/")[0] for name in names}
    assert {t for t in tops if not t.endswith(".dist-info")} == set(packages), sorted(tops)
    assert not [name for name in names if "/perf/" in name or name.startswith("perf/")]
    # and they are found where the code looks for them, with the source tree out of reach
    code = "from benchmarks.rl.configs import default_config as d; print(type(d('ppo')).__name__)"
    env = {**os.environ, "PYTHONPATH": str(tmp_path / "installed"), "PYTHONSAFEPATH": "1"}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, env=env
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "PPOConfig"


def test_ci_runs_the_readmes_test_command_word_for_word():
    """.ci/run runs exactly what the README tells a user to run, and it runs every tier."""
    readme = (ROOT / "README.md").read_text()
    commands = [
        line for line in readme.splitlines() if line.startswith('pip install -e ".[test]"')
    ]
    assert len(commands) == 1, commands
    (command,) = commands
    assert command.endswith("python -m pytest --all")  # the slow tier too
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert command in ci
