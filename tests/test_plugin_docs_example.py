"""The worked example of docs/optimizer-plugins.md is the fixture plugin, and it builds and passes.

The page's ``pyproject.toml`` and ``tooldesign_hillclimb.py`` are compared with
``tests/fixtures/external_plugin`` character for character; the fixture is then built by pip
into a fresh virtual environment beside ``tooldesign`` (its declared dependency, found installed,
so nothing is downloaded), and ``check_optimizer`` runs on the installed plugin there.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs" / "optimizer-plugins.md"
FIXTURE = ROOT / "tests" / "fixtures" / "external_plugin"


def _block(text: str, after: str, language: str) -> str:
    found = re.search(re.escape(after) + r".*?```" + language + r"\n(.*?)```\n", text, re.S)
    assert found, f"no {language} block after {after!r} in {DOCS.name}"
    return found.group(1)


def test_the_page_shows_the_fixture_and_declares_the_dependency():
    text = DOCS.read_text(encoding="utf-8")
    pyproject = _block(text, "`pyproject.toml` declares an entry point", "toml")
    module = _block(text, "`tooldesign_hillclimb.py`:", "python")
    assert pyproject == (FIXTURE / "pyproject.toml").read_text(encoding="utf-8")
    assert module == (FIXTURE / "tooldesign_hillclimb.py").read_text(encoding="utf-8")
    assert re.search(r'^dependencies = \["tooldesign"\]', pyproject, re.M)
    # The first snippet defines what it calls; the walkthrough comes before the long survey.
    first = _block(text, "## Using an optimizer", "python")
    assert "def evaluate(" in first
    assert text.index("## A worked example") < text.index("## Which Nevergrad optimizers work")
    assert "--option step=0.1" in text and "all 12 conformance checks passed" in text


def test_the_first_snippet_of_the_page_runs():
    text = DOCS.read_text(encoding="utf-8")
    code = _block(text, "## Using an optimizer", "python").replace(
        "print(optimizers.available())", "optimizers.available()"
    )
    namespace: dict[str, object] = {}
    exec(compile(code, str(DOCS), "exec"), namespace)  # noqa: S102 - the page's own example
    best = namespace["best"]
    assert best.value < 0.05  # CMA-ES found the sphere's centre  # type: ignore[attr-defined]


@pytest.mark.slow
def test_the_example_builds_into_a_fresh_venv_and_passes_the_checks(tmp_path: Path):
    source = tmp_path / "tooldesign-hillclimb"
    shutil.copytree(FIXTURE, source)  # a build writes into the source folder
    venv = tmp_path / "venv"
    # Beside tooldesign: the environment sees the installed packages, so pip finds the
    # declared dependency satisfied and needs no index. Without a pip (and setuptools) of its
    # own, it uses the installed ones: a venv's bundled setuptools may be too old to build.
    subprocess.run(
        [sys.executable, "-m", "venv", "--system-site-packages", "--without-pip", str(venv)],
        check=True,
    )
    python = venv / ("Scripts" if os.name == "nt" else "bin") / "python"
    pip = [str(python), "-m", "pip", "--disable-pip-version-check"]
    installed = subprocess.run(
        [*pip, "install", "--no-index", "--no-build-isolation", str(source)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert installed.returncode == 0, installed.stdout[-2000:] + installed.stderr[-2000:]
    assert "Successfully installed tooldesign-hillclimb" in installed.stdout
    requires = subprocess.run(
        [*pip, "show", "tooldesign-hillclimb"], capture_output=True, text=True, check=True
    )
    assert "Requires: tooldesign" in requires.stdout
    code = (
        "import optimizers\n"
        "from optimizers.testing import check_optimizer\n"
        "from tooldesign_hillclimb import HillClimb\n"
        "assert 'hillclimb' in optimizers.available()\n"
        "print(check_optimizer(HillClimb))\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}  # this tree's optimizers, the venv's plugin
    checked = subprocess.run(
        [str(python), "-c", code],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
        cwd=tmp_path,
    )
    assert checked.returncode == 0, checked.stderr[-2000:]
    assert checked.stdout.strip() == (
        "tooldesign_hillclimb.HillClimb: all 12 conformance checks passed"
    )
