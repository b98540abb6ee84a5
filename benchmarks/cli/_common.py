"""Arguments shared by the commands that evaluate designs."""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from benchmarks.execution import MAX_RETRIES_MAX, TaskSettings
from benchmarks.execution.evaluator import _ESTIMATORS, OBJECTIVES

#: ``tooldesign_env.geometry.SECTION_SHAPES`` and ``ToolSpec().section_shape``, spelled out so
#: that parsing the command line does not import the simulation (a test checks that they agree).
SECTION_SHAPES = ("square", "round")
DEFAULT_SECTION_SHAPE = "round"

#: ``benchmarks.suites.BUILTIN_SUITES`` and ``SIZES``, ``benchmarks.rl.RL_SUITE_NAME`` and the
#: names of ``benchmarks.rl.SIZES``, and ``RetestConfig()``'s ``nudges`` and ``repeats``: the
#: help of ``tooldesign bench`` and ``retest`` names them without importing the simulation.
BUILTIN_SUITES = (
    "optimizers",
    "precision-sweep",
    "robustness",
    "mass-perturbation",
    "optimizer-peers",
    "robust-design",
)
SIZES = ("smoke", "full")
RL_SUITE_NAME = "rl"
RL_SIZES = ("smoke", "short", "full")
PROTOCOL_SUITE_NAME = "protocol"  # benchmarks.protocol.PROTOCOL_SUITE_NAME and its sizes
PROTOCOL_SIZES = ("smoke", "quick", "full")
RETEST_NUDGES, RETEST_REPEATS = 5, 3

#: ``tooldesign_env.default_bounds`` (+-1.5, the linear coefficient +-0.5), ``ACTION_ROUNDING``,
#: ``COEFFICIENT_MAX`` and the geometry's ``DEGREE_MAX``, spelled out so that a design outside
#: the bounds is refused before the simulation is imported (a test checks that they agree).
COEFFICIENT_BOUND, LINEAR_BOUND = 1.5, 0.5
ACTION_ROUNDING = 1e-6
COEFFICIENT_MAX = 1e3
DEGREE_MAX = 20


def shown(path: object) -> str:
    """A path as a message shows it, so that a refusal stays one line.

    As typed, or quoted where it holds a newline or another control character (legal in a name).
    """
    text = str(path)
    return text if text.isprintable() else repr(text)


def _max_retries(text: str) -> int:
    # int() alone would take "1_000" and " 3"; a count is digits only. Booleans are not counts.
    if not text.isascii() or not text.isdigit() or int(text) > MAX_RETRIES_MAX:
        raise argparse.ArgumentTypeError(
            f"must be an int from 0 to {MAX_RETRIES_MAX}, got {text!r}"
        )
    return int(text)


def add_max_retries_argument(parser: argparse.ArgumentParser, default: int | None) -> None:
    """Add ``--max-retries N``: retries of a design whose worker process died (process pool).

    Args:
        parser: The command's parser.
        default: The value when the flag is not given (``None``: the suite's own).
    """
    shown = "the suite's, 0 if it sets none" if default is None else str(default)
    parser.add_argument(
        "--max-retries",
        type=_max_retries,
        default=default,
        metavar="N",
        help="with --executor process: how many more times a design whose worker process died "
        "while it was evaluated alone is evaluated again, alone in a fresh pool, before it is "
        f"logged as failed; 0 to {MAX_RETRIES_MAX} (default: {shown})",
    )


def scene_item(text: str) -> tuple[str, Any]:
    """``FIELD=VALUE`` of ``--scene``: a ``SceneSpec`` field and its value, checked later.

    The value is read as JSON (``false``, ``0.1``, ``[-0.4,1.2]``; Python's ``True`` and
    ``False`` too); anything else is a string (``auto``), which the spec refuses where a
    string is not allowed, naming the field.
    """
    name, sep, value = text.partition("=")
    if not sep or not name.strip() or not value.strip():
        raise argparse.ArgumentTypeError(
            f"must be FIELD=VALUE with a SceneSpec field and its value, e.g. "
            f"merge_fixed_links=false or box_position=[-0.4,1.2]; got {text!r}"
        )
    value = value.strip()
    value = {"True": "true", "False": "false"}.get(value, value)
    try:
        parsed = json.loads(value)
    except ValueError:
        parsed = value
    return name.strip(), parsed


def unique_pairs(pairs: Sequence[tuple[str, Any]], flag: str) -> dict[str, Any]:
    """The ``NAME=VALUE`` pairs of a repeatable flag as a dict, refusing a NAME given twice.

    ``dict(pairs)`` keeps the last value silently; which of two was meant is the user's to say.

    Args:
        pairs: The parsed ``(name, value)`` pairs, in the order given.
        flag: The flag, for the message, e.g. ``"--scene"``.

    Returns:
        ``{name: value}``.

    Raises:
        ValueError: a name is given twice; the message names it and both values.
    """
    out: dict[str, Any] = {}
    for name, value in pairs:
        if name in out:
            raise ValueError(
                f"{flag}: {name} is given twice ({name}={json.dumps(out[name], default=str)} "
                f"and {name}={json.dumps(value, default=str)}); give each once"
            )
        out[name] = value
    return out


def add_scene_argument(parser: argparse.ArgumentParser, what: str) -> None:
    """Add ``--scene FIELD=VALUE`` (repeatable): overrides of ``SceneSpec`` fields."""
    parser.add_argument(
        "--scene",
        type=scene_item,
        action="append",
        default=[],
        metavar="FIELD=VALUE",
        help=f"set a SceneSpec field {what} (repeatable; a JSON value), e.g. box_yaw=0.1 or "
        "merge_fixed_links=false, the 13-link arm of the runs made before 2026-11-25 "
        "(docs/benchmarks.md); not box_mass, a setting of its own",
    )


def out_path(text: str) -> Path:
    """An ``--out`` value: a path that is not empty (an unset variable would mean "here")."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"must name a folder, got {text!r}")
    return Path(text)


def _task_goals_text() -> str:
    """Each registered task's default goal, for ``--goal``'s help: ``push 0 1.5 0.1, ...``."""
    from tooldesign_env.tasks import get_task, task_names

    defaults = []
    for name in task_names():
        try:
            goal = get_task(name).goal
        except (ImportError, TypeError, ValueError):  # a plugin's task that does not load here
            continue
        defaults.append(f"{name} {' '.join(f'{v:g}' for v in goal)}")
    return ", ".join(defaults)


def add_task_arguments(
    parser: argparse.ArgumentParser, *, section_default: str = "", goal_of_task: bool = False
) -> None:
    """Add the task options (goal, p^X, box mass, estimator, objective) to a parser.

    ``section_default`` replaces the words after "default:" in ``--section-shape``'s help, for
    a command whose default depends on other options. ``goal_of_task``: the command takes
    ``--task`` (:func:`add_task_name_argument`), whose default goal ``--goal`` defaults to;
    its help names each task's.

    Their defaults are :class:`TaskSettings`'; every command that evaluates designs takes the
    same options with the same meaning.
    """
    from tooldesign_env.schema import DEFAULT_GOAL

    # The fields' defaults, not TaskSettings(): its checks import the simulation, which --help
    # does not need. Its goal's default is None (the task's goal): push's is DEFAULT_GOAL.
    defaults = argparse.Namespace(
        **{name: f.default for name, f in TaskSettings.__dataclass_fields__.items()}
    )
    defaults.goal = DEFAULT_GOAL
    parser.add_argument(
        "--goal",
        type=float,
        nargs=3,
        default=list(defaults.goal),
        metavar=("X", "Y", "Z"),
        help=(
            f"goal X^g in m (default: the task's: {_task_goals_text()})"
            if goal_of_task
            else f"goal X^g in m (default: {' '.join(f'{v:g}' for v in defaults.goal)})"
        ),
    )
    parser.add_argument(
        "--goal-precision",
        type=float,
        default=defaults.goal_precision,
        metavar="P",
        help="goal precision p^X (default: %(default)s)",
    )
    parser.add_argument(
        "--box-mass",
        type=float,
        default=defaults.box_mass,
        metavar="M",
        help="box mass in kg (default: %(default)s)",
    )
    parser.add_argument(
        "--estimator",
        choices=_ESTIMATORS,
        default=defaults.estimator,
        help="estimator of dX/dU (default: %(default)s)",
    )
    parser.add_argument(
        "--objective",
        choices=OBJECTIVES,
        default=defaults.objective,
        help="what is minimized: F, or the goal error averaged over box masses (the "
        "robust-design baseline) (default: %(default)s)",
    )
    parser.add_argument(
        "--section-shape",
        choices=SECTION_SHAPES,
        default=DEFAULT_SECTION_SHAPE,
        help="the tool's section: round (far less chaotic contact, see docs/model.md), or the "
        f"paper's square (default: {section_default or DEFAULT_SECTION_SHAPE})",
    )
    parser.add_argument(
        "--scene-samples",
        type=int,
        default=1,
        metavar="K",
        help="average F over K scenes whose box differs by a fixed small offset, which smooths "
        "the chaos of pushing; costs K rollouts per design (1 to 64, default: %(default)s)",
    )
    add_scene_argument(parser, "for every evaluation")


def add_task_name_argument(parser: argparse.ArgumentParser) -> None:
    """Add ``--task NAME`` (the registered task, docs/tasks.md); ``--goal`` then defaults to it.

    Read the goal with :func:`task_goal`: without ``--goal`` it is the task's default goal
    (``add_task_arguments(..., goal_of_task=True)`` says so in ``--goal``'s help).
    """
    parser.add_argument(
        "--task",
        default="push",
        metavar="NAME",
        help="the task (docs/tasks.md): push (the paper's, the default), hook, obstacle, puck, "
        "a task an installed package declares (entry-point group tooldesign.tasks), or "
        "MODULE:ATTR naming a TaskDefinition (e.g. my_tasks:WALLED, importable from here); it "
        "sets the scene, the plan, the fixed obstacles and the goal range (without --goal, "
        "the task's default goal)",
    )
    parser.set_defaults(goal=None)


def task_goal(args: argparse.Namespace) -> tuple[float, float, float]:
    """``--goal``, or the default goal of ``--task`` when no goal was given.

    The one check of ``--goal`` of every command that takes ``--task``: each coordinate must
    be a finite number in the task's goal range (push: anywhere in the workspace).

    Raises:
        ValueError: ``--task`` names no task (the message says what is allowed), or a
            coordinate of ``--goal`` is not finite or outside the range (the message names
            the coordinate and the range).
        TypeError: ``--task``'s ``MODULE:ATTR`` names something that is not a TaskDefinition.
    """
    from tooldesign_env.tasks import get_task

    try:
        definition = get_task(args.task)
    except (TypeError, ValueError) as error:
        raise type(error)(f"--task: {error}") from None
    if args.goal is None:
        return definition.goal
    return check_goal_flag(args.goal, definition)


def check_goal_flag(goal: Sequence[float], definition: Any) -> tuple[float, float, float]:
    """``--goal`` (x, y, z) as floats if ``definition`` (a TaskDefinition) takes it.

    Raises:
        ValueError: in one line naming ``--goal``, the coordinate, the range allowed (the
            task's goal range, or the workspace for a task that accepts any goal) and the value.
    """
    from tooldesign_env.specs import WORKSPACE_HALF_WIDTH, WORKSPACE_HEIGHT

    if definition.accepts_any_goal:
        low = (-WORKSPACE_HALF_WIDTH, -WORKSPACE_HALF_WIDTH, 0.0)
        high = (WORKSPACE_HALF_WIDTH, WORKSPACE_HALF_WIDTH, WORKSPACE_HEIGHT)
        where, slack = f"the {definition.name} task takes any goal in the workspace", 0.0
    else:
        low, high = definition.goal_low, definition.goal_high
        # TaskDefinition.check_goal's allowance: a range's edge typed in decimal is taken.
        where, slack = f"the {definition.name} task's goal range", 1e-12
    (x0, y0, z0), (x1, y1, z1) = low, high
    ranges = f"x in [{x0:g}, {x1:g}], y in [{y0:g}, {y1:g}], z in [{z0:g}, {z1:g}] m"
    values = [float(v) for v in goal]
    for axis, value, lo, hi in zip("xyz", values, low, high, strict=True):
        if not (math.isfinite(value) and lo - slack <= value <= hi + slack):
            allowed = f"{lo:g} m" if lo == hi else f"a finite number in [{lo:g}, {hi:g}] m"
            raise ValueError(f"--goal {axis} must be {allowed} ({where}: {ranges}), got {value!r}")
    x, y, z = values
    return (x, y, z)


def box_mass_flag(args: argparse.Namespace) -> float:
    """``--box-mass`` if it is a mass the env takes: the one check of every command.

    Raises:
        ValueError: in one line naming ``--box-mass``, what is allowed and the value.
    """
    from tooldesign_env.specs import BOX_MASS_MAX

    mass = float(args.box_mass)
    if not (math.isfinite(mass) and 0.0 < mass <= BOX_MASS_MAX):
        raise ValueError(
            f"--box-mass must be a finite mass in kg, > 0 and <= {BOX_MASS_MAX:g}, got {mass!r}"
        )
    return mass


def check_out_folder(out: Path, *, empty: bool = False) -> None:
    """Refuse an ``--out`` that is a file (or, with ``empty``, a folder with files) up front.

    The same words as the library's own checks (``benchmarks.storage.check_out_dir`` and
    ``evaluate_coefficients``), said before the command imports the simulation and the
    plotting, which takes seconds.

    Raises:
        ValueError: ``out`` is an existing file, or (``empty``) a folder that is not empty.
    """
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {shown(out)} is a file; give a folder for the run")
    if empty and out.is_dir() and any(out.iterdir()):
        raise ValueError(
            f"--out {out} exists and is not empty; tooldesign evaluate writes a folder of its "
            "own: give a new folder, or delete this one first"
        )


def check_in_default_bounds(coeffs: Sequence[float]) -> None:
    """Refuse a design outside the default bounds as ``tooldesign evaluate`` does, but early.

    Only a design of 1 to ``DEGREE_MAX`` finite coefficients is checked here; anything else is
    left to the library's checks, which say what is wrong with it.

    Raises:
        ValueError: the message of ``evaluate_coefficients`` for a design outside the bounds.
    """
    values = [float(c) for c in coeffs]
    if not 1 <= len(values) <= DEGREE_MAX or not all(math.isfinite(v) for v in values):
        return
    bounds = [[-COEFFICIENT_BOUND, COEFFICIENT_BOUND] for _ in values]
    bounds[-1] = [-LINEAR_BOUND, LINEAR_BOUND]
    slack = [ACTION_ROUNDING * max(max(abs(lo), abs(hi)), hi - lo) for lo, hi in bounds]
    if any(v < lo - d or v > hi + d for v, (lo, hi), d in zip(values, bounds, slack, strict=True)):
        raise ValueError(
            f"design {values} is outside the default bounds {bounds} (as env.step "
            "refuses it); pass --outside-bounds (API: outside_bounds=True) to evaluate it anyway"
        )
