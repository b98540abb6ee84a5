"""Builds the optional C control loop; everything else about the package is in pyproject.toml.

``tooldesign_env/native/control_loop.c`` is a PyBullet plugin, a plain shared library that PyBullet
loads (Python never imports it). It is optional: where it cannot be compiled (no C compiler, or
Windows, whose loader it does not support) the install goes on and the simulator runs its Python
loop, with the same results. ``-ffp-contract=off`` keeps the compiler from fusing a * b + c into
one rounding, which would make the controller's torques differ from the Python loop's.
"""

import sys

from setuptools import Extension, setup

extensions = []
if sys.platform != "win32":
    extensions.append(
        Extension(
            "tooldesign_env.native._control_loop",
            sources=["tooldesign_env/native/control_loop.c"],
            extra_compile_args=["-O2", "-ffp-contract=off", "-fno-fast-math"],
            libraries=["dl"] if sys.platform.startswith("linux") else [],
            optional=True,
        )
    )

setup(ext_modules=extensions)
