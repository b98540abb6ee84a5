"""An unreachable Dask scheduler is refused within seconds, naming its address (issue 33).

Dask's own wait (30 s, plus its retries) kept ``tcp://127.0.0.1:9`` waiting 34-40 s before the
refusal; :func:`benchmarks.execution.dask_client.connect` gives up after 5 s by default
(``TOOLDESIGN_DASK_CONNECT_TIMEOUT`` or ``connect_timeout`` set another wait).
"""

from __future__ import annotations

import time

import pytest

pytest.importorskip("distributed")

from benchmarks.cli import main  # noqa: E402
from benchmarks.execution import make_executor  # noqa: E402
from benchmarks.execution.dask_client import (  # noqa: E402
    CONNECT_TIMEOUT,
    CONNECT_TIMEOUT_ENV,
    connect_timeout,
)

DEAD = "tcp://127.0.0.1:9"  # the discard port: nothing listens there


@pytest.mark.slow
def test_a_dead_scheduler_is_refused_within_10_s_by_default(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.delenv(CONNECT_TIMEOUT_ENV, raising=False)
    assert CONNECT_TIMEOUT < 10
    began = time.monotonic()
    with pytest.raises(OSError, match=f"no Dask scheduler answers at {DEAD} .gave up after 5 s"):
        with make_executor("dask", scheduler=DEAD):
            pass
    # Not a timing measurement: Dask's own default kept it waiting 34-40 s.
    assert time.monotonic() - began < 20


@pytest.mark.slow
def test_the_wait_is_configurable_and_the_command_names_the_address(
    monkeypatch, tmp_path, capsys
) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setenv(CONNECT_TIMEOUT_ENV, "0.5")
    with pytest.raises(OSError, match="gave up after 0.5 s"):
        with make_executor("dask", scheduler=DEAD):
            pass
    with pytest.raises(OSError, match="gave up after 0.2 s"):
        with make_executor("dask", scheduler=DEAD, connect_timeout=0.2):
            pass
    argv = ["design", "--executor", "dask", "--scheduler", DEAD, "--out", str(tmp_path / "r")]
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert f"no Dask scheduler answers at {DEAD}" in err and err.count("\n") == 1
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf", "soon"])
def test_a_bad_wait_is_refused_naming_the_variable(monkeypatch, value: str) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setenv(CONNECT_TIMEOUT_ENV, value)
    with pytest.raises(ValueError, match=f"\\${CONNECT_TIMEOUT_ENV} must be a"):
        connect_timeout()
    with pytest.raises(ValueError, match="connect_timeout must be a"):
        connect_timeout(True)  # type: ignore[arg-type]
