"""``tooldesign rl``: the RL baselines' command line (``python -m benchmarks.rl`` is the same).

    tooldesign rl suite --size smoke --out runs/rl-smoke    # = tooldesign bench rl --size smoke
    tooldesign rl probe ppo --episodes 256 --seed 0 --set '{"log_std_init": -2.0}'
    tooldesign rl design --policy docs/results/square/rl/policies/contextual.json --goal 0.2 1.0 0.1

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
    _add_breakeven(commands)
    _add_score(commands)
    parser.set_defaults(run=_run)
    return cast(argparse.ArgumentParser, parser)


def _add_breakeven(commands: Any) -> None:
    study = commands.add_parser(
        "breakeven",
        help="the break-even study: learned designers against per-goal CMA-ES at equal budgets",
        description="Run the break-even study (docs/rl.md) into one run folder, resuming what "
        "is there, and write its report; --plan prints its size and time estimate only.",
    )
    study.add_argument("--size", default="smoke", help="smoke (default, CI) or full (hours)")
    study.add_argument("--out", type=out_path, default=None, metavar="DIR", help="run folder")
    study.add_argument(
        "--learned",
        nargs="+",
        default=None,
        metavar="METHOD",
        help="learned designers: any of contextual, ppo, sac (default: all)",
    )
    study.add_argument(
        "--workers", type=int, default=1, metavar="N", help="units run at once (default 1)"
    )
    study.add_argument(
        "--executor",
        default="process",
        help="where units run with --workers > 1: process (default) or dask",
    )
    study.add_argument("--scheduler", default=None, metavar="ADDR", help="Dask scheduler")
    study.add_argument(
        "--plan",
        action="store_true",
        help="print the planned evaluations and the time estimate, and run nothing",
    )
    study.add_argument("--no-progress", action="store_true", help="no progress lines")


def _add_score(commands: Any) -> None:
    score = commands.add_parser(
        "score",
        help="score your policy on a break-even study's tasks and print its row of the table",
        description="Evaluate a policy (a policy card .json, a Stable-Baselines3 .zip with "
        "--algorithm, or module:callable from the task (x, y, z, box mass) to an action in "
        "[-1, 1]^3) on the tasks of a break-even study, against the study's references, and "
        "print its row: mean normalized regret [95 %% interval] per budget (docs/rl.md).",
    )
    score.add_argument("--policy", required=True, metavar="SPEC", help="card, .zip or mod:func")
    score.add_argument(
        "--study",
        required=True,
        metavar="DIR",
        help="a break-even run folder (tooldesign rl breakeven)",
    )
    score.add_argument("--name", default=None, help="the row's name (default: the policy's)")
    score.add_argument(
        "--refine",
        action="store_true",
        help="also warm-start CMA-ES from the policy's designs (row warm-NAME)",
    )
    score.add_argument(
        "--algorithm", default=None, help="a .zip's algorithm: ppo, sac, td3, a2c or ddpg"
    )
    score.add_argument(
        "--allow-pickle",
        action="store_true",
        help="load a Stable-Baselines3 .zip, which is unpickled and so can run any code it "
        "holds; only for a file you trust",
    )
    score.add_argument(
        "--save",
        default=None,
        metavar="FILE.parquet",
        help="also write the policy's evaluations there, in the columns of the study's "
        "evaluations.parquet (load_breakeven's)",
    )
    score.add_argument("--executor", default="serial", help="serial (default), process or dask")
    score.add_argument("--workers", type=int, default=None, metavar="N")
    score.add_argument("--scheduler", default=None, metavar="ADDR", help="Dask scheduler")


def _run(args: argparse.Namespace) -> int:

    if args.rl_command == "suite":
        return run_rl_command(args, default_size="smoke")
    if args.rl_command == "breakeven":
        return _run_breakeven(args)
    if args.rl_command == "score":
        return _run_score(args)
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


def _run_breakeven(args: argparse.Namespace) -> int:
    from benchmarks.rl.breakeven import breakeven_config, estimate_text, run_breakeven

    config = breakeven_config(
        args.size,
        learned=args.learned or ("contextual", "ppo", "sac"),
        workers=args.workers,
        executor=args.executor,
        scheduler=args.scheduler,
    )
    if args.plan:
        print(estimate_text(config))
        return 0
    if args.out is None:
        raise ValueError("--out DIR is needed to run the study (or --plan to print its size)")
    from benchmarks.cli._common import check_out_folder

    check_out_folder(args.out)
    from benchmarks.reports import make_suite_report

    say = None if args.no_progress else (lambda line: print(line, flush=True))
    result = run_breakeven(config, args.out, progress=say)
    written = make_suite_report(result.out_dir)  # the study's report, recorded in its manifest
    print(
        f"break-even study ({config.size.name}): {len(result.evaluations)} evaluations, "
        f"{result.units} units ({result.units_run} run now), {result.wall_time:.1f} s\n"
        f"report: {written[0].parent} (breakeven.md); data: "
        f"{result.out_dir / 'evaluations.parquet'}"
    )
    return 0


def _run_score(args: argparse.Namespace) -> int:
    if not Path(args.study).exists():  # before the simulation is imported (seconds)
        raise FileNotFoundError(
            f"no break-even study {shown(args.study)}: give a folder of `tooldesign rl breakeven`"
        )
    from benchmarks.reports.breakeven import (
        regret_curves,
        regret_table,
        results_rows,
        study_references,
    )
    from benchmarks.rl.scoring import score_policy

    if args.save is not None and (not args.save.endswith(".parquet") or Path(args.save).is_dir()):
        raise ValueError(f"--save must be a file ending in .parquet, got {shown(args.save)}")
    rows, log = score_policy(
        args.policy,
        args.study,
        name=args.name,
        refine=args.refine,
        executor=args.executor,
        workers=args.workers,
        scheduler=args.scheduler,
        allow_pickle=args.allow_pickle,
        algorithm=args.algorithm,
    )
    from benchmarks.storage import read_manifest

    study = Path(args.study)
    budgets = read_manifest(study.parent if study.suffix == ".parquet" else study)["config"][
        "size"
    ]["budgets"]
    curves = regret_curves(rows, max(budgets), references=study_references(log))
    table = regret_table(curves, budgets)
    print("| method | " + " | ".join(str(b) for b in budgets) + " |")
    print("|---|" + "|".join("---" for _ in budgets) + "|")
    for row in results_rows(table):
        print("| " + " | ".join(row) + " |")
    if args.save is not None:
        import io

        from benchmarks.storage import atomic_write_bytes

        buffer = io.BytesIO()
        rows.to_parquet(buffer, index=False)
        print(f"evaluations: {atomic_write_bytes(args.save, buffer.getvalue())}")
    return 0
