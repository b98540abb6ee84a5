"""Fixtures shared by several test files, and the test tiers.

``python -m pytest`` runs the default tier: every test not marked ``slow`` (PyBullet rollouts,
subprocess runs of the command line, anything of a second or more), feedback within a minute on
2 cores. ``python -m pytest --all`` runs everything (CI does; README, "Run the tests"). An
explicit ``-m`` expression decides on its own (``-m slow``: the slow tier alone), and a slow
test named by its node id (``tests/test_x.py::test_y``) runs without ``--all``.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks.cli import main

ALL = "--all"


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        ALL,
        action="store_true",
        default=False,
        help="run the slow tests too (PyBullet rollouts, subprocess runs): the whole suite, as CI",
    )


def _named(item: pytest.Item, args: list[str], cwd: Path) -> bool:
    """Whether the command line names this test itself (a node id), not only its file."""
    for arg in args:
        path, sep, name = arg.partition("::")
        if sep and (cwd / path).resolve() == item.path:
            if item.nodeid.partition("::")[2].startswith(name):
                return True
    return False


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if config.getoption(ALL) or config.getoption("markexpr"):
        return
    args, cwd = [str(arg) for arg in config.args], config.invocation_params.dir
    keep, slow = [], []
    for item in items:
        named = _named(item, args, cwd)
        (slow if item.get_closest_marker("slow") and not named else keep).append(item)
    if slow:
        config.hook.pytest_deselected(items=slow)
        items[:] = keep
        config.stash[_SLOW_LEFT_OUT] = len(slow)


_SLOW_LEFT_OUT = pytest.StashKey[int]()


def pytest_terminal_summary(
    terminalreporter: pytest.TerminalReporter, config: pytest.Config
) -> None:
    left_out = config.stash.get(_SLOW_LEFT_OUT, 0)
    if left_out:
        terminalreporter.write_line(
            f"{left_out} slow tests left out (the default tier); run everything with "
            f"`python -m pytest {ALL}`"
        )


@pytest.fixture(scope="session")
def rl_smoke(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A run folder of the rl suite at size smoke, made as ``tooldesign bench rl`` makes it."""
    out = tmp_path_factory.mktemp("rl-smoke") / "run"
    assert main(["bench", "rl", "--size", "smoke", "--out", str(out), "--no-progress"]) == 0
    return out


@pytest.fixture(scope="session")
def breakeven_smoke(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A break-even run folder at size smoke (about 80 evaluations), made once per session.

    Shared by the study's tests and docs/rl.md's block's: copy it before changing it.
    """
    pytest.importorskip("stable_baselines3")
    out = tmp_path_factory.mktemp("breakeven") / "study"
    assert main(["rl", "breakeven", "--size", "smoke", "--out", str(out), "--no-progress"]) == 0
    return out


@pytest.fixture(scope="session")
def protocol_smoke(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A protocol run folder at size smoke, every cell run (no report), once per session.

    Shared by the protocol's tests and the reproduction page's: copy it before changing it.
    """
    from benchmarks.protocol import protocol_config, run_protocol

    out = tmp_path_factory.mktemp("protocol") / "smoke"
    run_protocol(protocol_config("smoke").replace(executor="serial"), out, progress=False)
    return out
