r"""Issue 31's two targets against what the equivalence rule leaves, counted by callgrind.

Issue 31 asks for (a) a time per evaluation of ``ToolDesign-v0`` at most half of 062b3a0's and
(b) evaluation / floor at most 1.10, the floor being PyBullet's own stepping (the same torques
applied open loop), both under the equivalence rule (docs/performance.md). This script turns
the accounting of docs/performance.md ("Why the targets are out of reach, measured") into two
printed bounds, in instructions, which valgrind's callgrind counts the same on a loaded machine
as on an idle one:

(a) **eval / baseline >= (stepping at the most aggressive settings the rule's tests 1 and 2
    accepted, less all of its collision detection) / 062b3a0's whole evaluation.** Whatever else
    changes, an evaluation steps the physics; the settings below are each the cheapest that
    passed tests 1 and 2 (together they were never judged, which can only lower the bound),
    and collision detection is counted as free, as if cheaper shapes took it all away. Printed
    also with the requests of (b) added, which an evaluation makes whatever the physics
    settings, and, given the baseline's idle-core times (``--seconds``), estimated in time.
(b) **eval / floor >= (floor + the requests the controller and the estimator cannot do
    without) / floor.** The floor does not ask PyBullet for the arm's state, its inverse
    dynamics, the tool-box contact manifold or the Jacobians and mass matrices of the contact
    steps; a computed-torque controller with feedback and the control-confidence estimator do,
    through PyBullet's C API, which is the only way to them the rule leaves. Counted: the C
    loop's ``arm_state`` request whole (joints and link frames, client and server), the
    server's handlers of the other four (none of their client-side overhead) and the client's
    copy of the contact manifold, each less what the floor asks of the same kind. Printed over
    the floor as ``evaluation_at_floor.py`` times it (the world built again and the torques
    replayed open loop), with only the reads of the world (the arm's state, the manifold), and
    over the stepping alone.

For each variant (this tree at its defaults, at ``LOWER_FLOOR`` and at the most aggressive
settings, each with its floors; 062b3a0 at its defaults if its tree is given) the script runs
``preset_callgrind.py --designs N [--floor]`` once under ``valgrind --tool=callgrind
--dump-before=getppid``: the script marks the end of each phase with a ``getppid`` call, so
callgrind writes the start-up and warm-up, the N evaluations and their floors to files of their
own, and a phase's count over N is an evaluation's (or a floor's), without the imports and the
warm-up. It parses the files itself and prints, per evaluation, (i) the whole evaluation, (ii)
PyBullet's stepping with its constraint solver and collision detection, (iii) the C control
loop's work beside stepping: the controller's reads, the contact log and the rest, (iv) what
lies outside the C loop, and the floor; then the two bounds. With ``--designs 4`` it took 14
minutes on a loaded 2-core machine (the start-up and the warm-up under valgrind are about a
minute of CPU a variant); ``--read`` prints again from the files ``--keep`` kept::

    python -m perf.speed.floor_bound /tmp/062b3a0 --designs 4 --keep /tmp/cg
    python -m perf.speed.floor_bound /tmp/062b3a0 --designs 4 --read /tmp/cg \
        --seconds 0.0723 0.0554   # 062b3a0's evaluation and floor, s, evaluation_at_floor.py
    python -m perf.speed.floor_bound --designs 2 --settings defaults   # no baseline: a proxy

where /tmp/062b3a0 is a worktree of 062b3a0 with its C loop built (``evaluation_at_floor.py``
says how). Without it, (a) is taken against this tree's defaults, which ran within a few per
cent of 062b3a0's time on an idle core (docs/performance.md), and says so. ``--keep`` keeps
the callgrind files for ``callgrind_annotate --inclusive=yes FOLDER/defaults.out.2``.

Instruction counts are a proxy of time: a part that runs at a lower rate of instructions per
cycle than the rest (cache misses, divisions) weighs more in seconds than here.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

from perf import _args
from perf.speed.preset_callgrind import PHASE_MARK

HERE = Path(__file__).resolve().parents[2]

#: The settings of the bound (a): LOWER_FLOOR, with each scene field at the most aggressive
#: value that passed tests 1 and 2 of the equivalence rule (docs/performance.md, "Issue 31,
#: staged", the candidates' table). Not judged together, so never a preset: a lower bound only.
AGGRESSIVE = {
    "solver_iterations": 10,
    "rest_time": 0.025,
    "rest_speed": 2e-3,
    "box_settle_time": 0.0,
}

#: This tree's settings the script can count, from the dearest to the cheapest.
SETTINGS = ("defaults", "lower-floor", "most aggressive")

#: What the script counts: each part is the inclusive count of these functions (their names
#: as callgrind prints them, without the argument list or a compiler's clone suffix such as
#: ``.isra.0``), summed; none calls another. ``arm_state`` is the C loop's own request of the
#: arm's joints and link frames (forward kinematics on), client and server; the others are
#: PyBullet's server answering a request, or its client copying the answer.
PARTS: dict[str, tuple[str, ...]] = {
    "stepping": ("btDiscreteDynamicsWorld::stepSimulation",),
    "solver": ("btMultiBodyDynamicsWorld::solveConstraints",),
    "solver iterations": (
        "btSequentialImpulseConstraintSolver::solveGroupCacheFriendlyIterations",
    ),
    "collision": ("btCollisionWorld::performDiscreteCollisionDetection",),
    "python stepping": ("pybullet_stepSimulation",),
    "c loop": ("executePluginCommand_tooldesign",),
    "arm state": ("arm_state",),
    "inverse dynamics": ("PhysicsServerCommandProcessor::processInverseDynamicsCommand",),
    "contact query": (
        "PhysicsServerCommandProcessor::processRequestContactpointInformationCommand",
    ),
    "contact copy": ("PhysicsDirect::processContactPointData",),
    "jacobians": ("PhysicsServerCommandProcessor::processCalculateJacobianCommand",),
    "mass matrices": ("PhysicsServerCommandProcessor::processCalculateMassMatrixCommand",),
}
#: The parts an evaluation must contain (the others may be zero: no Python stepping with
#: ``box_settle_time=0``).
REQUIRED = ("stepping", "solver", "collision", "c loop", "arm state", "inverse dynamics")

#: The requests (b) counts as what the controller and the estimator cannot do without, each
#: less what the floor asks of the same kind (the world's build asks the same in both).
NEEDED = (
    "arm state",
    "inverse dynamics",
    "contact query",
    "contact copy",
    "jacobians",
    "mass matrices",
)
#: Of them, what no computation of ours could replace: reading the world.
READS_ONLY = ("arm state", "contact query", "contact copy")


@dataclass(frozen=True, kw_only=True)
class Profile:
    """One callgrind output: its total and each function's inclusive count.

    Attributes:
        total: instructions of the whole run (the file's ``totals:``, else the sum of all).
        inclusive: by function name, its own instructions and those of its callees; a direct
            call of a function to itself is not counted twice.
        calls: by function name, how many times it was called.
    """

    total: int
    inclusive: dict[str, int]
    calls: dict[str, int]

    def count(self, names: tuple[str, ...]) -> int:
        """The inclusive instructions of the functions ``names``, summed.

        A name matches a function called so, with or without an argument list or a clone
        suffix: ``f`` matches ``f``, ``f(int)`` and ``f.isra.0``, not ``f2`` nor ``g::f``.
        """
        return sum(
            cost
            for function, cost in self.inclusive.items()
            if _CLONE.sub("", function.split("(", 1)[0]) in names
        )


#: A compiler's suffix of a function's copy: ``box_state.isra.0``, ``f.constprop.1.cold``.
_CLONE = re.compile(r"(\.(isra|constprop|part|cold|lto_priv)(\.\d+)?)+$")
_NAMED = re.compile(r"\((\d+)\)(?:\s+(.*))?")


def parse_callgrind(text: str) -> Profile:
    """Read a callgrind output file (the format of valgrind's callgrind, version 1).

    Names compressed as ``fn=(id) name`` and then ``fn=(id)`` are resolved; the event counted is
    ``Ir`` (else the first). Inclusive counts are the function's own cost lines plus the costs
    of its calls (the line after each ``calls=``), as ``callgrind_annotate --inclusive=yes``
    adds them.

    Raises:
        ValueError: the text is not a callgrind output (no ``events:`` line before the costs).
    """
    names: dict[str, str] = {}
    positions = 1
    event: int | None = None
    total: int | None = None
    own: dict[str, int] = defaultdict(int)
    called: dict[str, int] = defaultdict(int)
    calls: dict[str, int] = defaultdict(int)
    function = ""
    callee = ""
    pending_call = False
    skip_next = False

    def name_of(value: str) -> str:
        match = _NAMED.fullmatch(value.strip())
        if not match:
            return value.strip()
        key, name = match.groups()
        if name is not None:
            names[key] = name
        return names.get(key, f"({key})")

    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if skip_next:
            skip_next = False
            continue
        head, sep, value = line.partition("=")
        if sep and head in {"fn", "cfn", "cfni"}:
            if head == "fn":
                function = name_of(value)
            else:
                callee = name_of(value)
            continue
        if sep and head in {"ob", "fl", "fi", "fe", "cob", "cfi", "cfl"}:
            continue
        if sep and head == "calls":
            calls[callee] += int(value.split()[0])
            pending_call = True
            continue
        if sep and head in {"jump", "jcnd"}:
            skip_next = True  # the jump's source position follows, with no cost
            continue
        key, colon, rest = line.partition(":")
        if colon and re.fullmatch(r"[A-Za-z][\w ]*", key):
            if key == "positions":
                positions = len(rest.split())
            elif key == "events":
                events = rest.split()
                event = events.index("Ir") if "Ir" in events else 0
            elif key in {"totals", "summary"} and event is not None:
                fields = rest.split()
                total = int(fields[event]) if event < len(fields) else 0
            continue
        if event is None:
            raise ValueError("not a callgrind output: a cost line comes before any 'events:'")
        fields = line.split()[positions:]
        cost = int(fields[event]) if event < len(fields) else 0
        if pending_call:
            pending_call = False
            if callee != function:
                called[function] += cost
        else:
            own[function] += cost
    if event is None:
        raise ValueError("not a callgrind output: no 'events:' line")
    inclusive = {f: own.get(f, 0) + called.get(f, 0) for f in set(own) | set(called)}
    return Profile(
        total=total if total is not None else sum(own.values()),
        inclusive=inclusive,
        calls=dict(calls),
    )


def per_evaluation(profile: Profile, n: int) -> dict[str, float]:
    """The counts of ``n`` evaluations (or floors) over ``n``: the total and each part."""
    if n < 1:
        raise ValueError(f"n must be an int >= 1, got {n!r}")
    out = {"total": profile.total / n}
    for part, functions in PARTS.items():
        out[part] = profile.count(functions) / n
    return out


def breakdown(evaluation: dict[str, float], floor: dict[str, float] | None) -> dict[str, float]:
    """Rows (i)-(iv) of an evaluation and the two bounds' numerators, instructions each.

    Args:
        evaluation: :func:`per_evaluation` of the evaluations.
        floor: the same of their floors (None when not counted: then the rows that need it,
            the requests beyond the floor's, are left out).
    """
    rows = {
        "evaluation": evaluation["total"],
        "stepping": evaluation["stepping"],
        "solver": evaluation["solver"],
        "solver iterations": evaluation["solver iterations"],
        "collision": evaluation["collision"],
        "stepping in the C loop": evaluation["stepping"] - evaluation["python stepping"],
        "c loop": evaluation["c loop"],
        "outside the C loop": evaluation["total"] - evaluation["c loop"],
    }
    rows["c loop beside stepping"] = rows["c loop"] - rows["stepping in the C loop"]
    if floor is None:
        return rows
    rows["floor"] = floor["total"]
    rows["floor stepping"] = floor["stepping"]
    for part in NEEDED:
        rows[part] = max(evaluation[part] - floor[part], 0.0)
    rows["controller reads"] = rows["arm state"] + rows["inverse dynamics"]
    rows["contact log"] = sum(
        rows[p] for p in ("contact query", "contact copy", "jacobians", "mass matrices")
    )
    rows["rest of the C loop"] = (
        rows["c loop beside stepping"] - rows["controller reads"] - rows["contact log"]
    )
    rows["needed"] = sum(rows[p] for p in NEEDED)
    rows["reads only"] = sum(rows[p] for p in READS_ONLY)
    return rows


def floor_bounds(rows: dict[str, float]) -> dict[str, float]:
    """Bound (b): evaluation / floor can be no lower than these (rows of :func:`breakdown`)."""
    return {
        "over the floor": (rows["floor"] + rows["needed"]) / rows["floor"],
        "over the floor, reads only": (rows["floor"] + rows["reads only"]) / rows["floor"],
        "over the stepping": (rows["stepping"] + rows["needed"]) / rows["stepping"],
    }


def kept(rows: dict[str, float], requests: bool) -> float:
    """What bound (a) keeps of an evaluation (rows of :func:`breakdown`), in instructions.

    The stepping less all its collision detection; with ``requests``, the requests the
    controller and the estimator need too (the row "needed").
    """
    return rows["stepping"] - rows["collision"] + (rows["needed"] if requests else 0.0)


def baseline_bound(
    rows: dict[str, float], baseline_evaluation: float, *, requests: bool = False
) -> float:
    """Bound (a): :func:`kept` / the baseline's whole evaluation, in instructions."""
    if baseline_evaluation <= 0:
        raise ValueError(f"the baseline's evaluation must be > 0, got {baseline_evaluation!r}")
    return kept(rows, requests) / baseline_evaluation


@dataclass(frozen=True, kw_only=True)
class Variant:
    """One tree at one set of settings, as ``preset_callgrind.py`` arguments."""

    label: str
    tree: Path
    argv: tuple[str, ...]
    floor: bool


def count(
    variant: Variant, designs: int, seed: int, out: Path, valgrind: str
) -> tuple[dict[str, float], dict[str, float] | None]:
    """Count ``preset_callgrind.py`` of this tree on ``variant.tree`` under callgrind, once.

    The script marks its phases (``preset_callgrind.mark_phase``), and callgrind writes each
    to a file of its own: ``out.1`` the start-up and the warm-up, ``out.2`` the evaluations,
    ``out.3`` the floors (``variant.floor``).

    Returns:
        :func:`per_evaluation` of the evaluations, then of the floors (None without).

    Raises:
        SystemExit: the run failed, a design was invalid (an invalid design is a cheaper
            evaluation), or callgrind found none of a part's functions.
    """
    # A folder holding only this tree's perf scripts goes first on the path, the measured
    # tree's packages second: perf comes from here, tooldesign_env from the tree.
    lend = out.parent / "perf-from-here"
    if not lend.exists():
        lend.mkdir()
        (lend / "perf").symlink_to(HERE / "perf", target_is_directory=True)
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(lend), str(variant.tree)]),
        "PYTHONHASHSEED": "0",  # the same dict orders in every count
        "OMP_NUM_THREADS": "1",
        "OPENBLAS_NUM_THREADS": "1",
        "MKL_NUM_THREADS": "1",
    }
    command = [
        valgrind,
        "--tool=callgrind",
        f"--dump-before={PHASE_MARK}",
        f"--callgrind-out-file={out}",
        sys.executable,
        "-m",
        "perf.speed.preset_callgrind",
        *variant.argv,
        "--designs",
        str(designs),
        "--seed",
        str(seed),
        *(["--floor"] if variant.floor else []),
    ]
    done = subprocess.run(command, cwd=lend, env=env, capture_output=True, text=True, check=False)
    last = done.stdout.strip().splitlines()[-1:] or [""]
    match = re.search(r"valid (\d+); floors (\d+)", last[0])
    if done.returncode != 0 or not match:
        raise SystemExit(
            f"counting {variant.label} failed (exit {done.returncode}):\n"
            f"{done.stdout[-2000:]}{done.stderr[-2000:]}"
        )
    valid, floors = int(match.group(1)), int(match.group(2))
    if valid != designs:
        raise SystemExit(
            f"{variant.label}: {designs - valid} of the {designs} designs are invalid (an invalid "
            "design is a cheaper evaluation): take fewer --designs or another --seed"
        )
    if floors != (designs if variant.floor else 0):
        raise SystemExit(f"{variant.label}: {floors} floors for {designs} designs")
    phases = 3 if variant.floor else 2
    parts = sorted(out.parent.glob(f"{out.name}.*"))
    if len(parts) != phases:
        raise SystemExit(
            f"{variant.label}: callgrind wrote {len(parts)} parts where the script marks "
            f"{phases} phases: something else in the run called {PHASE_MARK}"
        )
    return read(variant, designs, out)


def read(
    variant: Variant, designs: int, out: Path
) -> tuple[dict[str, float], dict[str, float] | None]:
    """The phases' files of one count (``out.2``, ``out.3``), per evaluation; see :func:`count`.

    Every design was valid (:func:`count` checks it), so there are as many floors as designs.
    """
    files = [Path(f"{out}.{phase}") for phase in ((2, 3) if variant.floor else (2,))]
    absent = [str(path) for path in files if not path.is_file()]
    if absent:
        raise SystemExit(f"{variant.label}: no callgrind file {absent}")
    evaluation = per_evaluation(parse_callgrind(files[0].read_text()), designs)
    missing = [name for part in REQUIRED if evaluation[part] <= 0 for name in PARTS[part]]
    if variant.tree == HERE and missing:
        raise SystemExit(
            f"{variant.label}: callgrind counted nothing in {missing}: this PyBullet or C loop "
            "names them otherwise; find the names with callgrind_annotate --inclusive=yes "
            "on the files --keep keeps"
        )
    if not variant.floor:
        return evaluation, None
    return evaluation, per_evaluation(parse_callgrind(files[1].read_text()), designs)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "baseline",
        type=Path,
        nargs="?",
        default=None,
        help="the baseline source tree (a worktree of 062b3a0 with its C loop built); "
        "without it, bound (a) is taken against this tree's defaults, as a proxy",
    )
    parser.add_argument(
        "--designs",
        type=_args.count(1, 12),
        default=4,
        help="evaluations counted per variant: the straight tool, the hook, then random "
        "designs; all must be valid (default: %(default)s)",
    )
    parser.add_argument("--seed", type=_args.seed, default=0, help="the random designs' seed")
    parser.add_argument(
        "--settings",
        nargs="+",
        choices=SETTINGS,
        default=list(SETTINGS),
        help="this tree's settings to count (default: all); bound (a) takes the last of "
        f"{list(SETTINGS)} among them",
    )
    parser.add_argument(
        "--keep",
        type=Path,
        default=None,
        help="keep the callgrind outputs in this folder (made if missing; default: removed)",
    )
    parser.add_argument(
        "--read",
        type=Path,
        default=None,
        metavar="FOLDER",
        help="count nothing: print from the files an earlier run kept with --keep (give the "
        "same baseline, --designs and --settings)",
    )
    parser.add_argument(
        "--valgrind", default="valgrind", help="the valgrind command (default: %(default)s)"
    )
    parser.add_argument(
        "--seconds",
        nargs=2,
        type=_args.number(0, above=True, unit="s"),
        metavar=("EVALUATION", "FLOOR"),
        default=None,
        help="the baseline's time per evaluation and its floor's, as evaluation_at_floor.py "
        "printed them on an idle core: (a) is then also estimated in time",
    )
    args = parser.parse_args(argv)
    if args.seconds is not None and args.seconds[1] >= args.seconds[0]:
        parser.error(f"--seconds: the floor must take less than the evaluation, got {args.seconds}")
    if (
        args.baseline is not None
        and not (args.baseline / "tooldesign_env" / "__init__.py").is_file()
    ):
        parser.error(f"{args.baseline} has no tooldesign_env package: give a source tree's root")
    if args.keep is not None and args.keep.exists() and not args.keep.is_dir():
        parser.error(f"--keep must be a folder, got the file {args.keep}")
    if args.read is not None and not args.read.is_dir():
        parser.error(f"--read must be a folder that --keep filled, got {args.read}")
    if args.read is None and shutil.which(args.valgrind) is None:
        parser.error(
            f"--valgrind {args.valgrind!r} is not a command on PATH (apt install valgrind)"
        )
    return args


def variants(baseline: Path | None, settings: list[str]) -> list[Variant]:
    """What to count, in the order of :data:`SETTINGS`, then the baseline tree if given.

    This tree's settings with their floors (``most aggressive``: LOWER_FLOOR with
    :data:`AGGRESSIVE`); the baseline at its defaults, its evaluations only (bound (a) needs
    nothing else of it).
    """
    scene = tuple(f"--scene={k}={v!r}" for k, v in AGGRESSIVE.items())
    argv = {
        "defaults": ("--preset", "defaults"),
        "lower-floor": ("--preset", "lower-floor"),
        "most aggressive": ("--preset", "lower-floor", *scene),
    }
    out = [
        Variant(label=name, tree=HERE, argv=argv[name], floor=True)
        for name in SETTINGS
        if name in settings
    ]
    if baseline is not None:
        out.append(Variant(label="baseline", tree=baseline.resolve(), argv=(), floor=False))
    return out


#: The rows printed, in order: (key of breakdown, label); indented labels are parts of the row
#: above them.
ROWS = (
    ("evaluation", "(i) evaluation (env.step)"),
    ("stepping", "(ii) PyBullet's stepping (stepSimulation)"),
    ("solver", "      of it the constraint solver"),
    ("solver iterations", "        of it its iterations"),
    ("collision", "      of it collision detection"),
    ("stepping in the C loop", "      of it in the C loop's rollout"),
    ("c loop beside stepping", "(iii) the C loop beside stepping"),
    ("controller reads", "      the controller's reads"),
    ("arm state", "        the arm's joints and link frames (arm_state)"),
    ("inverse dynamics", "        inverse dynamics"),
    ("contact log", "      the contact log"),
    ("contact query", "        the tool-box contact query"),
    ("contact copy", "        the manifold's copy to the client"),
    ("jacobians", "        Jacobians of the contact steps"),
    ("mass matrices", "        mass matrices of the contact steps"),
    ("rest of the C loop", "      the rest (torques, box state, requests' overhead)"),
    ("outside the C loop", "(iv) outside the C loop (Python, NumPy, build)"),
    ("floor", "floor (build + the same torques open loop)"),
    ("floor stepping", "      of it PyBullet's stepping"),
)


def seconds_bound(
    rows: dict[str, float], floor_rows: dict[str, float], share: float, *, requests: bool = False
) -> float:
    """Bound (a) estimated in time: counts only within the physics, seconds across.

    Instructions of the stepping and of the Python around it take different times (the
    stepping runs more instructions a cycle), so the stepping's share of an evaluation is
    lower in seconds than in instructions. This estimate counts instructions only between
    like and like, the cheapest stepping (less collision detection) against the floor at the
    defaults (the physics of 062b3a0, bit for bit), and takes the floor's share of the
    baseline's evaluation from the clock.

    Args:
        rows: :func:`breakdown` at the cheapest settings.
        floor_rows: :func:`breakdown` at the defaults, with its floor.
        share: the baseline's floor over its evaluation, in seconds.
        requests: count the requests the controller and the estimator need too (:func:`kept`).
    """
    return kept(rows, requests) / floor_rows["floor"] * share


def report(
    table: dict[str, dict[str, float]],
    baseline_label: str | None,
    cheapest: str,
    seconds: tuple[float, float] | None = None,
) -> list[str]:
    """The printed lines: the table of rows (i)-(iv) and the two bounds.

    ``seconds`` is the baseline's (evaluation, floor) in s, for (a) estimated in time.
    """
    labels = list(table)
    width = max(len(label) for _, label in ROWS) + 2
    lines = [
        f"{'millions of instructions per evaluation':<{width}}"
        + "".join(f"{label:>17}" for label in labels),
    ]
    lines.append("-" * len(lines[0]))
    for key, label in ROWS:
        cells = [
            f"{table[v][key] / 1e6:>17.1f}" if key in table[v] else f"{'':>17}" for v in labels
        ]
        if any(cell.strip() for cell in cells):
            lines.append(f"{label:<{width}}" + "".join(cells))
    against = baseline_label or "defaults"
    lines.append("")
    cheap = table[cheapest]
    with_requests = "needed" in cheap
    if against in table:
        proxy = "" if baseline_label else " (no baseline tree given: this tree's defaults, a proxy)"
        base = table[against]["evaluation"]
        line = (
            f"(a) eval / baseline >= (stepping at {cheapest}, {cheap['stepping'] / 1e6:.1f} M, "
            f"less all its collision detection, {cheap['collision'] / 1e6:.1f} M) / {against}'s "
            f"evaluation ({base / 1e6:.1f} M){proxy}: {baseline_bound(cheap, base):.3f}"
        )
        if with_requests:
            line += (
                f"; with the requests the controller and the estimator need "
                f"({cheap['needed'] / 1e6:.1f} M): "
                f"{baseline_bound(cheap, base, requests=True):.3f}"
            )
        lines.append(line + "   (target <= 0.5)")
    else:
        lines.append("(a) not counted: it needs the baseline tree or --settings defaults")
    if seconds is not None and "floor" in table.get("defaults", {}):
        evaluation, floor = seconds
        share = floor / evaluation
        line = (
            f"(a) in time, estimated: the same over the floor at defaults, in instructions, x "
            f"the baseline's floor / evaluation in seconds ({floor:g} / {evaluation:g}): "
            f"{seconds_bound(cheap, table['defaults'], share):.3f}"
        )
        if with_requests:
            line += (
                "; with the requests: "
                f"{seconds_bound(cheap, table['defaults'], share, requests=True):.3f}"
            )
        lines.append(line + "   (target <= 0.5)")
    elif seconds is not None:
        lines.append("(a) in time not estimated: it needs --settings defaults (its floor)")
    for label in labels:
        if "floor" not in table[label]:
            continue
        bounds = floor_bounds(table[label])
        lines.append(
            f"(b) eval / floor at {label} >= {bounds['over the floor']:.3f} over the floor "
            f"(the needed requests {table[label]['needed'] / 1e6:.1f} M: the arm's state, "
            "inverse dynamics, the contact manifold, Jacobians, mass matrices), "
            f"{bounds['over the floor, reads only']:.3f} with only the arm's state and the "
            f"contact manifold, {bounds['over the stepping']:.3f} over the stepping alone   "
            "(target <= 1.10)"
        )
    return lines


def main(argv: list[str] | None = None) -> None:
    """Count, then print the table and the bounds."""
    args = parse_args(argv)
    chosen = variants(args.baseline, args.settings)
    table: dict[str, dict[str, float]] = {}
    with tempfile.TemporaryDirectory(prefix="floor-bound-") as scratch:
        folder = Path(scratch) / "counts"
        folder.mkdir()
        for variant in chosen:
            stem = re.sub(r"\W+", "-", variant.label).strip("-")
            if args.read is not None:
                evaluation, floor = read(variant, args.designs, args.read / f"{stem}.out")
            else:
                print(f"counting {variant.label} ({variant.tree}) ...", flush=True)
                out = folder / f"{stem}.out"
                evaluation, floor = count(variant, args.designs, args.seed, out, args.valgrind)
            table[variant.label] = breakdown(evaluation, floor)
        if args.keep is not None:
            args.keep.mkdir(parents=True, exist_ok=True)
            for path in folder.glob("*.out*"):
                shutil.copy2(path, args.keep / path.name)
    print(
        f"\ncallgrind, {args.designs} designs per variant (the straight tool, the hook, random "
        f"seed {args.seed}); per evaluation: the phase's count over {args.designs}; "
        f"most aggressive = lower-floor with {AGGRESSIVE}\n"
    )
    baseline_label = "baseline" if args.baseline is not None else None
    cheapest = [name for name in SETTINGS if name in args.settings][-1]
    seconds = None if args.seconds is None else (args.seconds[0], args.seconds[1])
    print("\n".join(report(table, baseline_label, cheapest, seconds)))


if __name__ == "__main__":
    main()
