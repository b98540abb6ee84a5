"""Where a rollout's time goes above the physics: each PyBullet call of the control loop, timed.

Every call the control loop makes through ``BulletWorld.control_calls`` is wrapped in a timer
(the wrapper itself costs about 0.4 us a call, a few ms an episode, and is included in the
totals), the rollouts are run with and without the contact log of the contact estimator
(``record_mobility``), alternating, and the script prints, per episode: the time in each call,
the calls per episode, the whole rollout, and what recording the contact log adds (its
Jacobians, mass matrices and their conversion).

These are the calls of the Python loop, which the script runs (``TOOLDESIGN_NATIVE_LOOP=0``): the
default loop runs in C inside PyBullet's server (:mod:`tooldesign_env.native`), where no call can
be timed from Python. The script also times that loop's rollouts on the same designs, alternating
with the Python loop's, and prints both.

Run on one core: ``taskset -c 0 python -m perf.speed.rollout_breakdown [--designs 8]
[--repeats 3]``.
"""

from __future__ import annotations

import argparse
import collections
import os
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import tooldesign_env.bullet as bullet
import tooldesign_env.native as native
from perf import _args
from tooldesign_env import ToolDesignEnv, make_tool
from tooldesign_env.env import default_bounds
from tooldesign_env.geometry import SECTION_SHAPES, ToolSpec
from tooldesign_env.simulation import ToolSimulator


def timed_control_calls(
    seconds: dict[str, float], counts: collections.Counter[str]
) -> Callable[..., Any]:
    """A ``BulletWorld.control_calls`` whose calls add their time to ``seconds[name]``.

    ``seconds`` and ``counts`` are read when a call is made, so the caller may swap their
    contents between rollouts.
    """
    original = bullet.BulletWorld.control_calls
    clock = time.perf_counter

    def wrap(name: str, call: Callable[..., Any]) -> Callable[..., Any]:
        def timed(*args: Any, **kwargs: Any) -> Any:
            start = clock()
            result = call(*args, **kwargs)
            seconds[name] += clock() - start
            counts[name] += 1
            return result

        return timed

    def control_calls(self: bullet.BulletWorld, *args: Any) -> bullet.ControlCalls:
        calls = original(self, *args)
        return calls._replace(**{name: wrap(name, getattr(calls, name)) for name in calls._fields})

    return control_calls


def timed_jacobian_calls(seconds: dict[str, float]) -> Callable[..., Any]:
    """A ``BulletWorld.jacobian_calls`` whose two calls add their time to ``seconds``."""
    original = bullet.BulletWorld.jacobian_calls
    clock = time.perf_counter

    def jacobian_calls(self: bullet.BulletWorld, *args: Any) -> Any:
        def wrap(name: str, call: Callable[..., Any]) -> Callable[..., Any]:
            def timed(q: Any) -> Any:
                start = clock()
                result = call(q)
                seconds[name] += clock() - start
                return result

            return timed

        jacobian, mass_matrix = original(self, *args)
        return wrap("jacobian", jacobian), wrap("mass_matrix", mass_matrix)

    return jacobian_calls


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--designs",
        type=_args.count(1),
        default=8,
        help="designs in all: the straight tool, then random buildable ones (default: %(default)s)",
    )
    parser.add_argument("--repeats", type=_args.count(1), default=3)
    parser.add_argument("--seed", type=_args.seed, default=1, help="the random designs' seed")
    parser.add_argument(
        "--section-shape",
        choices=SECTION_SHAPES,
        default=ToolSpec().section_shape,
        help="the tool's section (default: %(default)s)",
    )
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    """Measure and print."""
    args = parse_args(argv)

    tool = ToolSpec(section_shape=args.section_shape)
    # The env's simulator runs the Python loop: it looks for the C loop at its first rollout,
    # finds it switched off and keeps to Python from then on.
    os.environ[native.ENV_SWITCH] = "0"
    env = ToolDesignEnv(tool=tool)
    env.reset(seed=0)
    env.step(np.zeros(3))  # warm: the plan, imports, caches
    del os.environ[native.ENV_SWITCH]
    sim = env.simulator
    if sim.native_status == "native":
        raise SystemExit("the simulator runs the C loop: this script times the Python loop's calls")
    # The default loop, in C, on the same scene (None where the plugin was not built).
    c_sim = None
    if native.library_path() is not None:
        c_sim = ToolSimulator(
            scene=sim.scene, plan=sim.plan, controller=sim.controller, native_loop=True
        )
    rng = np.random.default_rng(args.seed)
    bounds = default_bounds(3)
    geometries = [make_tool(np.zeros(3), tool)]
    while len(geometries) < args.designs:
        geometry = make_tool(rng.uniform(bounds[:, 0], bounds[:, 1]), tool)
        if geometry.buildable and sim.build(geometry).usable:
            geometries.append(geometry)

    seconds: dict[str, float] = collections.defaultdict(float)
    counts: collections.Counter[str] = collections.Counter()
    bullet.BulletWorld.control_calls = timed_control_calls(seconds, counts)  # type: ignore[method-assign]
    estimator_calls: dict[str, float] = collections.defaultdict(float)
    bullet.BulletWorld.jacobian_calls = timed_jacobian_calls(estimator_calls)  # type: ignore[method-assign]
    # Per mode (with the contact log, without): rollout times, and the calls' totals.
    rollouts: dict[bool, list[float]] = {True: [], False: []}
    c_rollouts: dict[bool, list[float]] = {True: [], False: []}
    calls: dict[bool, dict[str, float]] = {
        True: collections.defaultdict(float),
        False: collections.defaultdict(float),
    }
    made: dict[bool, collections.Counter[str]] = {
        True: collections.Counter(),
        False: collections.Counter(),
    }
    for _ in range(args.repeats):
        for geometry in geometries:
            for record in (True, False):
                sim.build(geometry)
                seconds.clear()
                counts.clear()
                start = time.perf_counter()
                sim.run(record_mobility=record)
                rollouts[record].append(time.perf_counter() - start)
                for name, value in seconds.items():
                    calls[record][name] += value
                made[record].update(counts)
                if c_sim is not None:
                    c_sim.build(geometry)
                    start = time.perf_counter()
                    c_sim.run(record_mobility=record)
                    c_rollouts[record].append(time.perf_counter() - start)
    env.close()
    if c_sim is not None:
        c_sim.close()

    episodes = args.repeats * len(geometries)
    print(f"{len(geometries)} designs x {args.repeats} repeats, one core, without the contact log")
    print(f"{'call':18s} {'ms/episode':>11s} {'us/call':>9s} {'calls/episode':>14s}")
    plain_calls = calls[False]
    for name in sorted(plain_calls, key=plain_calls.__getitem__, reverse=True):
        print(
            f"{name:18s} {1e3 * plain_calls[name] / episodes:11.2f} "
            f"{1e6 * plain_calls[name] / made[False][name]:9.2f} "
            f"{made[False][name] / episodes:14.0f}"
        )
    total_calls = 1e3 * sum(plain_calls.values()) / episodes
    plain = 1e3 * statistics.median(rollouts[False])
    logged = 1e3 * statistics.median(rollouts[True])
    added = statistics.median(a - b for a, b in zip(rollouts[True], rollouts[False], strict=True))
    print(f"all calls: {total_calls:.1f} ms/episode (mean)")
    print(
        f"rollout, median: {plain:.1f} ms without the contact log, {logged:.1f} ms with it "
        f"(median of per-design differences: +{1e3 * added:.1f} ms)"
    )
    estimator = 1e3 * sum(estimator_calls.values()) / episodes
    print(
        f"of which the log's Jacobian and mass-matrix calls (mean): {estimator:.1f} ms "
        f"(jacobian {1e3 * estimator_calls['jacobian'] / episodes:.1f}, mass matrix "
        f"{1e3 * estimator_calls['mass_matrix'] / episodes:.1f})"
    )
    python = 1e3 * statistics.fmean(rollouts[False]) - total_calls
    print(f"rollout without the log, less its calls (mean): {python:.1f} ms of Python")
    if c_sim is None:
        print(f"the C loop: {native.status()}")
        return
    c_plain = 1e3 * statistics.median(c_rollouts[False])
    c_logged = 1e3 * statistics.median(c_rollouts[True])
    print(
        f"the same rollouts in the C loop (the default), median: {c_plain:.1f} ms without the "
        f"contact log, {c_logged:.1f} ms with it (Python loop: {plain:.1f}, {logged:.1f})"
    )


if __name__ == "__main__":
    main()
