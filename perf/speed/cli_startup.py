"""How long ``tooldesign --help``, ``--version`` and every ``tooldesign COMMAND --help`` take.

Each command is run ``--repeat`` times in a fresh ``python`` process (as the console script runs
it); printed: the median and the worst wall-clock time, and whether a heavy module was imported.

Run: ``python -m perf.speed.cli_startup [--repeat 5]``. Target (issue 11): under 1 s each,
with none of PyBullet, Matplotlib and torch imported (``tests/test_cli.py`` checks the imports).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time

from perf import _args

HEAVY = ("pybullet", "matplotlib", "pandas", "scipy", "torch")

CODE = (
    "import sys; from benchmarks.cli import main\n"
    "try:\n    main(sys.argv[1:])\nexcept SystemExit:\n    pass\n"
    "print('HEAVY', sorted(m for m in {heavy!r} if m in sys.modules), file=sys.stderr)\n"
)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--repeat",
        type=_args.count(1),
        default=5,
        help="fresh processes per command (default: %(default)s)",
    )
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    """Time the top-level help and version and every subcommand's help; one line each."""
    from benchmarks.cli import COMMANDS

    args = parse_args(argv)
    for argv in (["--help"], ["--version"], *([name, "--help"] for name in COMMANDS)):
        times = []
        heavy = ""
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            out = subprocess.run(
                [sys.executable, "-c", CODE.format(heavy=HEAVY), *argv],
                capture_output=True,
                text=True,
                check=True,
            )
            times.append(time.perf_counter() - t0)
            heavy = out.stderr.strip().splitlines()[-1]
        print(
            f"tooldesign {' '.join(argv):<20} median {statistics.median(times):.2f} s, "
            f"worst {max(times):.2f} s; {heavy}"
        )


if __name__ == "__main__":
    main()
