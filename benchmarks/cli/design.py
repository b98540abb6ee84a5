"""``tooldesign design``: design a tool (Algorithm 1) into a run folder, then draw its report."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any, cast

from benchmarks.cli._common import (
    DEFAULT_SECTION_SHAPE,
    add_max_retries_argument,
    add_task_arguments,
    add_task_name_argument,
    box_mass_flag,
    check_out_folder,
    out_path,
    task_goal,
    unique_pairs,
)
from benchmarks.design import DesignConfig
from benchmarks.design.config import HARNESS_SETTINGS
from benchmarks.execution import EXECUTORS, TaskSettings


def _setting(text: str) -> tuple[str, Any]:
    key, sep, raw = text.partition("=")
    if not sep or not key.strip():
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    try:
        value = json.loads(raw)
    except json.JSONDecodeError:
        value = raw  # a bare word is a string: --option method=lbfgs
    return key.strip(), value


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``tooldesign design`` on the dispatcher's subparsers."""
    parser = subparsers.add_parser(
        "design",
        help="design a tool: ask/evaluate/tell for K iterations (Algorithm 1)",
        description=(
            "Design a tool with an ask/tell optimizer (Algorithm 1 of the paper) and write a run "
            "folder: evaluation log, design card, meshes, Figure 3 panels, robustness test. "
            "See docs/design-runs.md."
        ),
    )
    defaults = DesignConfig.__dataclass_fields__
    from optimizers import registry

    # The designer's options default to None so that --policy can tell which were given.
    parser.add_argument(
        "--optimizer",
        default=None,
        metavar="NAME",
        help=f"optimizer: {', '.join(registry.available())}, an installed plugin's name, or "
        f"'module:Class' (default: {_DEFAULTS['optimizer']})",
    )
    parser.add_argument(
        "--policy",
        type=Path,
        default=None,
        metavar="PATH",
        help="design with a saved RL policy (a card .json of `tooldesign bench rl`) instead of "
        "an optimizer: its zero-shot tool for --goal and --box-mass, one evaluation, the same "
        "run folder (see docs/rl.md)",
    )
    parser.add_argument(
        "--refine",
        type=int,
        default=None,
        metavar="N",
        help="with --policy: refine the policy's design with N more evaluations of CMA-ES "
        "warm-started from it (mean = the design, step size from the policy's spread or "
        "--option sigma0=S; --option popsize=L, --seed); 0 is the design alone (see docs/rl.md)",
    )
    parser.add_argument(
        "--allow-pickle",
        action="store_true",
        help="with --policy: load a policy card of format 1, whose Stable-Baselines3 .zip is "
        "unpickled and so can run any code it holds; only for a policy you trust (it warns; "
        "docs/reliability.md)",
    )
    parser.add_argument(
        "--seed",
        type=int,
        default=None,
        help=f"seed of the optimizer (default: {_DEFAULTS['seed']})",
    )
    parser.add_argument(
        "--iterations",
        type=int,
        default=None,
        metavar="K",
        help=f"iterations K (default: {defaults['iterations'].default})",
    )
    parser.add_argument("--out", type=out_path, required=True, metavar="DIR", help="run folder")
    parser.add_argument(
        "--batch-size",
        type=int,
        default=None,
        metavar="B",
        help=f"designs per iteration (default: {defaults['batch_size'].default})",
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="W",
        help="worker processes (default: the CPUs this process may use)",
    )
    parser.add_argument(
        "--executor",
        choices=EXECUTORS,
        default=None,
        help="where designs are evaluated (default: process; serial with --policy)",
    )
    parser.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDR",
        help="Dask scheduler address, e.g. tcp://host:8786 (with --executor dask)",
    )
    add_max_retries_argument(parser, cast("int", defaults["max_retries"].default))
    add_task_arguments(
        parser,
        section_default=(
            f"{DEFAULT_SECTION_SHAPE}; with --policy, the one the policy was trained with"
        ),
        goal_of_task=True,
    )
    add_task_name_argument(parser)
    # With --policy the tool's section is the policy's unless given: None tells the two apart
    # (_tool_and_arm falls back to DEFAULT_SECTION_SHAPE without a policy).
    parser.set_defaults(section_shape=None)
    parser.add_argument(
        "--option",
        type=_setting,
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="optimizer setting (JSON value or word), repeatable, e.g. --option sigma0=0.3",
    )
    parser.add_argument("--resume", action="store_true", help="continue the run in --out")
    parser.add_argument(
        "--no-progress",
        action="store_true",
        help="no progress bar, and no status line for the phases after it",
    )
    parser.add_argument(
        "--no-video", action="store_true", help="do not write rollout.gif (saves about 20 s)"
    )
    parser.set_defaults(run=_run)
    return cast("argparse.ArgumentParser", parser)


_DEFAULTS: dict[str, Any] = {"optimizer": "cmaes", "seed": 0}
# Why a field of HARNESS_SETTINGS is no --option: the command gives the optimizer its own.
_HARNESS_FLAGS = {
    "seed": "the optimizer's seed is set by --seed",
    "batch_size": "the optimizer's batch size is set by --batch-size",
    "bounds": "the optimizer searches the run's coefficient bounds (on the command line the "
    "default ones), not an option's",
}
_DESIGNER_FLAGS = {
    "optimizer": "--optimizer",
    "option": "--option",
    "seed": "--seed",
    "iterations": "--iterations",
    "batch_size": "--batch-size",
}


def _designer(args: argparse.Namespace) -> dict[str, Any]:
    """The designer's fields of the config: an optimizer's, or a saved policy's one design."""
    if args.policy is None:
        if args.allow_pickle:
            raise ValueError("--allow-pickle applies to a policy's file: give it with --policy")
        _refine(args)  # refused without --policy
        settings = unique_pairs(args.option, "--option")
        for key in settings:
            if key in HARNESS_SETTINGS:
                raise ValueError(f"--option {key}=...: {_HARNESS_FLAGS[HARNESS_SETTINGS[key]]}")
        if args.optimizer is not None and not args.optimizer.strip():
            # An empty name is a mistake (an unset variable in a script), not the default.
            raise ValueError(
                f"--optimizer must be a name, got {args.optimizer!r}; omit it for the default "
                f"({_DEFAULTS['optimizer']}), or see tooldesign design --help for the names"
            )
        defaults = DesignConfig.__dataclass_fields__
        return {
            "optimizer": _DEFAULTS["optimizer"] if args.optimizer is None else args.optimizer,
            "optimizer_settings": settings,
            "seed": _DEFAULTS["seed"] if args.seed is None else args.seed,
            "iterations": defaults["iterations"].default
            if args.iterations is None
            else args.iterations,
            "batch_size": defaults["batch_size"].default
            if args.batch_size is None
            else args.batch_size,
            "executor": args.executor or "process",
        }
    refine = _refine(args)
    # With --refine the CMA-ES that refines the design takes a seed and two settings.
    allowed = {"seed", "option"} if refine is not None else set()
    given = [
        flag
        for key, flag in _DESIGNER_FLAGS.items()
        if key not in allowed and getattr(args, key) not in (None, [])
    ]
    if given:
        what = (
            "the warm-started design takes --seed and --option sigma0=/popsize= only"
            if refine is not None
            else "--policy designs one tool with the saved policy"
        )
        raise ValueError(
            f"{what}: {', '.join(given)} {'does' if len(given) == 1 else 'do'} not apply"
        )
    # The task is checked before the designer's settings hold its goal and mass: a NaN there
    # is refused as "goal must be finite", as without --policy, not as a bad JSON value.
    task = TaskSettings(goal=task_goal(args), box_mass=box_mass_flag(args))
    from benchmarks.rl.designer import POLICY_DESIGNER
    from benchmarks.rl.policies import policy_digest

    policy = Path(args.policy).resolve()
    policy_settings: dict[str, Any] = {
        "policy": str(policy),
        "sha256": policy_digest(policy),
        "goal": list(task.goal),
        "box_mass": task.box_mass,
    }
    if args.allow_pickle:  # recorded only when given: the runs made without it keep their config
        policy_settings["allow_pickle"] = True
    if refine is not None:
        from benchmarks.rl.warmstart import (
            WARM_START_DESIGNER,
            check_warm_settings,
            warm_sigma0,
            warm_start_proposal,
        )

        settings = unique_pairs(args.option, "--option")
        unknown = sorted(set(settings) - set(_WARM_SETTINGS))
        if unknown:
            raise ValueError(
                f"--option {unknown[0]}=...: the warm-started design takes "
                f"{' and '.join(_WARM_SETTINGS)} only"
            )
        try:
            sigma0, popsize = check_warm_settings(
                settings.get("sigma0"), settings.get("popsize", 8)
            )
        except (TypeError, ValueError) as error:
            raise type(error)(f"--option {error}") from None
        if sigma0 is None:
            # Resolved here from the policy's spread (docs/rl.md), so that the run folder
            # records the step size its CMA-ES started with, not only where it came from.
            _, spread = warm_start_proposal(
                policy,
                task.goal,
                box_mass=task.box_mass,
                sha256=policy_settings["sha256"],
                allow_pickle=bool(args.allow_pickle),
            )
            sigma0 = warm_sigma0(spread)
        policy_settings.update(sigma0=sigma0, popsize=popsize)
        return {
            "optimizer": WARM_START_DESIGNER,
            "optimizer_settings": policy_settings,
            "seed": _DEFAULTS["seed"] if args.seed is None else args.seed,
            "iterations": refine + 1,
            "batch_size": 1,
            "executor": args.executor or "serial",
        }
    return {
        "optimizer": POLICY_DESIGNER,
        "optimizer_settings": policy_settings,
        "seed": 0,
        "iterations": 1,
        "batch_size": 1,
        "executor": args.executor or "serial",
    }


#: The ``--option`` settings of a warm-started design (``--policy CARD --refine N``).
_WARM_SETTINGS = ("sigma0", "popsize")

#: Most refinement evaluations: the iterations of a design run are not bounded, but a
#: warm-started design is one evaluation per iteration, serial; 10^5 is hours.
REFINE_MAX = 100_000


def _refine(args: argparse.Namespace) -> int | None:
    """``--refine N`` checked (None when not given)."""
    refine = getattr(args, "refine", None)
    if refine is None:
        return None
    if args.policy is None:
        raise ValueError("--refine refines a saved policy's design: give the policy with --policy")
    if isinstance(refine, bool) or not isinstance(refine, int) or not 0 <= refine <= REFINE_MAX:
        raise ValueError(f"--refine must be an int from 0 to {REFINE_MAX}, got {refine!r}")
    return refine


def _tool_and_arm(args: argparse.Namespace) -> tuple[str, dict[str, Any]]:
    """The section and the scene: as given; with --policy, the policy's where not given."""
    section, scene = args.section_shape, unique_pairs(args.scene, "--scene")
    if args.policy is not None:
        from benchmarks.rl.policies import read_policy_card

        card = read_policy_card(args.policy)  # the task it was trained with (docs/rl.md)
        section = section or card["section_shape"]
        scene.setdefault("merge_fixed_links", card["merge_fixed_links"])
    return section or DEFAULT_SECTION_SHAPE, scene


def config_from_args(args: argparse.Namespace) -> DesignConfig:
    """The :class:`DesignConfig` of parsed ``tooldesign design`` arguments."""
    section_shape, scene = _tool_and_arm(args)
    return DesignConfig(
        **_designer(args),
        workers=args.workers,
        scheduler=args.scheduler,
        max_retries=args.max_retries,
        goal=task_goal(args),
        goal_precision=args.goal_precision,
        box_mass=box_mass_flag(args),
        estimator=args.estimator,
        objective=args.objective,
        scene_samples=args.scene_samples,
        section_shape=section_shape,
        scene=scene,
        task_name=args.task,
    )


def success_word(succeeded: bool | None) -> str:
    """What ``tooldesign design`` prints for a design's outcome: None (not stored) is unknown."""
    return {True: "success", False: "no success", None: "success unknown"}[succeeded]


def _counts_text(counts: dict[str, int]) -> str:
    text = (
        f"evaluations: {counts['total']} ({counts['ok']} ok, {counts['invalid']} invalid, "
        f"{counts['failed']} failed)"
    )
    if counts["failed"]:
        text += "; each failure's message is in the warnings above"
    return text


def _check_optimizer(name: str | None) -> None:
    """Refuse an unknown optimizer name now, as ``optimizers.make`` would once the run starts."""
    from optimizers import make, registry

    if name is None or not name.strip() or ":" in name or name in registry.available():
        # A known name (a plugin string is imported and checked when the run starts), or an
        # empty one, which _designer refuses in its own words.
        return
    make(name)  # raises: unknown (ValueError), or its backend is not installed (ImportError)


def _straight_text(free_energy: float, straight: dict[str, Any]) -> str:
    """One line: F against the straight tool's, or nothing if it has no score."""
    theirs = straight.get("free_energy")
    if straight.get("status") != "ok" or not isinstance(theirs, float) or theirs == 0:
        return ""
    change = 100.0 * (free_energy - theirs) / abs(theirs)
    return (
        f"straight tool (C = 0) on the same task: F = {theirs:.6g}; the design's F is "
        f"{abs(change):.1f} % {'lower' if change < 0 else 'higher'}\n"
    )


def _run(args: argparse.Namespace) -> int:
    # Bad input is refused in well under a second, before the run imports the simulation,
    # pandas and the plotting (seconds on a busy machine): the folder, the optimizer's name,
    # then every setting (DesignConfig).
    check_out_folder(args.out)
    if args.policy is not None and args.task != "push":
        # A saved policy was trained on the push task: it has no design for another.
        raise ValueError(
            f"--policy designs for the push task its policy was trained on; --task {args.task} "
            "does not apply (design for another task with an optimizer)"
        )
    if args.policy is None:
        _check_optimizer(args.optimizer)
    config = config_from_args(args)
    from benchmarks.design import run_design
    from benchmarks.design.progress import phase
    from benchmarks.reports import write_design_report

    result = run_design(
        config,
        args.out,
        resume=args.resume,
        progress=not args.no_progress,
        video=not args.no_video,
    )
    with phase(
        f"design {config.optimizer}: drawing Figure 3, robustness.png and report.html",
        enabled=not args.no_progress,
    ):
        write_design_report(result.out_dir)
    coeffs = ", ".join(repr(float(c)) for c in result.coefficients)
    from benchmarks.reports.success import (
        design_succeeded,
        evaluations_success,
        evaluations_success_text,
    )
    from tooldesign_env.tasks import get_task

    task = get_task(config.task_name)
    tolerance = task.tolerance
    # The task's whole test (standing at the goal) with the best row's stored height and tilt,
    # in the run's scene (a --scene box_size changes the box's resting height), as the env's.
    succeeded = design_succeeded(
        result.status,
        result.final_distance,
        task,
        result.card.get("final_height"),
        result.card.get("final_tilt"),
        scene=config.task_scene(),
    )
    stands = ", standing" if "final_height" in result.card else ""
    # The lowest F is not a success: in hook and obstacle the lowest-F design leaves the box
    # off the goal while many other evaluations succeed (docs/tasks.md).
    every = evaluations_success(result.evaluations, task, scene=config.task_scene())
    print(
        f"best design: C = ({coeffs}), F = {result.free_energy!r} "
        f"(goal error {result.goal_error:.6g}, confidence {result.confidence:.6g}, "
        f"final distance {result.final_distance:.4g} m), iteration {result.iteration}, "
        f"candidate {result.candidate}\n"
        f"task {config.task_name}: {success_word(succeeded)} (the box ends "
        f"{result.final_distance:.3f} m from the goal; success within {tolerance:g} m"
        f"{stands})\n"
        f"{evaluations_success_text(every, config.degree)}\n"
        f"{_counts_text(result.card['evaluations'])}\n"
        f"{_straight_text(result.free_energy, result.straight_tool)}"
        f"run folder: {result.out_dir} (open report.html there)"
    )
    return 0
