"""The generic import names resolve to this project, and the docs build without warnings."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("name", ["tooldesign_env", "optimizers", "benchmarks"])
def test_top_level_packages_are_this_projects(name):
    module = __import__(name)
    assert Path(module.__file__).resolve().parent == ROOT / name


def test_console_script_is_installed():
    exe = shutil.which("tooldesign")
    assert exe is not None, "pip install -e . should install the 'tooldesign' command"
    out = subprocess.run([exe, "--help"], capture_output=True, text=True, check=True)
    assert "evaluate" in out.stdout


def test_docs_build_strict(tmp_path):
    out = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path)],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
