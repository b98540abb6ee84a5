"""Survey: which entries of Nevergrad's registry work through the ``nevergrad`` adapter.

Not a test (pytest does not collect it): the script that measured the adapter's refusal table,
``optimizers/_nevergrad_support.py``, and writes it again (``--table``). Every name of
``nevergrad.optimizers.registry`` (or those given) runs through the adapter with its refusal
switched off, at the settings of this project: 3 dimensions in the tool's coefficient box,
batch sizes 1, 4 and 8, no budget and budgets 20, 60 and 200. Per setting it checks that

- every ask/tell round up to the budget (or 15 rounds without one) runs, with finite asks
  inside the box (the adapter raises otherwise);
- the same seed gives the same asks, also when the caller draws from ``np.random`` between
  rounds, and ``np.random``'s state is left as it was;
- a state saved (``save_state``) halfway and loaded continues with the same asks;
- all that also in another process with another ``PYTHONHASHSEED`` (a second pass, which
  loads the states the first one saved): a resumed design run is a new process.

Each name runs in a forked child with a time limit. Run it with::

    PYTHONPATH=. python tests/nevergrad_survey.py --out survey.json \\
        --table optimizers/_nevergrad_support.py
    PYTHONPATH=. python tests/nevergrad_survey.py Wiz NgIoh CMA      # some names, printed
    PYTHONPATH=. python tests/nevergrad_survey.py --load survey.json  # print saved results

All names take about an hour on one core. ``--conformance`` also runs the whole
conformance suite (``optimizers.testing.check_optimizer``, budget 200) on each name that passed.
"""

from __future__ import annotations

import argparse
import collections
import functools
import hashlib
import json
import math
import multiprocessing
import os
import subprocess
import sys
import tempfile
import textwrap
import time
import traceback
import warnings
from typing import Any

import numpy as np

import optimizers
from optimizers import nevergrad_adapter, testing

BOUNDS = testing.BOUNDS
BATCH_SIZES = (1, 4, 8)
BUDGETS: tuple[int | None, ...] = (None, 20, 60, 200)
ROUNDS_WITHOUT_BUDGET = 15


def _make(name: str, budget: int | None, batch_size: int, seed: int) -> optimizers.Optimizer:
    return optimizers.make(
        "nevergrad", bounds=BOUNDS, batch_size=batch_size, seed=seed, optimizer=name, budget=budget
    )


def _rounds(
    optimizer: optimizers.Optimizer, rounds: int, *, disturb: bool = False, save: str | None = None
) -> list[np.ndarray]:
    """The asks of ``rounds`` rounds on the shifted sphere; saves the state halfway if asked."""
    asks = []
    for r in range(rounds):
        if disturb:
            np.random.seed(1000 + r)  # noqa: NPY002 - the caller's draws must not matter
            np.random.random(3)  # noqa: NPY002
        before = np.random.get_state(legacy=True)  # noqa: NPY002
        batch = optimizer.ask()
        optimizer.tell(batch.ids, testing.shifted_sphere(batch.x))
        after = np.random.get_state(legacy=True)  # noqa: NPY002
        if not (before[0] == after[0] and np.array_equal(before[1], after[1])):
            raise AssertionError("ask/tell changed np.random's global state")
        asks.append(np.array(batch.x))
        if save is not None and r + 1 == _half(rounds):
            optimizer.save_state(save)
    return asks


def _half(rounds: int) -> int:
    return max(1, rounds // 2)


def _digest(asks: list[np.ndarray]) -> str:
    return hashlib.sha256(b"".join(np.ascontiguousarray(x).tobytes() for x in asks)).hexdigest()


def _problem(stage: str, error: BaseException, start: float) -> dict[str, Any]:
    """A failed setting: the stage, the innermost error and where it was raised."""
    cause: BaseException = error
    while cause.__cause__ is not None:
        cause = cause.__cause__
    frames = traceback.extract_tb(cause.__traceback__)
    return {
        "ok": False,
        "stage": stage,
        "error": _first_line(cause),
        "where": f"{os.path.basename(frames[-1].filename)}:{frames[-1].lineno}" if frames else "?",
        "seconds": round(time.perf_counter() - start, 2),
    }


def _first_line(error: BaseException) -> str:
    text = f"{type(error).__name__}: {error}".strip().splitlines()
    return text[0][:200] if text else type(error).__name__


def _rounds_of(budget: int | None, batch_size: int) -> int:
    return ROUNDS_WITHOUT_BUDGET if budget is None else math.ceil(budget / batch_size)


def probe_setting(name: str, budget: int | None, batch_size: int, state: str) -> dict[str, Any]:
    """One setting in this process: ``{"ok": True, "digest": ..., "tail": ...}`` or a problem.

    The state saved halfway through the reference run is left in ``state`` for the second pass.
    """
    rounds = _rounds_of(budget, batch_size)
    stage = "construct"
    start = time.perf_counter()
    try:
        optimizer = _make(name, budget, batch_size, 0)
        stage = "run"
        reference = _rounds(optimizer, rounds, save=state)
        stage = "same seed"
        if _digest(_rounds(_make(name, budget, batch_size, 0), rounds, disturb=True)) != _digest(
            reference
        ):
            raise AssertionError("the same seed gave other asks")
        stage = "save/load"
        resumed = _rounds(optimizers.Optimizer.load_state(state), rounds - _half(rounds))
        if _digest(resumed) != _digest(reference[_half(rounds) :]):
            raise AssertionError("a saved and loaded state continued with other asks")
    except Exception as error:  # the survey records whatever the backend raises
        return _problem(stage, error, start)
    return {
        "ok": True,
        "digest": _digest(reference),
        "tail": _digest(reference[_half(rounds) :]),
        "seconds": round(time.perf_counter() - start, 2),
    }


def recheck_setting(
    name: str, budget: int | None, batch_size: int, state: str, first: dict[str, Any]
) -> dict[str, Any]:
    """One setting that passed the first pass, again in a process with another hash seed."""
    rounds = _rounds_of(budget, batch_size)
    stage = "other process"
    start = time.perf_counter()
    try:
        if _digest(_rounds(_make(name, budget, batch_size, 0), rounds)) != first["digest"]:
            raise AssertionError("the same seed gave other asks in another process")
        stage = "load in other process"
        resumed = _rounds(optimizers.Optimizer.load_state(state), rounds - _half(rounds))
        if _digest(resumed) != first["tail"]:
            raise AssertionError("a state loaded in another process continued with other asks")
    except Exception as error:  # the survey records whatever the backend raises
        return _problem(stage, error, start)
    return first


def _key(budget: int | None, batch_size: int) -> str:
    return f"budget={budget},batch={batch_size}"


def probe(name: str, states: str, first: dict[str, Any] | None) -> dict[str, Any]:
    """Every setting of one name: the first pass, or (given its results) the second."""
    warnings.simplefilter("ignore")
    nevergrad_adapter._refusal = lambda *args: None  # measure, do not refuse
    settings = {}
    for budget in BUDGETS:
        for batch_size in BATCH_SIZES:
            key = _key(budget, batch_size)
            state = os.path.join(states, f"{name}.{budget}.{batch_size}.pkl")
            if first is None:
                settings[key] = probe_setting(name, budget, batch_size, state)
            elif first["settings"][key]["ok"]:
                settings[key] = recheck_setting(
                    name, budget, batch_size, state, first["settings"][key]
                )
            else:
                settings[key] = first["settings"][key]
    return {"settings": settings}


def conformance(name: str) -> str:
    """The conformance suite with budget 200: "ok" or the first failing check."""
    warnings.simplefilter("ignore")
    factory = functools.partial(optimizers.make, "nevergrad", optimizer=name, budget=200)
    try:
        testing.check_optimizer(factory)
    except AssertionError as error:
        return _first_line(error)
    return "ok"


def _child(work: Any, pipe: Any) -> None:
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)  # prints of Nevergrad's optional backends
    os.dup2(os.open(os.devnull, os.O_WRONLY), 2)  # the noise of threads being torn down
    try:
        pipe.send(work())
    except BaseException as error:  # noqa: BLE001 - reported to the parent
        pipe.send({"crash": _first_line(error)})
    os._exit(0)  # leave threads of thread-based optimizers behind


def in_child(work: Any, timeout: float) -> Any:
    """``work()`` in a forked child: its result, or ``{"timeout": ...}`` past the limit."""
    context = multiprocessing.get_context("fork")
    parent, child = context.Pipe(duplex=False)
    process = context.Process(target=_child, args=(work, child))
    process.start()
    child.close()
    result: Any = {"timeout": timeout}
    if parent.poll(timeout):
        try:
            result = parent.recv()
        except EOFError:
            result = {"crash": "the child died"}
    process.kill()
    process.join()
    return result


def survey(
    names: list[str],
    timeout: float,
    states: str,
    first: dict[str, Any] | None = None,
    check_conformance: bool = False,
) -> dict[str, Any]:
    """``probe`` of each name (in a child); names that timed out or crashed are not redone."""
    results: dict[str, Any] = {}
    for k, name in enumerate(names):
        start = time.perf_counter()
        if first is not None and "settings" not in first[name]:
            results[name] = first[name]
        else:
            previous = None if first is None else first[name]
            results[name] = in_child(functools.partial(probe, name, states, previous), timeout)
            if check_conformance and not _failing(results[name]):
                results[name]["conformance"] = in_child(
                    functools.partial(conformance, name), timeout
                )
        results[name]["seconds"] = round(time.perf_counter() - start, 1)
        print(f"[{k + 1}/{len(names)}] {name}: {verdict(results[name])}", flush=True)
    return results


def _failing(result: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """The failing settings of a name; every setting if it timed out or crashed."""
    if "settings" not in result:
        problem = f"timed out after {result['timeout']:g} s" if "timeout" in result else "crashed"
        return {
            f"budget={b},batch={n}": {"stage": "run", "error": problem, "where": "survey"}
            for b in BUDGETS
            for n in BATCH_SIZES
        }
    return {k: v for k, v in result["settings"].items() if not v["ok"]}


def verdict(result: dict[str, Any]) -> str:
    """One line: "ok" or the first problem."""
    failed = _failing(result)
    if not failed:
        return "ok" + (
            f" (conformance: {result['conformance']})" if "conformance" in result else ""
        )
    setting, first = next(iter(failed.items()))
    return (
        f"{len(failed)}/{len(BUDGETS) * len(BATCH_SIZES)} settings fail, e.g. {setting}: "
        f"{first['stage']}: {first['error']} ({first['where']})"
    )


def _setting(key: str) -> tuple[int | None, int]:
    budget, batch = (part.split("=")[1] for part in key.split(","))
    return (None if budget == "None" else int(budget)), int(batch)


def _why(problem: dict[str, Any], key: str) -> str:
    """Why a setting failed, as the end of "optimizer NAME ..."."""
    budget, batch_size = _setting(key)
    where = f"budget={budget}, batch_size={batch_size}"
    error, stage = problem["error"], problem["stage"]
    if "0-dimensional arrays can be converted" in error:
        return (
            "raises TypeError on numpy 2 (float() of a 1-element array in its meta-model step), "
            f"e.g. with {where}"
        )
    if error.startswith("ModuleNotFoundError: No module named "):
        package = error.split("No module named ")[1]
        return f"needs the package {package}, which is not installed where this rule was measured"
    if stage == "same seed":
        return f"is not reproducible: the same seed gave other points, e.g. with {where}"
    if stage == "other process":
        return (
            "is not reproducible across processes (it depends on Python's hash seed): the same "
            f"seed gave other points in another process, e.g. with {where}"
        )
    if stage == "save/load":
        return (
            "does not continue with the same points after save_state and load_state, e.g. with "
            + where
        )
    if stage == "load in other process":
        return (
            "does not continue with the same points when its saved state is loaded in another "
            f"process, e.g. with {where}"
        )
    if problem["where"] == "survey" and error.startswith("timed out"):
        return (
            f"is too slow to be checked: its runs in the survey {error} (3 dimensions, budgets up "
            "to 200)"
        )
    if problem["where"] == "survey":
        return f"could not be checked: its runs in the survey {error}"
    return f"fails with {where}: {error} ({problem['where']}, at {stage})"


def classify(result: dict[str, Any]) -> tuple[str, str | None]:
    """The rule of one name: ("ok"|"needs budget"|"sequential"|"both"|"fails", why)."""
    failed = _failing(result)
    if not failed:
        return "ok", None
    settings = [_setting(key) for key in failed]
    if all(budget is None for budget, _ in settings):
        return "needs budget", None
    if all(batch > 1 for _, batch in settings):
        return "sequential", None
    if all(budget is None or batch > 1 for budget, batch in settings):
        return "both", None
    # the first failure with a budget and batch_size 1 says best why it cannot work
    key = next(k for k in failed if _setting(k)[0] is not None and _setting(k)[1] == 1)
    return "fails", _why(failed[key], key)


def _literal(text: str, indent: int, before: int) -> str:
    """``text`` as a Python string literal after ``before`` characters of a line indented by
    ``indent``, split into parenthesized lines to fit 100 columns."""
    width = 100 - indent - 4
    if before + len(json.dumps(text)) + 1 <= 100:
        return json.dumps(text)
    words, lines, line = text.split(" "), [], ""
    for word in words:
        if line and len(json.dumps(line + word)) > width:
            lines.append(line)
            line = ""
        line += word + " "
    lines.append(line.rstrip(" "))
    inner = "".join(f"{' ' * (indent + 4)}{json.dumps(part)}\n" for part in lines)
    return f"(\n{inner}{' ' * indent})"


def write_table(results: dict[str, Any], versions: dict[str, str], path: str) -> None:
    """Write the refusal table of ``optimizers.nevergrad_adapter`` (a Python module)."""
    rules = {name: classify(result) for name, result in sorted(results.items())}
    needs_budget = sorted(n for n, (rule, _) in rules.items() if rule in ("needs budget", "both"))
    sequential = sorted(n for n, (rule, _) in rules.items() if rule in ("sequential", "both"))
    fails = {n: why for n, (rule, why) in rules.items() if rule == "fails"}
    ok = sum(rule == "ok" for rule, _ in rules.values())
    measured = ", ".join(f"{k} {v}" for k, v in versions.items())
    budgets = ", ".join(str(b) for b in BUDGETS if b is not None)
    doc = textwrap.fill(
        f"Generated by ``tests/nevergrad_survey.py --table`` (do not edit by hand; run it again "
        f"after upgrading Nevergrad) from a survey of the {len(rules)} names of "
        f"``nevergrad.optimizers.registry`` with {measured}. Each ran through the adapter in 3 "
        f"dimensions with batch sizes {', '.join(map(str, BATCH_SIZES))}, without a budget and "
        f"with budgets {budgets}, and had to ask and tell up to its budget, ask the same points "
        "again under the same seed, and continue with the same points after ``save_state`` and "
        "``load_state``, also in another process. "
        f"{ok} names passed everywhere, {len(needs_budget)} need a budget and {len(sequential)} "
        f"``batch_size=1`` ({len(set(needs_budget) & set(sequential))} of them both), "
        f"{len(fails)} fail with a budget and ``batch_size=1`` too.",
        width=99,
    )

    def names(items: list[str]) -> str:
        return "".join(f"        {json.dumps(name)},\n" for name in items)

    text = (
        '"""Which Nevergrad optimizers the ``nevergrad`` adapter refuses, as measured.\n\n'
        f'{doc}\n"""\n\n'
        "from __future__ import annotations\n\n"
        "#: Package versions the table was measured with.\n"
        f"MEASURED_ON = {json.dumps(versions)}\n\n"
        "#: Names that failed without a budget only (or also with batch sizes above 1).\n"
        f"NEEDS_BUDGET = frozenset(\n    {{\n{names(needs_budget)}    }}\n)\n\n"
        "#: Names that failed with batch sizes above 1 only (or also without a budget).\n"
        f"SEQUENTIAL = frozenset(\n    {{\n{names(sequential)}    }}\n)\n\n"
        "#: Names that failed with a budget and batch size 1 too: name -> why.\n"
        "FAILS = {\n"
        + "".join(
            f"    {json.dumps(n)}: {_literal(why, 4, 6 + len(json.dumps(n)))},\n"
            for n, why in fails.items()
        )
        + "}\n"
    )
    with open(path, "w") as handle:
        handle.write(text)


def main(argv: list[str] | None = None) -> None:
    """Parse the arguments; survey in two passes (two processes) or one pass of a pair."""
    import nevergrad as ng

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("names", nargs="*", help="registry names (default: all)")
    parser.add_argument("--timeout", type=float, default=90.0, help="seconds per name and pass")
    parser.add_argument("--out", help="write the results as JSON here")
    parser.add_argument("--table", help="write the adapter's refusal table (a .py file) here")
    parser.add_argument("--load", help="print (and --table) the results of an earlier --out")
    parser.add_argument("--conformance", action="store_true", help="also run the checks")
    parser.add_argument("--pass", dest="which", choices=("first", "second"), help=argparse.SUPPRESS)
    parser.add_argument("--states", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.load:
        with open(args.load) as handle:
            saved = json.load(handle)
        results = {n: saved["results"][n] for n in args.names or saved["results"]}
        for name, result in results.items():
            print(f"{name}: {classify(result)[0]}: {verdict(result)}")
        if args.table:
            write_table(saved["results"], saved["versions"], args.table)
        return
    names = args.names or sorted(ng.optimizers.registry)
    unknown = [n for n in names if n not in ng.optimizers.registry]
    if unknown:
        parser.error(f"not in nevergrad.optimizers.registry: {unknown}")
    if args.which:  # one pass, in a process the driver below started
        first = None
        if args.which == "second":
            with open(args.out) as handle:
                first = json.load(handle)["results"]
        results = survey(names, args.timeout, args.states, first, args.conformance)
        with open(args.out, "w") as handle:
            json.dump({"results": results}, handle, indent=1)
        return

    from importlib.metadata import version

    with tempfile.TemporaryDirectory() as states:
        out = os.path.join(states, "results.json")
        for which, hash_seed in (("first", "1"), ("second", "2")):
            print(f"{which} pass, PYTHONHASHSEED={hash_seed}", flush=True)
            command = [sys.executable, __file__, *names, "--pass", which, "--states", states]
            command += ["--out", out, "--timeout", str(args.timeout)]
            if args.conformance and which == "second":
                command.append("--conformance")
            env = {**os.environ, "PYTHONHASHSEED": hash_seed}
            subprocess.run(command, env=env, check=True)
        with open(out) as handle:
            results = json.load(handle)["results"]
    rules = collections.Counter(classify(result)[0] for result in results.values())
    print(dict(rules))
    versions = {p: version(p) for p in ("nevergrad", "numpy", "scipy", "scikit-learn")}
    if args.out:
        with open(args.out, "w") as handle:
            json.dump({"versions": versions, "results": results}, handle, indent=1)
    if args.table:
        write_table(results, versions, args.table)


if __name__ == "__main__":
    main()
