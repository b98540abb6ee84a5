"""How long ``tooldesign --help``, ``--version``, every ``COMMAND --help`` and refusals take.

Each command is run ``--repeat`` times in a fresh ``python`` process (as the console script runs
it); printed: the median and the worst wall-clock time, the exit code, and which heavy modules
were imported. Besides the help of every subcommand, one or more refusals of bad input per
subcommand (an unknown optimizer, ``--iterations 0``, a file as ``--out``, a design outside the
bounds, a folder that does not exist, ...), each of which should exit 2 with one line.

Run: ``python -m perf.speed.cli_startup [--repeat 5]``. Target (issues 11 and 34): under
1 s each on an idle 2-core machine, with none of PyBullet, Matplotlib, pandas, SciPy and torch
imported (``tests/test_cli.py`` checks the imports of the help, ``tests/test_cli_refusals.py``
those of the refusals).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from perf import _args

HEAVY = ("pybullet", "matplotlib", "pandas", "scipy", "torch")

CODE = (
    "import sys; from benchmarks.cli import main\n"
    "if __name__ == '__main__':\n"
    "    code = 0\n"
    "    try:\n        main(sys.argv[1:])\n    except SystemExit as e:\n        code = e.code\n"
    "    print('EXIT', code, 'HEAVY', sorted(m for m in {heavy!r} if m in sys.modules),"
    " file=sys.stderr)\n"
)

#: Bad input every subcommand should refuse at once; FILE is an existing file, NEW a path that
#: does not exist (nothing is made: each is refused before).
REFUSALS: tuple[tuple[str, ...], ...] = (
    ("design", "--optimizer", "cmaess", "--out", "NEW"),
    ("design", "--iterations", "0", "--out", "NEW"),
    ("design", "--out", "FILE"),
    ("evaluate", "--coeffs", "2.0", "0", "0.9", "--out", "NEW"),
    ("evaluate", "--coeffs", "0", "0", "0", "--out", "FILE"),
    ("bench", "nosuch", "--out", "NEW"),
    ("bench", "optimizers", "--out", "FILE"),
    ("retest", "NEW"),
    ("report", "NEW"),
    ("html", "NEW"),
    ("dense-search", "--out", "FILE"),
    ("reproduce", "--results", "NEW"),
    ("rl", "suite", "--out", "FILE"),
    ("rl", "design", "--policy", "NEW", "--goal", "0", "1.5", "0.1"),
    ("readme", "--iterations", "0"),
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
    """Time the help, the version, every subcommand's help and the refusals; one line each."""
    from benchmarks.cli import COMMANDS

    args = parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        file, new = Path(tmp) / "file.txt", Path(tmp) / "new"
        file.write_text("a file, given where a folder is wanted")
        names = {"FILE": str(file), "NEW": str(new)}
        runs = [["--help"], ["--version"], *([name, "--help"] for name in COMMANDS)]
        runs += [[names.get(word, word) for word in refusal] for refusal in REFUSALS]
        for run in runs:
            times = []
            outcome = ""
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                out = subprocess.run(
                    [sys.executable, "-c", CODE.format(heavy=HEAVY), *run],
                    capture_output=True,
                    text=True,
                    check=True,
                )
                times.append(time.perf_counter() - t0)
                outcome = out.stderr.strip().splitlines()[-1]
            shown = " ".join(run).replace(tmp, "TMP")
            print(
                f"tooldesign {shown:<44} median {statistics.median(times):.2f} s, "
                f"worst {max(times):.2f} s; {outcome}"
            )


if __name__ == "__main__":
    main()
