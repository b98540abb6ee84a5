"""``tooldesign rl``: the RL baselines' command line (``python -m benchmarks.rl`` is the same).

    tooldesign rl suite --size smoke --out runs/rl-smoke
    tooldesign rl probe ppo --episodes 256 --seed 0 --set '{"log_std_init": -2.0}'
    tooldesign rl design --policy docs/results/rl/policies/contextual.json --goal 0.2 1.0 0.1

All the work is done by plain functions of :mod:`benchmarks.rl` (``run_rl_suite``,
``design_for_goal``); this module only parses arguments and prints.
"""

from __future__ import annotations

import argparse
import json
from typing import Any, cast

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
    suite = commands.add_parser("suite", help="run the rl suite and write its results")
    suite.add_argument("--size", choices=("smoke", "short", "paper"), default="smoke")
    suite.add_argument("--out", required=True, help="output folder")
    suite.add_argument("--seeds", type=int, default=None, help="fixed-goal seeds (override)")
    suite.add_argument("--parts", nargs="+", choices=("fixed", "task"), default=["fixed", "task"])
    suite.add_argument(
        "--methods",
        nargs="+",
        choices=("random", "cmaes", "ppo", "sac"),
        default=["random", "cmaes", "ppo", "sac"],
    )
    tune = commands.add_parser("probe", help="one tuning probe at the default goal")
    tune.add_argument("method", choices=("random", "cmaes", "ppo", "sac"))
    tune.add_argument("--episodes", type=int, default=256)
    tune.add_argument("--seed", type=int, default=0)
    tune.add_argument("--set", default="{}", help="config fields as JSON, e.g. '{\"n_steps\": 16}'")
    design = commands.add_parser("design", help="design a tool for a goal with a saved policy")
    design.add_argument("--policy", required=True, help="a policy card (.json)")
    design.add_argument("--goal", type=float, nargs=3, required=True, metavar=("X", "Y", "Z"))
    design.add_argument("--box-mass", type=float, default=0.1, help="kg")
    design.add_argument("--no-simulate", action="store_true", help="print the design only")
    parser.set_defaults(run=_run)
    return cast(argparse.ArgumentParser, parser)


def _run(args: argparse.Namespace) -> int:

    if args.rl_command == "suite":
        from benchmarks.rl.suite import run_rl_suite

        summary = run_rl_suite(
            args.size,
            args.out,
            seeds=args.seeds,
            methods=args.methods,
            parts=args.parts,
            progress=lambda line: print(line, flush=True),
        )
        print(f"wrote {args.out} in {summary['wall_time_s']} s")
        return 0
    if args.rl_command == "probe":
        from benchmarks.rl.tuning import probe

        report = probe(
            args.method, episodes=args.episodes, seed=args.seed, overrides=json.loads(args.set)
        )
        print(json.dumps(report), flush=True)
        return 0
    from benchmarks.rl.policies import design_for_goal

    result = design_for_goal(
        args.policy, args.goal, box_mass=args.box_mass, simulate=not args.no_simulate
    )
    print(json.dumps(result.__dict__, indent=2))
    return 0
