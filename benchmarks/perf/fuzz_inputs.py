# mypy: disable-error-code="misc"
# (the lambdas bind loop variables through default arguments, whose types mypy cannot infer)
"""Fuzz every public entry point with bad and corner-case inputs; count the ones that fail badly.

Tries booleans, strings, None, NaN, +-inf, +-1e308, 10**400, negative and zero values and
malformed sequences on:

* the env constructor (every keyword), ``reset`` options and the action check of ``step``;
* every registered optimizer (bounds, batch size, seed) and ``tell`` values;
* ``DesignConfig`` fields (the configuration of ``tooldesign design`` and of suites);
* every flag of ``tooldesign design`` and ``tooldesign evaluate``, run in this process with
  ``--out`` pointing at an existing FILE, so no valid combination starts a simulation.

A GOOD outcome is a ``TypeError``/``ValueError`` (or exit code 2 with one line and no traceback
on the command line), or acceptance of a value that is a valid number for its field. A BAD
outcome is any other exception, a hang (more than ``--timeout`` s), or a bool, string or
non-finite number accepted where a number is expected.

Run: ``python benchmarks/perf/fuzz_inputs.py [--random 2000] [--seed 0] [--steps 0]``.
``--steps N`` also simulates N random actions (corners of the action space included) and checks
that reward and F are finite. Exit code 1 when any outcome is bad.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import io
import math
import os
import signal
import sys
import tempfile
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

NASTY: list[Any] = [
    True,
    False,
    np.bool_(True),
    "20",
    "no",
    "",
    None,
    float("nan"),
    float("inf"),
    -float("inf"),
    1e308,
    -1e308,
    10**400,
    -(10**400),
    0,
    0.0,
    -1,
    -1e-300,
    5e-324,
    2**63,
    99999999999999999999,
    [],
    [1.0],
    [[1.0, 2.0]],
    {"a": 1},
    np.float32("nan"),
    np.int64(-5),
    object(),
    1j,
]


def _is_number(value: Any) -> bool:
    """A finite real number that is not a bool."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(
        value, (int, float, np.integer, np.floating)
    ):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def _number_or_none(value: Any) -> bool:
    """None means "the default" (workers) or "fresh entropy" (seed)."""
    return value is None or _is_number(value)


def _is_float_non_finite(value: Any) -> bool:
    return isinstance(value, (float, np.floating)) and not math.isfinite(value)


class Tally:
    """Counts outcomes and remembers the bad ones."""

    def __init__(self) -> None:
        self.tried = 0
        self.bad: list[str] = []

    def check(
        self,
        label: str,
        call: Callable[[], Any],
        value: Any,
        allowed: Callable[[Any], bool] = lambda v: _is_number(v),
    ) -> None:
        """Run ``call`` and count a bad outcome.

        Bad: an exception other than TypeError/ValueError, a hang, or acceptance of ``value``
        although ``allowed(value)`` is false.
        """
        self.tried += 1
        try:
            with _deadline(TIMEOUT):
                call()
        except (TypeError, ValueError):
            return
        except _Hang:
            self.bad.append(f"{label}: hang over {TIMEOUT} s")
            return
        except Exception as error:  # noqa: BLE001  (that is what is counted)
            self.bad.append(f"{label}: {type(error).__name__}: {error}"[:300])
            return
        if not allowed(value):
            self.bad.append(f"{label}: accepted {value!r}")


TIMEOUT = 20.0


class _Hang(Exception):
    pass


@contextlib.contextmanager
def _deadline(seconds: float) -> Iterator[None]:
    def _raise(signum: int, frame: Any) -> None:
        raise _Hang

    previous = signal.signal(signal.SIGALRM, _raise)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _random_values(rng: np.random.Generator, n: int) -> list[Any]:
    """Random magnitudes over the whole float64 range, both signs, and random nasty items."""
    out: list[Any] = []
    for _ in range(n):
        kind = rng.integers(4)
        if kind == 0:
            out.append(float(rng.choice([-1, 1]) * 10.0 ** rng.uniform(-320, 308)))
        elif kind == 1:
            out.append(int(rng.integers(-(2**62), 2**62)) * int(rng.choice([1, 10**20])))
        elif kind == 2:
            out.append(NASTY[int(rng.integers(len(NASTY)))])
        else:
            out.append(float(rng.normal()))
    return out


def fuzz_env(tally: Tally, values: list[Any]) -> None:
    """Env constructor keywords, reset options and the action check."""
    from tooldesign_env import ToolDesignEnv

    env = ToolDesignEnv()
    for v in values:
        for key in ("goal_precision", "box_mass"):
            tally.check(
                f"ToolDesignEnv({key}={v!r})",
                lambda k=key, x=v: ToolDesignEnv(**{k: x}).close(),
                value=v,
                allowed=lambda x: x is None or _is_number(x),  # None: the default
            )
        tally.check(
            f"ToolDesignEnv(randomize_goal={v!r})",
            lambda x=v: ToolDesignEnv(randomize_goal=x).close(),
            value=v,
            allowed=lambda x: isinstance(x, (bool, np.bool_)),
        )
        for goal in ((v, 1.5, 0.1), (0.0, v, 0.1)):
            tally.check(
                f"ToolDesignEnv(goal={goal!r})",
                lambda g=goal: ToolDesignEnv(goal=g).close(),
                value=v,
            )
        tally.check(
            f"ToolDesignEnv(goal={v!r})",
            lambda x=v: ToolDesignEnv(goal=x).close(),
            value=v,
            allowed=lambda x: False,
        )
        tally.check(
            f"ToolDesignEnv(bounds=[[-1, {v!r}]] * 3)",
            lambda x=v: ToolDesignEnv(bounds=[[-1.0, x]] * 3).close(),
            value=v,
        )
        tally.check(
            f"reset(options={{'box_mass': {v!r}}})",
            lambda x=v: env.reset(options={"box_mass": x}),
            value=v,
        )
        tally.check(
            f"reset(options={{'goal': ({v!r}, 1.5, 0.1)}})",
            lambda x=v: env.reset(options={"goal": (x, 1.5, 0.1)}),
            value=v,
        )
        tally.check(
            f"check_action([{v!r}, 0, 0])",
            lambda x=v: env.check_action([x, 0.0, 0.0]),
            value=v,
        )
    for options in ("goal", 3, [1], {"seed": 1}, {"goal": None}):
        tally.check(
            f"reset(options={options!r})",
            lambda o=options: env.reset(options=o),
            value=options,
            allowed=lambda x: False,
        )
    env.close()


def fuzz_optimizers(tally: Tally, values: list[Any]) -> None:
    """Every registered optimizer: bounds, batch size, seed, and tell values."""
    import optimizers

    for name in optimizers.available():
        for v in values:
            tally.check(
                f"make({name!r}, bounds=[[0, {v!r}]])",
                lambda n=name, x=v: optimizers.make(n, bounds=[[0.0, x]] * 2, batch_size=4),
                value=v,
            )
            for key in ("batch_size", "seed"):
                tally.check(
                    f"make({name!r}, {key}={v!r})",
                    lambda n=name, k=key, x=v: optimizers.make(
                        n, bounds=[[0.0, 1.0]] * 2, **{"batch_size": 4, k: x}
                    ),
                    value=v,
                    allowed=_number_or_none if key == "seed" else _is_number,
                )
        opt = optimizers.make(name, bounds=[[0.0, 1.0]] * 2, batch_size=4, seed=0)
        for v in values:
            try:
                batch = opt.ask()
            except Exception as error:  # noqa: BLE001  (an optimizer broken by an earlier tell)
                tally.bad.append(f"{name}.ask() after tells: {type(error).__name__}: {error}")
                break
            # A failed tell must leave the batch pending; a good one ends it. Either way tell
            # the batch with good values afterwards if it is still pending.
            tally.check(
                f"{name}.tell([{v!r}, 1, 1, 1])",
                lambda o=opt, b=batch, x=v: o.tell(b.ids, [x, 1.0, 1.0, 1.0]),
                value=v,
                # None, nan and +-inf are failed evaluations by contract.
                allowed=lambda x: x is None or _is_number(x) or _is_float_non_finite(x),
            )
            with contextlib.suppress(ValueError):
                opt.tell(batch.ids, [1.0] * len(batch.ids))


def fuzz_design_config(tally: Tally, values: list[Any]) -> None:
    """``DesignConfig`` numeric fields."""
    from benchmarks.design import DesignConfig

    for v in values:
        for key in ("seed", "iterations", "batch_size", "workers", "goal_precision", "box_mass"):
            tally.check(
                f"DesignConfig({key}={v!r})",
                functools.partial(DesignConfig, **{key: v}),
                value=v,
                allowed=_number_or_none if key == "workers" else _is_number,
            )
        tally.check(
            f"DesignConfig(bounds=[[0, {v!r}]] * 3)",
            lambda x=v: DesignConfig(bounds=[[0.0, x]] * 3),
            value=v,
        )


CLI_FLAGS = {
    "design": [
        "--seed",
        "--iterations",
        "--batch-size",
        "--workers",
        "--goal-precision",
        "--box-mass",
        "--optimizer",
        "--executor",
        "--option",
    ],
    "evaluate": ["--goal-precision", "--box-mass", "--estimator", "--objective"],
}
CLI_TEXT = [
    "20",
    "1e308",
    "-1e308",
    "1e999",
    "nan",
    "inf",
    "-1",
    "0",
    "True",
    "no",
    "",
    "99999999999999999999",
    "x=1",
    "x=nan",
    "0x10",
    "1_000",
    "--",
    "\x00",
]


def fuzz_cli(tally: Tally) -> None:
    """Every numeric flag of ``design`` and ``evaluate`` with text a user could type."""
    from benchmarks.cli import main

    with tempfile.NamedTemporaryFile(prefix="tooldesign-fuzz-") as existing:
        for command, flags in CLI_FLAGS.items():
            base = [command, "--out", existing.name]
            if command == "evaluate":
                base += ["--coeffs", "0", "0", "0"]
            for flag in flags:
                for text in CLI_TEXT:
                    argv = [*base, flag, text]
                    tally.tried += 1
                    err = io.StringIO()
                    code: Any = None
                    try:
                        with (
                            contextlib.redirect_stderr(err),
                            contextlib.redirect_stdout(io.StringIO()),
                            _deadline(TIMEOUT),
                        ):
                            code = main(argv)
                    except SystemExit as stop:
                        code = stop.code
                    except _Hang:
                        tally.bad.append(f"tooldesign {' '.join(argv)}: hang")
                        continue
                    except Exception as error:  # noqa: BLE001
                        tally.bad.append(f"tooldesign {' '.join(argv)}: {type(error).__name__}")
                        continue
                    lines = [ln for ln in err.getvalue().splitlines() if ln.strip()]
                    message = lines[-1] if lines else ""
                    if code != 2 or "Traceback" in err.getvalue() or "error" not in message:
                        tally.bad.append(
                            f"tooldesign {' '.join(map(repr, argv))}: exit {code!r}, {message!r}"
                        )


def fuzz_steps(tally: Tally, n: int, rng: np.random.Generator) -> None:
    """Simulate ``n`` actions (corners first, then uniform) and check that the reward is finite."""
    from tooldesign_env import ToolDesignEnv

    env = ToolDesignEnv()
    env.reset(seed=0)
    box: Any = env.action_space
    low, high = box.low, box.high
    corners = [np.where(np.array(bits) > 0, high, low) for bits in np.ndindex(*(2,) * low.size)]
    actions = [*corners, *(rng.uniform(low, high) for _ in range(n))][:n]
    for action in actions:
        tally.tried += 1
        _, reward, _, _, info = env.step(action)
        if not (math.isfinite(reward) and math.isfinite(info["free_energy"])):
            tally.bad.append(f"step({action.tolist()}): reward {reward!r}")
    env.close()


def main() -> int:
    """Fuzz and print the counts; exit code 1 if anything failed badly."""
    global TIMEOUT
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--random", type=int, default=200, help="random values on top of the list")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--steps", type=int, default=0, help="simulated random actions")
    parser.add_argument("--timeout", type=float, default=20.0, help="s before a call is a hang")
    args = parser.parse_args()
    TIMEOUT = args.timeout
    os.environ.setdefault("PYTHONWARNINGS", "ignore")
    rng = np.random.default_rng(args.seed)
    values = [*NASTY, *_random_values(rng, args.random)]
    for part in (fuzz_env, fuzz_optimizers, fuzz_design_config):
        tally = Tally()
        part(tally, values)
        _report(part.__name__, tally)
    for name, run in (("fuzz_cli", fuzz_cli), ("fuzz_steps", None)):
        tally = Tally()
        if run is not None:
            run(tally)
        elif args.steps:
            fuzz_steps(tally, args.steps, rng)
        else:
            continue
        _report(name, tally)
    print(f"total: {TOTAL['tried']} inputs tried, {TOTAL['bad']} failed badly")
    return 1 if TOTAL["bad"] else 0


TOTAL = {"tried": 0, "bad": 0}


def _report(name: str, tally: Tally) -> None:
    TOTAL["tried"] += tally.tried
    TOTAL["bad"] += len(tally.bad)
    print(f"{name}: {tally.tried} inputs tried, {len(tally.bad)} failed badly")
    for line in tally.bad[:20]:
        print(f"  BAD {line}")
    sys.stdout.flush()


if __name__ == "__main__":
    sys.exit(main())
