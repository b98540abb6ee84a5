"""``python -m benchmarks.rl`` is ``tooldesign rl`` (see :mod:`benchmarks.cli.rl`)."""

from __future__ import annotations

import sys

from benchmarks.cli import main

if __name__ == "__main__":
    sys.exit(main(["rl", *sys.argv[1:]]))
