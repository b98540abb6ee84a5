# mypy: disable-error-code="misc"
# (the lambdas bind loop variables through default arguments, whose types mypy cannot infer)
"""Every public entry point, fuzzed with bad and corner-case inputs: none may fail badly.

The fuzzer that was ``benchmarks/perf/fuzz_inputs.py``, as Hypothesis properties. Values are
booleans, strings, None, NaN, +-inf, +-1e308, 10**400, negative and zero values and malformed
sequences (:data:`NASTY`) and random magnitudes over the whole float64 and int range, tried on:

* the env constructor (every keyword), ``reset`` options and the action check of ``step``;
* every registered optimizer (bounds, batch size, seed) and ``tell`` values;
* ``DesignConfig`` fields (the configuration of ``tooldesign design`` and of suites);
* every flag of ``tooldesign design`` and ``tooldesign evaluate``, run in this process with
  ``--out`` pointing at an existing FILE, so no valid combination starts a simulation;
* suite config files: every field of a suite (top level, variants, optimizers and their
  settings) set to each value, whole and inside the list or table it belongs in, plus unknown
  keys, written as a JSON file and read by ``load_suite``; random edits of the text of a valid
  JSON and TOML suite file (truncated, characters deleted or inserted, deep nesting, bytes that
  are not UTF-8); and ``tooldesign bench --config FILE --out EXISTING_FILE`` on the bad files;
* the corners of the action space, simulated: reward and F are finite.

A GOOD outcome is a ``TypeError``/``ValueError`` (or exit code 2 with one line and no traceback
on the command line), or acceptance of a value that is valid for its field. For suite configs
the error must also name the field (or the unknown key), so an error from deep inside (say
"unhashable type") counts as bad. A BAD outcome is any other exception, a hang (more than
:data:`TIMEOUT` s), or a bool, string, non-finite or out-of-range number accepted where a number
in a range is expected. The cheap properties run in the default tier; those that build envs,
run optimizers or the command line many times are ``slow`` (``python -m pytest --all``).
"""

from __future__ import annotations

import contextlib
import functools
import io
import json
import math
import os
import signal
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

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
    {},
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
        names: str | None = None,
    ) -> None:
        """Run ``call`` and count a bad outcome.

        Bad: an exception other than TypeError/ValueError, a hang, acceptance of ``value``
        although ``allowed(value)`` is false, or (with ``names``) an error whose message does
        not contain ``names``.
        """
        self.tried += 1
        try:
            with _deadline(TIMEOUT):
                call()
        except (TypeError, ValueError) as error:
            if names is not None and names not in str(error):
                self.bad.append(f"{label}: error does not name {names!r}: {error}"[:300])
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


def _run_cli(tally: Tally, argv: list[str]) -> tuple[Any, str] | None:
    """Run ``tooldesign ARGV`` here: exit code and stderr, or ``None`` (recorded) on a failure."""
    from benchmarks.cli import main

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
        return None
    except Exception as error:  # noqa: BLE001
        tally.bad.append(f"tooldesign {' '.join(argv)}: {type(error).__name__}: {error}"[:300])
        return None
    return code, err.getvalue()


def fuzz_cli(tally: Tally, texts: list[str] = CLI_TEXT) -> None:
    """Every numeric flag of ``design`` and ``evaluate`` with text a user could type."""
    with tempfile.NamedTemporaryFile(prefix="tooldesign-fuzz-") as existing:
        for command, flags in CLI_FLAGS.items():
            base = [command, "--out", existing.name]
            if command == "evaluate":
                base += ["--coeffs", "0", "0", "0"]
            for flag in flags:
                for text in texts:
                    argv = [*base, flag, text]
                    ran = _run_cli(tally, argv)
                    if ran is None:
                        continue
                    code, err = ran
                    lines = [ln for ln in err.splitlines() if ln.strip()]
                    message = lines[-1] if lines else ""
                    if code != 2 or "Traceback" in err or "error" not in message:
                        tally.bad.append(
                            f"tooldesign {' '.join(map(repr, argv))}: exit {code!r}, {message!r}"
                        )


def _number_in(low: float, high: float, *, integer: bool = False) -> Callable[[Any], bool]:
    """A predicate: a number (an int if ``integer``) from ``low`` to ``high``."""

    def allowed(value: Any) -> bool:
        if integer and not isinstance(value, (int, np.integer)):
            return False
        return _is_number(value) and low <= float(value) <= high

    return allowed


def _never(value: Any) -> bool:
    return False


def _is_str(value: Any) -> bool:
    return isinstance(value, str)


def _json_finite(value: Any) -> bool:
    """JSON an optimizer setting may hold: no NaN, no int beyond float64, no other types."""
    if value is None or isinstance(value, (bool, str)):
        return True
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return _is_number(value)
    if isinstance(value, list):
        return all(_json_finite(v) for v in value)
    if isinstance(value, dict):
        return all(isinstance(k, str) and _json_finite(v) for k, v in value.items())
    return False


def _settings_table(value: Any) -> bool:
    # Names the optimizer does not take are refused when it is made (the command-line check).
    if isinstance(value, list):
        return value == []
    return isinstance(value, dict) and all(k.isidentifier() for k in value)


SUITE_BASE: dict[str, Any] = {
    # One cheap optimizer and a tiny budget, so the command line gets to its --out check fast.
    "name": "fuzz",
    "optimizers": [{"name": "random"}],
    "n_seeds": 1,
    "iterations": 1,
    "batch_size": 2,
    "executor": "serial",
}

# (field named in the error, where the value goes, which values are valid). Each place puts the
# value at one spot of a valid suite; "whole" places replace the field, others put it inside.
SuitePlace = tuple[str, Callable[[Any], dict[str, Any]], Callable[[Any], bool]]
SUITE_PLACES: list[SuitePlace] = [
    ("name", lambda v: {"name": v}, lambda v: isinstance(v, str) and v == v.strip() and v != ""),
    ("description", lambda v: {"description": v}, _is_str),
    ("env_id", lambda v: {"env_id": v}, lambda v: v == "ToolDesign-v0"),
    ("goal", lambda v: {"goal": v}, _never),
    ("goal", lambda v: {"goal": [v, 1.5, 0.1]}, _number_in(-2.5, 2.5)),
    ("goal", lambda v: {"goal": [0.0, 1.5, v]}, _number_in(0.0, 1.0)),
    ("goal_box", lambda v: {"goal_box": v}, lambda v: v is None),
    ("goal_box", lambda v: {"goal_box": [v, [0.5, 1.5], [0.1, 0.1]]}, _never),
    (
        "goal_box x",
        lambda v: {"goal_box": [[v, 0.5], [0.5, 1.5], [0.1, 0.1]]},
        _number_in(-2.5, 0.5),
    ),
    ("goal_precision", lambda v: {"goal_precision": v}, _number_in(0.0, 1e6)),
    ("box_mass", lambda v: {"box_mass": v}, lambda v: _number_in(0.0, 1e3)(v) and v > 0),
    ("estimator", lambda v: {"estimator": v}, _never),
    ("objective", lambda v: {"objective": v}, _never),
    ("executor", lambda v: {"executor": v}, _never),
    ("scheduler", lambda v: {"scheduler": v}, lambda v: v is None),
    (
        "bounds",
        lambda v: {"bounds": v},
        lambda v: v is None or (isinstance(v, list) and v == [[1.0, 2.0]]),
    ),
    (
        "bounds",
        lambda v: {"bounds": [[-1.0, v]] * 3},
        lambda v: _number_in(-1.0, 1e3)(v) and v > -1,
    ),
    ("variants", lambda v: {"variants": v}, _never),
    ("variants", lambda v: {"variants": [v]}, lambda v: isinstance(v, dict) and v == {}),
    ("variant name", lambda v: {"variants": [{"name": v}]}, _is_str),
    (
        "goal_precision",
        lambda v: {"variants": [{"goal_precision": v}]},
        lambda v: v is None or _number_in(0.0, 1e6)(v),
    ),
    ("label of variant", lambda v: {"variants": [{"label": v}]}, _is_str),
    ("optimizers", lambda v: {"optimizers": v}, _never),
    ("optimizers", lambda v: {"optimizers": [v]}, _never),
    (
        "optimizer name",
        lambda v: {"optimizers": [{"name": v}]},
        lambda v: isinstance(v, str) and v.strip() == v != "",
    ),
    ("optimizer label", lambda v: {"optimizers": [{"name": "random", "label": v}]}, _is_str),
    (
        "settings of random",
        lambda v: {"optimizers": [{"name": "random", "settings": v}]},
        _settings_table,
    ),
    (
        "sigma0",
        lambda v: {"optimizers": [{"name": "cmaes", "settings": {"sigma0": v}}]},
        _json_finite,
    ),
    ("batch_size", lambda v: {"batch_size": v}, _number_in(1, 10_000, integer=True)),
    ("iterations", lambda v: {"iterations": v}, _number_in(1, 2**63 - 1, integer=True)),
    ("root_seed", lambda v: {"root_seed": v}, _number_in(0, 2**63 - 1, integer=True)),
    ("n_seeds", lambda v: {"n_seeds": v}, _number_in(1, 10_000, integer=True)),
    (
        "workers",
        lambda v: {"workers": v},
        lambda v: v is None or _number_in(1, 1024, integer=True)(v),
    ),
    ("max_retries", lambda v: {"max_retries": v}, _number_in(0, 100, integer=True)),
    ("test_robustness", lambda v: {"test_robustness": v}, lambda v: isinstance(v, bool)),
    ("keep_paths", lambda v: {"keep_paths": v}, lambda v: isinstance(v, bool)),
    (
        "robustness_masses",
        lambda v: {"robustness_masses": v},
        lambda v: isinstance(v, list) and v == [1.0],
    ),
    (
        "robustness_masses",
        lambda v: {"robustness_masses": [0.5, v]},
        lambda v: _number_in(0.0, 1e3)(v) and v > 0,
    ),
    ("figures", lambda v: {"figures": v}, lambda v: isinstance(v, list) and v == []),
    ("figures", lambda v: {"figures": [v]}, _never),
    ("unknown keys", lambda v: {"speed": v}, _never),
    ("unknown keys", lambda v: {"variants": [{"colour": v}]}, _never),
]


def _suite_data(place: SuitePlace, value: Any) -> dict[str, Any]:
    """SUITE_BASE with the value put in its place (nested tables merged, not replaced)."""
    data = dict(SUITE_BASE)
    for key, item in place[1](value).items():
        data[key] = item
    return data


def _json_text(data: Any) -> str | None:
    """The suite as JSON text (NaN and Infinity as their literals), or None.

    None: JSON has no way to write a value (numpy scalars, objects, complex numbers).
    """
    try:
        return json.dumps(data)
    except (TypeError, ValueError, RecursionError):
        return None


def fuzz_suite_config(tally: Tally, values: list[Any], folder: Path) -> list[Any]:
    """Every field of a suite set to each value, read from a JSON file.

    A value JSON cannot write is given to ``suite_from_json`` in memory instead. Returns the
    paths of the files that were refused, for the command line.
    """
    from benchmarks.suites import load_suite, suite_from_json

    refused: list[Any] = []
    for index, value in enumerate(values):
        for number, place in enumerate(SUITE_PLACES):
            data = _suite_data(place, value)
            text = _json_text(data)
            label = f"suite {place[0]} = {value!r}"[:200]
            if text is None:
                call: Callable[[], Any] = functools.partial(suite_from_json, data)
            else:
                path = os.path.join(folder, f"v{index}-p{number}.json")
                with open(path, "w", encoding="utf-8") as f:
                    f.write(text)
                call = functools.partial(_load_and_plan, load_suite, path)
            before = len(tally.bad)
            tally.check(label, call, value=value, allowed=place[2], names=place[0])
            if text is not None and not place[2](value) and len(tally.bad) == before:
                refused.append(path)
    return refused


def _load_and_plan(load: Callable[[str], Any], path: str) -> None:
    # Planning the tasks spawns n_seeds seeds: a huge n_seeds accepted here would hang there.
    load(path).tasks()


def fuzz_suite_files(
    tally: Tally, rng: np.random.Generator, edits: int, folder: Path
) -> list[str]:
    """Random edits of the text of a valid JSON and TOML suite file, and odd files."""
    from benchmarks.suites import builtin_suite, load_suite, save_suite

    texts = {}
    for suffix in (".json", ".toml"):
        valid = os.path.join(folder, f"valid{suffix}")
        save_suite(builtin_suite("robustness", "smoke"), valid)
        with open(valid, encoding="utf-8") as f:
            texts[suffix] = f.read()
    odd = {
        "deep.json": ("[" * 100_000 + "]" * 100_000).encode(),
        "deep.toml": ("a = " + "[" * 100_000 + "]" * 100_000).encode(),
        "binary.json": bytes(range(256)),
        "empty.json": b"",
        "empty.toml": b"",
        "bom.json": "\ufeff{}".encode(),
        "nan.json": b'{"name": "x", "goal_precision": NaN}',
        "inf.toml": b'name = "x"\nbox_mass = inf\n',
        "date.toml": b'name = "x"\nroot_seed = 1979-05-27\n',
        "bigint.json": b'{"name": "x", "n_seeds": 1' + b"0" * 5000 + b"}",
        "list.json": b"[]",
        "sizes.toml": b'name = "x"\nsizes = 3\n',
        "base.toml": b"base = 3\n",
    }
    paths = []
    for name, data in odd.items():
        paths.append(os.path.join(folder, name))
        with open(paths[-1], "wb") as f:
            f.write(data)
    alphabet = list('{}[]",:=.-+eE0123456789 \n\tabnulltrue\x00') + ["NaN", "1e999", "[[", "]]"]
    for i in range(edits):
        suffix = (".json", ".toml")[i % 2]
        text = texts[suffix]
        at = int(rng.integers(len(text)))
        kind = i % 3
        if kind == 0:
            text = text[:at]
        elif kind == 1:
            text = text[:at] + text[at + int(rng.integers(1, 20)) :]
        else:
            text = text[:at] + str(rng.choice(alphabet)) + text[at:]
        paths.append(os.path.join(folder, f"edit{i}{suffix}"))
        with open(paths[-1], "w", encoding="utf-8") as f:
            f.write(text)
    for path in paths:
        # A valid edit (a changed number, say) may be accepted; an error must name the file.
        tally.check(
            f"load_suite({os.path.basename(path)})",
            functools.partial(_load_and_plan, load_suite, path),
            value=path,
            allowed=lambda v: True,
            names=os.path.basename(path),
        )
    return paths


def fuzz_suite_cli(tally: Tally, paths: list[str]) -> None:
    """``tooldesign bench --config FILE --out EXISTING_FILE``: exit 2 and one line each."""
    with tempfile.NamedTemporaryFile(prefix="tooldesign-fuzz-") as existing:
        for path in paths:
            argv = ["bench", "--config", path, "--out", existing.name, "--no-progress"]
            ran = _run_cli(tally, argv)
            if ran is None:
                continue
            code, err = ran
            lines = [ln for ln in err.splitlines() if ln.strip()]
            if code != 2 or len(lines) != 1 or "error" not in lines[0]:
                tally.bad.append(
                    f"tooldesign {' '.join(argv)}: exit {code!r}, {lines[-3:]!r}"[:300]
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


# --- the properties ----------------------------------------------------------------------------

#: The fuzzer's values: the nasty list, and random magnitudes over the whole float64 range and
#: ints far beyond int64, both signs.
VALUES = st.one_of(
    st.sampled_from(NASTY),
    st.floats(allow_nan=False, allow_infinity=False),
    st.integers(min_value=-(2**62) * 10**20, max_value=2**62 * 10**20),
    st.floats(),
)


def _no_bad(tally: Tally) -> None:
    assert tally.tried > 0
    assert tally.bad == [], "\n".join(tally.bad[:20])


def test_the_oracle_counts_what_fails_badly() -> None:
    """The checks below can fail: an accepted bad value, a stray exception, an unnamed field."""
    tally = Tally()
    tally.check("accepts nan", lambda: None, value=float("nan"))
    tally.check("raises KeyError", lambda: {}["x"], value=1.0)
    tally.check("names nothing", lambda: int("x"), value="x", allowed=_never, names="seed")
    tally.check("refuses well", lambda: int("x"), value="x", allowed=_never, names="int()")
    tally.check("accepts a number", lambda: None, value=2.0)
    assert tally.tried == 5
    assert [line.split(":")[0] for line in tally.bad] == [
        "accepts nan",
        "raises KeyError",
        "names nothing",
    ]


@settings(max_examples=30, deadline=None)
@given(value=VALUES)
def test_design_config_fields_take_only_valid_values(value: Any) -> None:
    tally = Tally()
    fuzz_design_config(tally, [value])
    _no_bad(tally)


@settings(max_examples=10, deadline=None)
@given(value=VALUES)
def test_every_suite_field_takes_only_valid_values_and_its_errors_name_it(
    tmp_path_factory: pytest.TempPathFactory, value: Any
) -> None:
    tally = Tally()
    fuzz_suite_config(tally, [value], tmp_path_factory.mktemp("suites"))
    _no_bad(tally)


@settings(max_examples=5, deadline=None)
@given(seed=st.integers(min_value=0, max_value=2**32 - 1))
def test_odd_and_edited_suite_files_are_read_or_refused_naming_the_file(
    tmp_path_factory: pytest.TempPathFactory, seed: int
) -> None:
    tally = Tally()
    rng = np.random.default_rng(seed)
    fuzz_suite_files(tally, rng, 30, tmp_path_factory.mktemp("files"))
    _no_bad(tally)


@pytest.mark.slow
@settings(max_examples=25, deadline=None)
@given(value=VALUES)
def test_the_env_takes_only_valid_values(value: Any) -> None:
    tally = Tally()
    fuzz_env(tally, [value])
    _no_bad(tally)


@pytest.mark.slow
@settings(max_examples=15, deadline=None)
@given(value=VALUES)
def test_every_optimizer_takes_only_valid_values_and_tells(value: Any) -> None:
    tally = Tally()
    fuzz_optimizers(tally, [value])
    _no_bad(tally)


@pytest.mark.slow
def test_every_numeric_flag_refuses_bad_text_in_one_line() -> None:
    tally = Tally()
    fuzz_cli(tally)
    _no_bad(tally)


@pytest.mark.slow
@settings(max_examples=20, deadline=None)
@given(text=st.text(max_size=12))
def test_every_numeric_flag_refuses_any_text_in_one_line(text: str) -> None:
    # --out is an existing file, so even a valid value ends in a one-line error (exit code 2).
    tally = Tally()
    fuzz_cli(tally, [text])
    _no_bad(tally)


@pytest.mark.slow
@settings(max_examples=10, deadline=None)
@given(value=VALUES)
def test_bench_refuses_each_refused_suite_file_in_one_line(
    tmp_path_factory: pytest.TempPathFactory, value: Any
) -> None:
    tally = Tally()
    refused = fuzz_suite_config(tally, [value], tmp_path_factory.mktemp("suites"))
    fuzz_suite_cli(tally, refused)
    _no_bad(tally)


@pytest.mark.slow
def test_bench_refuses_odd_and_edited_suite_files_in_one_line(tmp_path: Path) -> None:
    tally = Tally()
    files = fuzz_suite_files(tally, np.random.default_rng(0), 300, tmp_path)
    fuzz_suite_cli(tally, files)
    _no_bad(tally)


@pytest.mark.slow
def test_the_corners_of_the_action_space_give_a_finite_reward_and_f() -> None:
    tally = Tally()
    fuzz_steps(tally, 8, np.random.default_rng(0))
    _no_bad(tally)
