"""A script starting worker processes without a ``__main__`` guard fails at once, saying why."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from benchmarks.execution import check_main_guard

UNGUARDED = """
from benchmarks.execution import make_executor
with make_executor("process", workers=1) as pool:
    print(pool.submit(abs, -1).result())
"""

GUARDED = """
from benchmarks.execution import check_main_guard
if __name__ == "__main__":
    check_main_guard()
    print("ok")
"""


def _run(tmp_path, source):
    script = tmp_path / "script.py"
    script.write_text(textwrap.dedent(source))
    return subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=120
    )


def test_an_unguarded_script_fails_before_starting_a_pool(tmp_path):
    out = _run(tmp_path, UNGUARDED)
    assert out.returncode != 0
    assert "RuntimeError" in out.stderr
    assert "has no 'if __name__ == \"__main__\":' guard" in out.stderr
    assert "script.py" in out.stderr


def test_a_guarded_script_passes_the_check(tmp_path):
    out = _run(tmp_path, GUARDED)
    assert out.returncode == 0, out.stderr
    assert out.stdout == "ok\n"


def test_the_check_ignores_python_c_and_pytest():
    check_main_guard()  # under pytest: __main__ is pytest's module or console script
    code = "from benchmarks.execution import check_main_guard; check_main_guard(); print('ok')"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.stdout == "ok\n", out.stderr


@pytest.mark.parametrize(
    "source",
    [
        "x = 1\nif __name__ != '__main__':\n    pass\n",  # compares, but not a guard we know
        "import sys\n",
    ],
)
def test_a_script_with_some_other_if_is_still_unguarded(tmp_path, source):
    out = _run(tmp_path, source + UNGUARDED)
    assert "has no 'if __name__" in out.stderr
