"""Bad input is refused before the heavy imports: one line, exit code 2, in well under a second.

Each refusal took 3-4 s on an idle machine and 12-16 s on a busy one (issue 34), most of it
importing SciPy's statistics, pandas, Matplotlib and PyBullet before the argument was looked
at. Checked by what is imported, which does not depend on the machine's load;
``benchmarks/perf/cli_startup.py`` measures the times.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

HEAVY = ("pandas", "scipy", "matplotlib", "pybullet", "torch")

CODE = (
    "import sys\nfrom benchmarks.cli import main\n"
    "if __name__ == '__main__':\n"
    "    try:\n        main(sys.argv[1:])\n    except SystemExit as e:\n"
    "        print('EXIT', e.code, file=sys.stderr)\n"
    f"    print('HEAVY', sorted(m for m in {HEAVY!r} if m in sys.modules), file=sys.stderr)\n"
)

#: (arguments, words of the one-line error); FILE is an existing file, NEW a folder not made.
REFUSALS = [
    (["design", "--optimizer", "cmaess", "--out", "NEW"], "unknown optimizer 'cmaess'"),
    (["design", "--iterations", "0", "--out", "NEW"], "iterations must be >= 1, got 0"),
    (["design", "--batch-size", "0", "--out", "NEW"], "batch_size must be"),
    (["design", "--goal", "nan", "1.5", "0.1", "--out", "NEW"], "goal"),
    (["design", "--out", "FILE"], "is a file; give a folder for the run"),
    (["evaluate", "--coeffs", "2.0", "0", "0.9", "--out", "NEW"], "outside the default bounds"),
    (["evaluate", "--coeffs", "0", "0", "0", "--out", "FILE"], "is a file"),
    (["bench", "optimizers", "--out", "FILE"], "is a file; give a folder for the run"),
    (["bench", "nosuch", "--out", "NEW"], "unknown suite 'nosuch'"),
    (["retest", "NEW"], "does not exist"),
    (["report", "NEW"], "does not exist"),
    (["html", "NEW"], "is not a folder"),
    (["dense-search", "--out", "FILE"], "is a file"),
    (["reproduce", "--results", "NEW"], "no results folder"),
    (["rl", "suite", "--out", "FILE"], "is a file"),
    (["rl", "design", "--policy", "NEW", "--goal", "0", "1.5", "0.1"], "no policy card"),
    (["readme", "--iterations", "0"], "must be an int >= 1"),
]


@pytest.mark.slow
@pytest.mark.parametrize(("argv", "words"), REFUSALS, ids=lambda v: " ".join(v)[:40])
def test_a_refusal_imports_nothing_heavy(tmp_path, argv, words):
    file = tmp_path / "file.txt"
    file.write_text("a file")
    new = tmp_path / "new"
    argv = [str(file) if a == "FILE" else str(new) if a == "NEW" else a for a in argv]
    out = subprocess.run(
        [sys.executable, "-c", CODE, *argv], capture_output=True, text=True, timeout=120
    )
    lines = out.stderr.strip().splitlines()
    assert lines[-2] == "EXIT 2", out.stderr
    assert words in lines[0] and len(lines) == 3, out.stderr  # one line, then the probe's two
    assert lines[-1] == "HEAVY []", f"{' '.join(argv)}: {lines[-1]}"
    assert not new.exists()  # nothing was made


def test_the_spelled_out_bounds_agree_with_the_env():
    import numpy as np

    from benchmarks.cli import _common
    from tooldesign_env.env import ACTION_ROUNDING, COEFFICIENT_MAX, default_bounds
    from tooldesign_env.geometry.tool import DEGREE_MAX

    assert _common.ACTION_ROUNDING == ACTION_ROUNDING
    assert _common.COEFFICIENT_MAX == COEFFICIENT_MAX and _common.DEGREE_MAX == DEGREE_MAX
    for degree in (1, 3, DEGREE_MAX):
        bounds = default_bounds(degree)
        assert np.all(bounds[:-1] == [-_common.COEFFICIENT_BOUND, _common.COEFFICIENT_BOUND])
        assert np.all(bounds[-1] == [-_common.LINEAR_BOUND, _common.LINEAR_BOUND])


@pytest.mark.parametrize(
    "coeffs",
    [[2.0, 0.0, 0.9], [0.0, 0.0, 0.500002], [-1.6], [0.0] * 19 + [0.7]],
)
def test_the_early_bounds_check_says_what_evaluate_says(tmp_path, coeffs):
    from benchmarks.cli._common import check_in_default_bounds
    from benchmarks.design.evaluate import evaluate_coefficients

    with pytest.raises(ValueError) as early:
        check_in_default_bounds(coeffs)
    with pytest.raises(ValueError) as late:
        evaluate_coefficients(coeffs, tmp_path / "out")
    assert str(early.value) == str(late.value)


@pytest.mark.parametrize("coeffs", [[0.0, 0.0, 0.5000004], [1.5, -1.5, -0.5], [0.0] * 21])
def test_the_early_bounds_check_leaves_the_rest_to_the_library(coeffs):
    from benchmarks.cli._common import check_in_default_bounds

    check_in_default_bounds(coeffs)  # within rounding, inside, or malformed: not refused here
