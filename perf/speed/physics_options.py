"""Outcomes and cost of physics options that may lower the floor, side by side with the defaults.

For a fixed set of designs (the straight tool, a hook and uniform random designs in the default
bounds), evaluates each design with the default specs and with each option, in one process,
alternating (so that load on a shared machine hits both alike), and prints per design:

* F, the goal error and the confidence, before and after, and their relative differences;
* the CPU time of ``env.step``, before and after.

Then a summary per option: the median and largest relative difference of each term (to be read
against the noise floor of F per design, ``confidence_noise.py``: about 0.3-0.4 % with the
round section, the default, and 1-1.5 % with the square one), how many
designs are bit for bit the same, and the ratio of median CPU times.

An option is ``spec.field=value`` with spec one of scene, plan, controller, tool, e.g.
``scene.arm_floor_contacts=False``, ``scene.solver_iterations=20``, ``tool.n_segments=15``.
Several options joined by ``+`` are applied together.

Run: ``taskset -c 0 python -m perf.speed.physics_options --designs 32 --repeats 3
[--base spec.field=value] --option scene.arm_floor_contacts=False --option
scene.solver_iterations=25``. ``--base`` changes the defaults themselves and every option with
them: the figures measured before the round section became the default tool's were taken with
``--base "tool.section_shape='square'"``.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import statistics
import time
from typing import Any

import numpy as np

from perf import _args
from tooldesign_env import (
    ControllerSpec,
    PlanSpec,
    SceneSpec,
    ToolDesignEnv,
    ToolSpec,
)

SPECS = {"scene": SceneSpec, "plan": PlanSpec, "controller": ControllerSpec, "tool": ToolSpec}
TERMS = ("free_energy", "goal_error", "confidence")
#: The noise floor of F per design (median relative spread over 0.1 mm nudges of the box), as
#: measured by ``confidence_noise.py`` for each tool section (docs/performance.md).
NOISE_FLOOR = {"round": "0.3-0.4 %", "square": "1-1.5 %"}


def designs(n: int, seed: int) -> list[np.ndarray]:
    """The first n of: the straight tool, a hook, then uniform random designs in the default bounds.

    The same n - 2 random designs as before for n >= 2 (older trees' scripts always ran the
    straight tool and the hook, even for n < 2). ``evaluation_speed.py`` uses it too.
    """
    rng = np.random.default_rng(seed)
    out = [np.zeros(3), np.array([0.0, 1.5, 0.0])]
    out += list(rng.uniform([-1.5, -1.5, -0.5], [1.5, 1.5, 0.5], size=(max(n - 2, 0), 3)))
    return out[:n]


def parse_option(text: str) -> dict[str, dict[str, Any]]:
    """``"scene.a=1+tool.b=2"`` as ``{"scene": {"a": 1}, "tool": {"b": 2}}``.

    Raises:
        ValueError: not ``spec.field=value``, an unknown spec or field, or a value that is not
            a Python literal.
    """
    changes: dict[str, dict[str, Any]] = {}
    for part in text.split("+"):
        target, sep, raw = part.partition("=")
        spec, dot, name = target.strip().partition(".")
        if not sep or not dot:
            raise ValueError(f"option {part!r} must look like spec.field=value")
        if spec not in SPECS:
            raise ValueError(f"option {part!r}: spec must be one of {sorted(SPECS)}")
        fields = {f.name for f in dataclasses.fields(SPECS[spec])}
        if name not in fields:
            raise ValueError(
                f"option {part!r}: {spec} has no field {name!r}; it has {sorted(fields)}"
            )
        try:
            value = ast.literal_eval(raw.strip())
        except (ValueError, SyntaxError):
            raise ValueError(f"option {part!r}: {raw!r} is not a Python literal") from None
        changes.setdefault(spec, {})[name] = value
    return changes


def option(text: str) -> dict[str, dict[str, Any]]:
    """:func:`parse_option` as an argparse type (the type of ``--base``)."""
    try:
        return parse_option(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def scene_field(text: str) -> tuple[str, Any]:
    """``"field=value"``, a ``SceneSpec`` field and a Python literal, as (field, value).

    The argparse type of :func:`add_scene_option`.
    """
    try:
        changes = parse_option(f"scene.{text}")
    except ValueError as error:
        raise argparse.ArgumentTypeError(f"--scene {text!r}: {error}") from None
    if list(changes) != ["scene"] or len(changes["scene"]) != 1:
        raise argparse.ArgumentTypeError(f"--scene takes one field=value, got {text!r}")
    ((name, value),) = changes["scene"].items()
    return name, value


def add_scene_option(parser: argparse.ArgumentParser, description: str) -> None:
    """Add ``--scene FIELD=VALUE`` (repeatable; :func:`scene_field`) to a perf script's parser.

    ``dict(args.scene)`` is then the ``SceneSpec`` fields given, ``{}`` for none.
    """
    parser.add_argument(
        "--scene",
        type=scene_field,
        action="append",
        default=[],
        metavar="FIELD=VALUE",
        help=f"{description} (repeatable; a Python literal)",
    )


def _merged(
    base: dict[str, dict[str, Any]], changes: dict[str, dict[str, Any]]
) -> dict[str, dict[str, Any]]:
    """``changes`` applied on top of ``base`` (spec by spec, field by field)."""
    out = {spec: dict(values) for spec, values in base.items()}
    for spec, values in changes.items():
        out.setdefault(spec, {}).update(values)
    return out


def make_env(changes: dict[str, dict[str, Any]]) -> ToolDesignEnv:
    """An env with the default specs changed by ``changes``."""
    kwargs = {spec: SPECS[spec](**values) for spec, values in changes.items()}
    env = ToolDesignEnv(**kwargs, info_series=True)
    env.reset(seed=0)
    env.step(np.zeros(3))  # warm
    return env


def relative(after: float, before: float) -> float:
    """|after - before| / |before| (0 when both are 0)."""
    if after == before:
        return 0.0
    return abs(after - before) / max(abs(before), 1e-300)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it.

    ``args.option`` is then a list of (text, changes), the changes merged with ``--base``'s, and
    ``args.base`` the changes of ``--base``.
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--designs",
        type=_args.count(1),
        default=32,
        help="designs in all: the straight tool, the hook, then N - 2 random ones (N >= 1; "
        "default: %(default)s)",
    )
    parser.add_argument(
        "--repeats", type=_args.count(1), default=3, help="timed evaluations per design"
    )
    parser.add_argument("--seed", type=_args.seed, default=0, help="the random designs' seed")
    parser.add_argument(
        "--option",
        action="append",
        default=[],
        type=str,
        help="spec.field=value[+...], spec one of " + ", ".join(SPECS) + " (repeatable)",
    )
    parser.add_argument(
        "--base",
        type=option,
        default={},
        help="spec.field=value[+...] applied to the defaults and to every option, e.g. "
        "\"tool.section_shape='square'\" to measure against the paper's square tool",
    )
    parser.add_argument("--quiet", action="store_true", help="summary only")
    args = parser.parse_args(argv)
    if not args.option:
        parser.error("give at least one --option, e.g. --option scene.arm_floor_contacts=False")
    try:  # the values, not only the names: a spec refuses a bad value when it is made
        for spec, values in args.base.items():
            SPECS[spec](**values)
    except (TypeError, ValueError) as error:
        parser.error(f"--base: {error}")
    options = []
    for text in args.option:
        try:
            changes = _merged(args.base, parse_option(text))
        except ValueError as error:
            parser.error(f"--option: {error}")
        try:
            for spec, values in changes.items():
                SPECS[spec](**values)
        except (TypeError, ValueError) as error:
            parser.error(f"--option {text!r}: {error}")
        options.append((text, changes))
    args.option = options
    return args


def main(argv: list[str] | None = None) -> None:
    """Measure and print."""
    args = parse_args(argv)
    common = args.base
    options = args.option
    base = make_env(common)
    tool_shape = base.tool_spec.section_shape
    envs = [make_env(changes) for _, changes in options]
    sample = designs(args.designs, args.seed)
    rows: list[list[dict[str, Any]]] = [[] for _ in options]
    for i, c in enumerate(sample):
        b_info = base.step(c)[4]
        b_times = []
        o_infos = [env.step(c)[4] for env in envs]
        o_times: list[list[float]] = [[] for _ in envs]
        for _ in range(args.repeats):
            t0 = time.process_time()
            base.step(c)
            b_times.append(time.process_time() - t0)
            for j, env in enumerate(envs):
                t0 = time.process_time()
                env.step(c)
                o_times[j].append(time.process_time() - t0)
        for j in range(len(options)):
            o_info = o_infos[j]
            rows[j].append(
                {
                    "design": i,
                    "coefficients": c,
                    "valid": (bool(b_info["valid"]), bool(o_info["valid"])),
                    "before": {t: float(b_info[t]) for t in TERMS},
                    "after": {t: float(o_info[t]) for t in TERMS},
                    "final_distance": (
                        float(b_info["final_distance"]),
                        float(o_info["final_distance"]),
                    ),
                    "identical": all(float(b_info[t]) == float(o_info[t]) for t in TERMS)
                    and np.array_equal(b_info["box_trajectory"], o_info["box_trajectory"]),
                    "time": (statistics.median(b_times), statistics.median(o_times[j])),
                }
            )

    for (text, _), option_rows in zip(options, rows, strict=True):
        print(f"\n=== option {text} vs the defaults, {len(sample)} designs ===")
        if not args.quiet:
            print(
                f"{'#':>3} {'c1':>6} {'c2':>6} {'c3':>6} | {'F before':>10} {'F after':>10} "
                f"{'dF':>7} | {'E before':>10} {'E after':>10} {'dE':>7} | {'C before':>9} "
                f"{'C after':>9} {'dC':>7} | {'d_final':>13} | {'ms':>11}"
            )
            for r in option_rows:
                b, a = r["before"], r["after"]
                c1, c2, c3 = r["coefficients"]
                mark = " =" if r["identical"] else ""
                valid = "" if all(r["valid"]) else f" valid {r['valid']}"
                print(
                    f"{r['design']:>3} {c1:6.2f} {c2:6.2f} {c3:6.2f} | "
                    f"{b['free_energy']:10.1f} {a['free_energy']:10.1f} "
                    f"{100 * relative(a['free_energy'], b['free_energy']):6.2f}% | "
                    f"{b['goal_error']:10.1f} {a['goal_error']:10.1f} "
                    f"{100 * relative(a['goal_error'], b['goal_error']):6.2f}% | "
                    f"{b['confidence']:9.1f} {a['confidence']:9.1f} "
                    f"{100 * relative(a['confidence'], b['confidence']):6.2f}% | "
                    f"{r['final_distance'][0]:6.3f} {r['final_distance'][1]:6.3f} | "
                    f"{1000 * r['time'][0]:5.0f} {1000 * r['time'][1]:5.0f}{mark}{valid}"
                )
        touched = [r for r in option_rows if all(r["valid"])]
        for term in TERMS:
            diffs = [relative(r["after"][term], r["before"][term]) for r in touched]
            if diffs:
                print(
                    f"{term:>12}: relative change median {100 * statistics.median(diffs):.3f} %, "
                    f"max {100 * max(diffs):.3f} % (noise floor of F per design: about "
                    f"{NOISE_FLOOR[tool_shape]})"
                )
        same = sum(r["identical"] for r in option_rows)
        flips = sum(r["valid"][0] != r["valid"][1] for r in option_rows)
        before = statistics.median(r["time"][0] for r in option_rows)
        after = statistics.median(r["time"][1] for r in option_rows)
        per_design = statistics.median(r["time"][1] / r["time"][0] for r in option_rows)
        print(
            f"bit for bit identical (F, terms and box path): {same} of {len(option_rows)}; "
            f"validity changed: {flips}"
        )
        print(
            f"CPU time per evaluation: median {1000 * before:.1f} ms -> {1000 * after:.1f} ms "
            f"(after / before: ratio of medians {after / before:.3f}, median of per-design "
            f"ratios {per_design:.3f})"
        )
    base.close()
    for env in envs:
        env.close()


if __name__ == "__main__":
    main()
