"""The rl suite's options, shared by ``tooldesign bench rl`` and ``tooldesign rl suite``.

Both commands take the same options and run the same function: the suite into one run folder
(resumed if it is there), then its report from the stored files. Values are checked by
:func:`benchmarks.rl.rl_suite_config`, so bad input ends with one line that names the value and
what is allowed (exit code 2).
"""

from __future__ import annotations

import argparse
import math
from typing import Any

__all__ = ["RL_ONLY_OPTIONS", "add_rl_suite_arguments", "run_rl_command"]

#: Options that only the rl suite takes (``tooldesign bench`` refuses them for other suites).
RL_ONLY_OPTIONS: tuple[str, ...] = ("seeds", "methods", "parts", "mass_range")


def add_rl_suite_arguments(parser: argparse.ArgumentParser | Any, *, title: str) -> None:
    """Add ``--seeds``, ``--methods``, ``--parts`` and ``--mass-range`` to ``parser``."""
    group = parser.add_argument_group(title)
    group.add_argument(
        "--seeds",
        default=None,
        metavar="N",
        help="seeds of the fixed-goal part instead of the size's (an int >= 1)",
    )
    group.add_argument(
        "--methods",
        nargs="+",
        default=None,
        metavar="METHOD",
        help="fixed-goal methods: any of random, cmaes, ppo, sac (default: all)",
    )
    group.add_argument(
        "--parts",
        nargs="+",
        default=None,
        metavar="PART",
        help="parts to run: any of fixed, task, mass (default: all)",
    )
    group.add_argument(
        "--mass-range",
        nargs=2,
        default=None,
        metavar=("LOW", "HIGH"),
        help="box masses of the mass part in kg, 0 < LOW <= HIGH (default: 0.1 0.9)",
    )


def _count(option: str, text: Any) -> Any:
    if text is None or isinstance(text, int):
        return text  # rl_suite_config checks the range
    try:
        return int(text)
    except ValueError:
        raise ValueError(f"{option} must be an int >= 1, got {text!r}") from None


def _mass_range(text: Any) -> tuple[float, float] | None:
    if text is None:
        return None
    try:
        low, high = (float(v) for v in text)
    except ValueError:
        raise ValueError(
            f"--mass-range must be two numbers LOW HIGH in kg, got {' '.join(text)}"
        ) from None
    if not (math.isfinite(low) and math.isfinite(high)):
        raise ValueError(f"--mass-range must be two finite numbers in kg, got {' '.join(text)}")
    return low, high


def run_rl_command(args: argparse.Namespace, *, default_size: str) -> int:
    """Run the rl suite as the parsed arguments ask, write its report, print the summary.

    Args:
        args: ``size``, ``out``, ``workers``, ``no_progress`` and the options of
            :func:`add_rl_suite_arguments`; ``config``, ``executor``, ``scheduler``,
            ``max_retries`` and ``dump_config`` (from ``tooldesign bench``) must be unset.
        default_size: the size when ``--size`` is not given.

    Returns:
        0.

    Raises:
        ValueError / TypeError: bad input (one line for the command line).
    """
    from benchmarks.cli._common import check_out_folder

    check_out_folder(args.out)  # before the suite's imports (seconds)
    from benchmarks.reports import make_suite_report
    from benchmarks.rl import rl_suite_config, rl_summary_text, run_rl_suite
    from benchmarks.rl.suite import FIXED_METHODS, MASS_RANGE, PARTS

    for name, flag in (
        ("config", "--config"),
        ("executor", "--executor"),
        ("scheduler", "--scheduler"),
        ("max_retries", "--max-retries"),
        ("dump_config", "--dump-config"),
    ):
        if getattr(args, name, None) is not None:
            raise ValueError(
                f"{flag} is not available for the rl suite (its units run in this process, or "
                "on --workers processes; its configuration is in the run folder's manifest.json)"
            )
    config = rl_suite_config(
        args.size or default_size,
        seeds=_count("--seeds", args.seeds),
        methods=args.methods or FIXED_METHODS,
        parts=args.parts or PARTS,
        mass_range=_mass_range(args.mass_range) or MASS_RANGE,
        workers=1 if args.workers is None else _count("--workers", args.workers),
    )
    say = None if args.no_progress else (lambda line: print(line, flush=True))
    result = run_rl_suite(config, args.out, progress=say)
    report = make_suite_report(result.out_dir)
    print(rl_summary_text(result))
    if report:
        print(f"report: {report[0].parent} ({len(report)} files)")
    return 0
