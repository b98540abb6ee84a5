"""``tooldesign rl``: the RL baselines' command line (``python -m benchmarks.rl`` is the same).

    tooldesign rl suite --size smoke --out runs/rl-smoke    # = tooldesign bench rl --size smoke
    tooldesign rl probe ppo --episodes 256 --seed 0 --set '{"log_std_init": -2.0}'
    tooldesign rl design --policy docs/results/rl/policies/contextual.json --goal 0.2 1.0 0.1

All the work is done by plain functions of :mod:`benchmarks.rl` (``run_rl_suite``,
``design_for_goal``); this module only parses arguments and prints. ``rl suite`` is
``tooldesign bench rl`` with the same options (:mod:`benchmarks.cli.rl_suite`), but its default
size is ``smoke``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import warnings
from pathlib import Path
from typing import Any, cast

from benchmarks.cli._common import out_path, shown
from benchmarks.cli._warnings import warning_line
from benchmarks.cli.rl_suite import add_rl_suite_arguments, run_rl_command
from tooldesign_env.schema import DEFAULT_BOX_MASS

__all__ = ["add_parser"]


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``tooldesign rl`` and its subcommands."""
    parser = subparsers.add_parser(
        "rl",
        help="RL baselines on ToolDesignRL-v0: the rl suite, tuning probes, saved policies",
        description="RL baselines on ToolDesignRL-v0 (see docs/rl.md): run the rl suite, one "
        "tuning probe, or design a tool for a goal with a saved policy.",
    )
    commands = parser.add_subparsers(dest="rl_command", required=True)
    suite = commands.add_parser(
        "suite",
        help="run the rl suite into a run folder and write its report (= tooldesign bench rl)",
        description="Run the rl suite into one run folder, resuming what is there, and write "
        "its report: the same as tooldesign bench rl, with the default size smoke.",
    )
    suite.add_argument(
        "--size",
        default=None,
        help="smoke (default, CI), short (docs/rl.md) or full (docs/rl.md's committed results)",
    )
    suite.add_argument("--out", type=out_path, required=True, metavar="DIR", help="run folder")
    suite.add_argument(
        "--workers",
        default=None,
        metavar="N",
        help="processes that run units of work at once (default 1: this process)",
    )
    suite.add_argument("--no-progress", action="store_true", help="no progress lines")
    add_rl_suite_arguments(suite, title="what to run")
    tune = commands.add_parser("probe", help="one tuning probe at the default goal")
    tune.add_argument("method", choices=("random", "cmaes", "ppo", "sac"))
    tune.add_argument("--episodes", type=int, default=256)
    tune.add_argument("--seed", type=int, default=0)
    tune.add_argument("--set", default="{}", help="config fields as JSON, e.g. '{\"n_steps\": 16}'")
    design = commands.add_parser("design", help="design a tool for a goal with a saved policy")
    design.add_argument("--policy", required=True, help="a policy card (.json)")
    design.add_argument("--goal", type=float, nargs=3, required=True, metavar=("X", "Y", "Z"))
    design.add_argument("--box-mass", type=float, default=DEFAULT_BOX_MASS, help="kg")
    design.add_argument(
        "--allow-pickle",
        action="store_true",
        help="load a policy card of format 1, whose Stable-Baselines3 .zip runs code when "
        "unpickled; only for a policy you trust",
    )
    design.add_argument(
        "--no-simulate",
        action="store_true",
        help="print the design only (free_energy, normalized_reward and final_distance are null)",
    )
    parser.set_defaults(run=_run)
    return cast(argparse.ArgumentParser, parser)


def _run(args: argparse.Namespace) -> int:

    if args.rl_command == "suite":
        return run_rl_command(args, default_size="smoke")
    if args.rl_command == "probe":
        from benchmarks.rl.tuning import probe

        report = probe(
            args.method, episodes=args.episodes, seed=args.seed, overrides=json.loads(args.set)
        )
        print(json.dumps(report), flush=True)
        return 0
    if not Path(args.policy).is_file():  # before the simulation is imported (seconds)
        raise FileNotFoundError(
            f"no policy card {shown(args.policy)}: give a .json card of a policy"
        )
    from benchmarks.rl.policies import design_for_goal

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        result = design_for_goal(
            args.policy,
            args.goal,
            box_mass=args.box_mass,
            simulate=not args.no_simulate,
            allow_pickle=args.allow_pickle,
        )
    for warning in caught:  # a task outside the policy's training ranges: one line each
        sys.stderr.write(warning_line("tooldesign rl design", warning.message))
    # JSON has no NaN: what was not simulated is null.
    printed = {key: _json_value(value) for key, value in result.__dict__.items()}
    print(json.dumps(printed, indent=2, allow_nan=False))
    return 0


def _json_value(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
