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


@pytest.mark.slow
def test_an_unguarded_script_fails_before_starting_a_pool(tmp_path):
    out = _run(tmp_path, UNGUARDED)
    assert out.returncode != 0
    assert "RuntimeError" in out.stderr
    assert "has no 'if __name__ == \"__main__\":' guard" in out.stderr
    assert "script.py" in out.stderr


@pytest.mark.slow
def test_a_guarded_script_passes_the_check(tmp_path):
    out = _run(tmp_path, GUARDED)
    assert out.returncode == 0, out.stderr
    assert out.stdout == "ok\n"


@pytest.mark.slow
def test_the_check_ignores_python_c_and_pytest():
    check_main_guard()  # under pytest: __main__ is pytest's module or console script
    code = "from benchmarks.execution import check_main_guard; check_main_guard(); print('ok')"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.stdout == "ok\n", out.stderr


@pytest.mark.slow
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


DESIGN = """
from benchmarks.design import DesignConfig, run_design
config = DesignConfig(optimizer="random", iterations=1, batch_size=2, workers=1)
"""


@pytest.mark.slow
def test_an_unguarded_design_script_leaves_no_run_folder(tmp_path):
    # The check came after the run folder was made: its manifest and heartbeat stayed, and the
    # fixed script was refused with "exists and is not empty" (an audit of issue 11).
    run = tmp_path / "run"
    out = _run(tmp_path, DESIGN + f"run_design(config, {str(run)!r}, progress=False)\n")
    assert out.returncode != 0
    assert "has no 'if __name__ == \"__main__\":' guard" in out.stderr
    assert not run.exists()


@pytest.mark.slow
def test_a_run_design_call_beside_the_guard_fails_at_once_naming_its_line(tmp_path):
    # The script had a guard, so the check passed; each worker then re-ran the module-level
    # call and the run ended seconds later in multiprocessing tracebacks (an audit of issue 11).
    run = tmp_path / "run"
    source = (
        DESIGN
        + f"run_design(config, {str(run)!r}, progress=False)\n"
        + "if __name__ == '__main__':\n    print('done')\n"
    )
    out = _run(tmp_path, source)
    assert out.returncode != 0
    assert "script.py, line 4, starts worker processes outside its" in out.stderr
    assert out.stderr.count("Traceback") == 1  # the parent's only: no worker was started
    assert not run.exists()


@pytest.mark.slow
@pytest.mark.parametrize(
    "test",
    [
        "__name__ == '__main__' and len(sys.argv) < 5",
        "len(sys.argv) < 5 and '__main__' == __name__",
    ],
)
def test_a_guard_joined_with_and_is_a_guard(tmp_path, test):
    source = (
        "import sys\nfrom benchmarks.execution import check_main_guard\n"
        f"if {test}:\n    check_main_guard()\n    print('ok')\n"
    )
    out = _run(tmp_path, source)
    assert out.returncode == 0, out.stderr
    assert out.stdout == "ok\n"


@pytest.mark.slow
def test_a_guard_joined_with_or_is_not_a_guard(tmp_path):
    source = "import sys\nif __name__ == '__main__' or len(sys.argv) > 1:\n    pass\n"
    out = _run(tmp_path, source + UNGUARDED)
    assert "has no 'if __name__" in out.stderr


@pytest.mark.slow
def test_a_worker_process_re_running_the_script_is_refused_with_the_guard_message(tmp_path):
    # What a worker sees of a call outside the guard when the parent's check cannot see it.
    source = """
    import multiprocessing
    from benchmarks.execution import check_main_guard
    if __name__ != "__main__":
        try:
            check_main_guard()
        except RuntimeError as error:
            print("worker refused:", error, flush=True)
    if __name__ == "__main__":
        worker = multiprocessing.get_context("spawn").Process(target=print, args=("ran",))
        worker.start()
        worker.join()
    """
    out = _run(tmp_path, source)
    assert out.returncode == 0, out.stderr
    assert "worker refused:" in out.stdout
    assert "outside its 'if __name__ == \"__main__\":' guard" in out.stdout
    assert "ran" in out.stdout  # the check only refuses; the process went on
