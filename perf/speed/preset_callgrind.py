r"""Evaluations at a physics preset, to be counted by valgrind's callgrind.

Instruction counts do not depend on the machine's load, so a preset's cost against the
defaults' is measured in them on a shared machine (``docs/performance.md``, "The preset,
measured"). The script makes ``ToolDesign-v0`` at ``--preset`` (``defaults``: the specs'
defaults), with the ``SceneSpec`` fields of ``--scene`` on top of it, warms it with one
evaluation (the plan, imports, caches), then evaluates the first ``--designs`` of the straight
tool, the hook and uniform random cubics (seed ``--seed``). Count it twice, with ``--designs N``
and ``--designs 0``: the difference over N is the cost of an evaluation, without the imports
and the warm-up::

    for n in 0 4; do valgrind --tool=callgrind --callgrind-out-file=/tmp/cg-$n.out \
        python -m perf.speed.preset_callgrind --preset lower-floor --designs $n; done
    callgrind_annotate --inclusive=yes /tmp/cg-4.out | grep -E "TOTALS|apply_and_step|eigvalsh"

With ``--floor``, the evaluations are followed by their floors, as ``evaluation_at_floor.py``
times them: for each valid design, the same world built again and the evaluation's simulated
torques applied open loop (``ToolSimulator.replay_open_loop``), with the geometry the
evaluation made.

Between its phases the script calls ``getppid``, which nothing else in a run calls, so that
one count splits them: with ``--dump-before=getppid`` callgrind writes the start-up and the
warm-up to ``OUT.1``, the evaluations to ``OUT.2``, the floors (``--floor``) to ``OUT.3`` and
the exit to ``OUT``; ``OUT.2`` over N is then an evaluation, as the two counts above give it.
``floor_bound.py`` counts that way::

    valgrind --tool=callgrind --dump-before=getppid --callgrind-out-file=/tmp/cg.out \
        python -m perf.speed.preset_callgrind --designs 3 --floor
    callgrind_annotate --inclusive=yes /tmp/cg.out.2 | grep -E "TOTALS|stepSimulation"

With ``--preset defaults`` and no ``--scene`` the script imports nothing that 062b3a0 lacked, so
it also counts an older tree: run it from a folder without a package, with
``PYTHONPATH=OLD_TREE:THIS_TREE`` (this tree only lends ``perf``).

Run it with the Python binary itself, not a shell shim such as pyenv's, which valgrind would
count instead (``python -c "import sys; print(sys.executable)"`` names it).
"""

from __future__ import annotations

import argparse
import os
from dataclasses import replace
from typing import Any

import numpy as np

from perf import _args
from perf.speed.physics_options import add_scene_option

#: The C function ``mark_phase`` calls: ``valgrind --tool=callgrind --dump-before=`` it.
PHASE_MARK = "getppid"

#: The name under which the env module calls the tool's maker (``--floor`` wraps it there).
MAKE_TOOL = "make_tool"


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--preset",
        default="defaults",
        help="the physics preset, a name of tooldesign_env.specs.PHYSICS_PRESETS, or defaults "
        "(the specs' defaults; the default)",
    )
    parser.add_argument(
        "--designs",
        type=_args.count(0),
        default=4,
        help="evaluations after the warm-up (0 counts the warm-up alone; default: %(default)s)",
    )
    parser.add_argument("--seed", type=_args.seed, default=0, help="the random designs' seed")
    add_scene_option(parser, "a SceneSpec field set on top of the preset's")
    parser.add_argument(
        "--floor",
        action="store_true",
        help="follow each evaluation by its floor: the same world, the same torques open loop",
    )
    args = parser.parse_args(argv)
    if args.preset != "defaults":
        # Imported only here: an older tree (062b3a0) has no presets, and counts its defaults.
        from tooldesign_env.specs import PHYSICS_PRESETS

        if args.preset not in PHYSICS_PRESETS:
            allowed = ["defaults", *sorted(PHYSICS_PRESETS)]
            parser.error(f"--preset must be one of {allowed}, got {args.preset!r}")
    args.scene_spec = _args.check_scene(parser, args) if args.scene else None
    return args


def mark_phase() -> None:
    """Mark the end of a phase: a call of ``getppid``, which nothing else in a run makes.

    Under ``valgrind --tool=callgrind --dump-before=getppid`` each mark writes the counts so
    far to a part file of their own (``OUT.1``, ``OUT.2``, ...; the exit's in ``OUT``).
    """
    os.getppid()


def main(argv: list[str] | None = None) -> None:
    """Evaluate and exit; the counting is valgrind's."""
    args = parse_args(argv)
    import tooldesign_env.env as env_module
    from tooldesign_env import ToolDesignEnv, make_tool

    kwargs: dict[str, Any] = {}
    if args.preset != "defaults":
        from tooldesign_env.specs import physics_preset

        kwargs = physics_preset(args.preset).specs()
    if args.scene_spec is not None:
        # The fields given, on top of the preset's (specs() would put the preset's back).
        given = dict(args.scene)
        kwargs["scene"] = replace(kwargs.get("scene", args.scene_spec), **given)
    env = ToolDesignEnv(**kwargs)
    made: list[Any] = []
    if args.floor:
        # The geometry env.step makes, kept for the floor: making it again would count the
        # tool's mesh and mass properties as part of the floor.
        def keep(*a: Any, **k: Any) -> Any:
            made.append(make_tool(*a, **k))
            return made[-1]

        setattr(env_module, MAKE_TOOL, keep)
    try:
        env.reset(seed=0)
        env.step(np.zeros(3))  # warm
        rng = np.random.default_rng(args.seed)
        designs = [np.zeros(3), np.array([0.0, 1.5, 0.0])]
        randoms = rng.uniform(
            [-1.5, -1.5, -0.5], [1.5, 1.5, 0.5], size=(max(args.designs - 2, 0), 3)
        )
        designs += list(randoms)
        replays = []
        valid = 0
        mark_phase()  # 1: start-up and warm-up
        for coefficients in designs[: args.designs]:
            info = env.step(coefficients)[4]
            valid += bool(info["valid"])
            if args.floor and info["valid"]:
                series = env._last_series
                assert series is not None
                torques = np.asarray(series["torques"])[: info["fast_forward_from"]]
                replays.append((made[-1], torques))
        mark_phase()  # 2: the evaluations
        for geometry, torques in replays:
            env.simulator.replay_open_loop(geometry, torques)
        if args.floor:
            mark_phase()  # 3: the floors
    finally:
        if args.floor:
            setattr(env_module, MAKE_TOOL, make_tool)
        env.close()
    # floor_bound.py reads this line.
    print(
        f"{args.designs} evaluations at {args.preset} after one warm-up evaluation; "
        f"valid {valid}; floors {len(replays)}"
    )


if __name__ == "__main__":
    main()
