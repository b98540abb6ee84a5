"""PyBullet's banner and renderer warnings are dropped where they are made; other output stays."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from tooldesign_env.bullet import _filter_noise


def test_filter_drops_banner_argv_and_warning_with_its_message():
    text = (
        "pybullet build time: Jan 29 2025 23:17:20\n"
        "argv[0]=\n"
        "b3Warning[examples/SharedMemory/b3RobotSimulatorClientAPI.cpp,42]:\n"
        "no texture\n"
        "a real error\n"
    )
    assert _filter_noise(text) == "a real error\n"


def test_filter_keeps_unrelated_lines_unchanged():
    assert _filter_noise("error: out of memory\nsecond\n") == "error: out of memory\nsecond\n"
    assert _filter_noise("") == ""


@pytest.mark.slow
def test_import_connect_and_render_print_nothing():
    code = textwrap.dedent(
        """
        import sys
        from tooldesign_env.bullet import BulletWorld
        w = BulletWorld()
        w.render(width=32, height=24)
        w.close()
        w = BulletWorld(render_mode="rgb_array")  # a floor with a visual warns in PyBullet
        w.add_floor(friction=0.5)
        w.render(width=32, height=24, goal=(0.0, 1.0, 0.1))
        w.close()
        print("python output survives")
        print("so does stderr", file=sys.stderr)
        """
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout == "python output survives\n"
    assert out.stderr == "so does stderr\n"


@pytest.mark.slow
def test_exceptions_inside_the_quiet_block_propagate_and_restore_the_descriptors():
    code = textwrap.dedent(
        """
        from tooldesign_env.bullet import _quiet_pybullet
        try:
            with _quiet_pybullet():
                raise RuntimeError("boom")
        except RuntimeError as exc:
            print("caught", exc)
        """
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout == "caught boom\n"
