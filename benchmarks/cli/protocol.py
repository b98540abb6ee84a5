"""``tooldesign bench protocol``: the benchmark protocol (docs/protocol.md).

``tooldesign bench protocol --size smoke|quick|full --out DIR`` runs every (instance, d) cell
into DIR (resuming what is there), exports the runs in the IOHprofiler format to DIR/ioh and
writes the report to DIR/report. With ``--optimizer NAME`` only that optimizer runs (a registry
name or ``module:Class``), and ``--baseline DIR2`` puts it in one report beside the runs of
DIR2 (the committed built-ins), which are not run again. ``--references`` computes the
references of the size into the file ``--out`` instead; ``--with-references`` computes them into
DIR/references.json after the runs when the references a report would use (the folder's,
else the committed ones of the size) are none or lack a cell of the run (the full benchmark in
one resumable command; with ``--tasks``, the other tasks' cells are added to the folder's
references, or to a copy of the committed ones); ``--verify-references`` evaluates the
reference design and the straight tool of every cell of the size's references again on this
machine and compares them with the file (bit for bit, and within each value's noise floor);
``--buildable N`` prints the fraction of N random designs per degree that can be built and
used. ``--tasks hook obstacle`` (or
``--tasks all``) adds the task axis: every named task's cells (push alone by default).

What the run or its report would refuse is refused before ``protocol.json`` is written or a
cell starts, in one line: an optimizer that cannot be made, a ``--baseline`` of another plan
or with an optimizer of the run, references that lack a cell of the run, and a flag that
another would make ignored (``--references`` or ``--with-references`` with
``--reference-file``, ``--buildable`` with a run's options); docs/protocol.md "Commands".
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

__all__ = ["PROTOCOL_ONLY_OPTIONS", "add_protocol_arguments", "run_protocol_command"]

#: Options that only the protocol suite takes.
PROTOCOL_ONLY_OPTIONS: tuple[str, ...] = (
    "tasks",
    "optimizer",
    "baseline",
    "references",
    "reference_file",
    "with_references",
    "verify_references",
    "buildable",
)


def add_protocol_arguments(parser: argparse.ArgumentParser | Any, *, title: str) -> None:
    """Add the protocol suite's options to ``tooldesign bench``."""
    group = parser.add_argument_group(title)
    group.add_argument(
        "--tasks",
        nargs="+",
        default=None,
        metavar="TASK",
        help="the tasks to run (push, hook, obstacle, puck, ... or all; default: push alone); "
        "each other task runs at d = 3 on its own committed instances",
    )
    group.add_argument(
        "--optimizer",
        default=None,
        metavar="NAME",
        help="run only this optimizer (a registry name or module:Class), with the protocol's "
        "seeds and budgets",
    )
    group.add_argument(
        "--baseline",
        type=Path,
        nargs="+",
        default=None,
        metavar="DIR",
        help="protocol run folders of the same size to report beside this run (not rerun)",
    )
    group.add_argument(
        "--reference-file",
        type=Path,
        default=None,
        metavar="FILE",
        help="references to measure against (default: the run folder's references.json, "
        "else the committed ones of the size)",
    )
    group.add_argument(
        "--references",
        action="store_true",
        default=None,
        help="compute the size's references into the .json file --out (resumable) and exit",
    )
    group.add_argument(
        "--with-references",
        action="store_true",
        default=None,
        help="if the references of the run (OUT's, else the committed ones of the size) are "
        "none or lack a cell of it, compute the missing ones into OUT/references.json after the "
        "runs (resumable) and report against them: the whole benchmark in one command",
    )
    group.add_argument(
        "--verify-references",
        action="store_true",
        default=None,
        help="evaluate the reference design and the straight tool of every cell of the size's "
        "references (--reference-file, else the committed ones) again on this machine, print "
        "how far each F moved against its noise floor, and exit (1 if one moved beyond it)",
    )
    group.add_argument(
        "--buildable",
        type=int,
        default=None,
        metavar="N",
        help="print the fraction of N random designs per degree that can be built and used, "
        "and exit",
    )


def _lacks_cells(folders: list[Path], size: str, config: Any) -> bool:
    """Whether the references a report would use lack some cell of ``config``, or are none.

    They are :func:`~benchmarks.protocol.report.find_references`'s: a run folder's own
    (recorded, checked) ``references.json``, else the committed ones of the size. A push run's
    folder extended with ``--tasks`` has references of its push cells only, and the committed
    ones may hold push cells only: ``--with-references`` then adds the other tasks' cells.
    """
    from benchmarks.protocol import load_references

    path, expected = _found_references(folders, size)
    if path is None:
        return True
    cells = load_references(path, expected_sha256=expected)
    return any((i.label, d) not in cells for i, d in config.cells())


def _found_references(folders: list[Path], size: str) -> tuple[Any, str | None]:
    """The references a report of ``folders`` would use, and the SHA-256 recorded for them.

    :func:`~benchmarks.protocol.report.find_references`'s file (``None`` if none), with the
    digest of the folder that holds it (``None`` for the committed ones).

    Raises:
        ValueError: A folder's ``references.json`` is not recorded in its ``protocol.json``.
    """
    from benchmarks.protocol.report import find_references, folder_references

    path = find_references(folders, size)
    for folder in folders:
        found = folder_references(folder)
        if found is not None:
            return path, found[1]
    return path, None


def _verify(args: argparse.Namespace, config: Any, size: str, say: Any) -> int:
    """``--verify-references``: 0 if every value is within its noise floor, else 1."""
    from benchmarks.protocol import packaged_references, verify_references
    from benchmarks.protocol.references import verify_verdict

    for name in (
        "references",
        "with_references",
        "optimizer",
        "baseline",
        "buildable",
        "out",
        "max_retries",  # its evaluations run without retries
    ):
        if getattr(args, name, None) is not None:
            raise ValueError(
                f"--verify-references checks references only: no --{name.replace('_', '-')} "
                "(it writes nothing, and evaluates without retries)"
            )
    path = args.reference_file or packaged_references(size)
    if path is None:
        raise ValueError(f"no committed references of size {size!r}: give --reference-file")
    table = verify_references(path, config, say=say)
    identical = int(table["identical"].sum())
    within = int(table["within_floor"].sum())
    n_cells = len(table[["task", "instance", "d"]].drop_duplicates())
    lacking = len(config.cells()) - n_cells
    print(
        f"{path}: {len(table)} values of {n_cells} "
        f"cells evaluated again: {identical} identical to the bit, "
        f"{within} within their noise floor"
        + (
            f"; the file has no cell for {lacking} of the run's cells (not checked)"
            if lacking
            else ""
        )
    )
    passed, sentence = verify_verdict(table)
    print(("passed: " if passed else "failed: ") + sentence)
    beyond = table[~table["within_floor"]]
    if len(beyond):
        print("beyond the noise floor:")
        print(beyond.to_string(index=False))
    return 0 if passed else 1


def _flags(args: argparse.Namespace, names: tuple[str, ...]) -> list[str]:
    """The options of ``names`` given on the command line, as ``--a`` flags."""
    return [f"--{n.replace('_', '-')}" for n in names if getattr(args, n, None) is not None]


def _check_optimizer(config: Any, name: str | None) -> None:
    """Refuse an optimizer that cannot be made, before anything is read, run or written.

    The protocol's own check (:func:`~benchmarks.protocol.suite.check_protocol_optimizers`,
    which ``run_protocol`` makes again), with the flag and what it takes in the message.
    """
    from benchmarks.protocol.suite import check_protocol_optimizers
    from optimizers import DependencyNotInstalled, available

    try:
        check_protocol_optimizers(config)
    except (ImportError, TypeError, ValueError) as err:
        if name is None:
            raise  # a built-in whose backend is missing: the message names the pip extra
        text = str(err)
        cause = err.__cause__
        if isinstance(cause, ImportError) and not isinstance(cause, DependencyNotInstalled):
            text += (
                f"; --optimizer takes a registered name ({', '.join(available())}), an installed "
                "plugin's name or the importable 'module:Class' of an optimizers.Optimizer"
            )
        raise ValueError(f"--optimizer {name}: {text}") from None


def _check_baselines(args: argparse.Namespace, config: Any) -> None:
    """Refuse ``--baseline`` folders the report would refuse beside this run, before it runs.

    Each must be a finished protocol run folder without links, not ``--out`` itself, of the
    same plan as this run and without an optimizer of this run or of another baseline
    (:func:`~benchmarks.protocol.suite.check_mergeable`, the report's own rule).
    """
    from benchmarks.protocol import load_runs
    from benchmarks.protocol.suite import check_mergeable

    plans: list[tuple[Any, Any]] = [(args.out, config)]
    for folder in args.baseline:
        if Path(folder).resolve() == Path(args.out).resolve():
            raise ValueError(f"--baseline {folder} is the run folder --out itself")
        # Refuse a folder that is not a finished protocol run, or holds a link, before
        # running (load_runs refuses links below it).
        plans.append((folder, load_runs(folder)[0]))
    check_mergeable(plans)


def _check_references(args: argparse.Namespace, config: Any, size: str) -> None:
    """Refuse, before the run, references its report would refuse after it.

    ``--reference-file`` must exist, be a references file of this run's plan and have every
    cell of the run; without ``--with-references``, so must the references the report would
    find (:func:`~benchmarks.protocol.report.find_references`: the folders' own, else the
    committed ones of the size). With ``--with-references`` the missing cells are computed after
    the runs, and none found at all is left to the report's "no report" line.
    """
    from benchmarks.protocol import load_references
    from benchmarks.protocol.instances import PUSH_TASK

    expected = None
    if args.reference_file is not None:
        path = args.reference_file
    else:
        # Refuses a folder's unrecorded references.json, as the report would.
        path, expected = _found_references([args.out, *(args.baseline or [])], size)
        if path is None or args.with_references:
            return
    cells = load_references(path, config=config, expected_sha256=expected)
    missing = [f"{i.label} at d = {d}" for i, d in config.cells() if (i.label, d) not in cells]
    if missing:
        # The report's words (measure_runs), with the file and how many cells lack one.
        tasks = "" if config.tasks == (PUSH_TASK,) else f" --tasks {' '.join(config.tasks)}"
        compute = (
            f"compute them with `tooldesign bench protocol --references --size {size}{tasks} "
            "--out FILE.json` and pass --reference-file FILE.json"
        )
        fix = (
            compute
            if args.reference_file is not None
            else f"{compute} (or run with --with-references)"
        )
        raise ValueError(
            f"no reference for instance {missing[0]} in {path} ({len(missing)} of the run's "
            f"{len(config.cells())} cells lack one); {fix}"
        )


def run_protocol_command(args: argparse.Namespace) -> int:
    """Run the protocol as the parsed ``tooldesign bench`` arguments ask.

    Raises:
        ValueError: bad input (one line for the command line).
    """
    from benchmarks.protocol import (
        DEGREES,
        PROTOCOL_SIZES,
        buildable_fraction,
        compute_references,
        export_ioh,
        load_runs,
        make_protocol_report,
        protocol_config,
        run_protocol,
    )
    from benchmarks.protocol.report import (
        REFERENCES_IN_FOLDER,
        find_references,
        record_references,
    )

    for name, flag in (
        ("config", "--config"),
        ("dump_config", "--dump-config"),
        ("section_shape", "--section-shape"),
    ):
        if getattr(args, name, None) is not None:
            raise ValueError(f"{flag} is not available for the protocol suite (docs/protocol.md)")
    if getattr(args, "scene", None):
        raise ValueError("--scene is not available for the protocol suite: its instances set it")
    if args.buildable is not None:
        # It draws designs in this process and prints; the run's options would be ignored.
        others = _flags(
            args,
            (
                "size",
                "out",
                "tasks",
                "optimizer",
                "baseline",
                "reference_file",
                "references",
                "with_references",
                "verify_references",
                "workers",
                "executor",
                "scheduler",
                "max_retries",
            ),
        )
        if args.buildable < 1:
            raise ValueError(f"--buildable must be an int >= 1, got {args.buildable}")
        if others:
            raise ValueError(
                f"--buildable prints the buildable fraction of random designs at every degree "
                f"and exits: no {', '.join(others)}"
            )
        for degree in DEGREES:
            print(buildable_fraction(degree, args.buildable).text(), flush=True)
        return 0
    size = args.size or "full"
    if size not in PROTOCOL_SIZES:
        raise ValueError(f"unknown size {size!r}; protocol sizes: {', '.join(PROTOCOL_SIZES)}")
    try:
        config = protocol_config(size, optimizer=args.optimizer, tasks=args.tasks)
    except ValueError as err:
        raise ValueError(f"--tasks: {err}" if args.tasks is not None else str(err)) from None
    changes: dict[str, Any] = {}
    if args.workers is not None:
        changes["workers"] = args.workers
    if args.scheduler is not None:
        changes.update(scheduler=args.scheduler, executor=args.executor or "dask")
    elif args.executor is not None:
        changes["executor"] = args.executor
    if args.max_retries is not None:
        changes["max_retries"] = args.max_retries
    if changes:
        config = config.replace(**changes)
    say = None if args.no_progress else (lambda line: print(line, flush=True))
    if args.verify_references:
        return _verify(args, config, size, say)
    if args.references:
        if args.with_references:
            raise ValueError("--references and --with-references: give one")
        if args.optimizer is not None or args.baseline is not None:
            raise ValueError("--references computes references only: no --optimizer, --baseline")
        if args.max_retries is not None:
            # compute_references makes its executor without retries: the flag would be ignored.
            raise ValueError(
                f"--max-retries {args.max_retries} is for the runs' cells: --references evaluates "
                "without retries (an interrupted computation resumes at its next cell)"
            )
        if args.reference_file is not None:
            # It writes the references into --out; --reference-file is what a run measures
            # against, so the pair would read as "compute them into FILE" and be ignored.
            raise ValueError(
                f"--references computes the references into --out {args.out}: no "
                f"--reference-file {args.reference_file} (a run measures against that one)"
            )
        path = compute_references(config, args.out, say=say)
        print(f"references: {path}")
        return 0
    if args.with_references and args.reference_file is not None:
        raise ValueError(
            f"--with-references computes the run's references into {args.out}/"
            f"{REFERENCES_IN_FOLDER} and measures against them, --reference-file "
            f"{args.reference_file} measures against that file: give one"
        )
    # Every refusal the run or its report would make, before a cell starts or a file is
    # written: the optimizer, the baselines beside it, the references it is measured against.
    _check_optimizer(config, args.optimizer)
    if args.baseline is not None:
        _check_baselines(args, config)
    _check_references(args, config, size)
    out = run_protocol(config, args.out, progress=not args.no_progress, say=say)
    _, runs = load_runs(out)
    info = {o.column: f"{o.name} {dict(o.settings)}" for o in config.optimizers}
    export_ioh(runs, out / "ioh", algorithm_info=info, run_folder=out)
    print(f"IOHprofiler data: {out / 'ioh'}")
    folders = [out, *(args.baseline or [])]
    if args.with_references and args.reference_file is None and _lacks_cells(folders, size, config):
        # The folder's own references are extended in place; others (the committed ones, a
        # baseline's) seed the folder's new file, which the report then uses.
        own = out / REFERENCES_IN_FOLDER
        found = find_references(folders, size)
        seed = None if found is None or Path(found) == own else found
        path = compute_references(config, own, say=say, seed_from=seed)
        digest = record_references(out)  # a report checks the file against this SHA-256
        print(f"references: {path} (sha256 {digest[:16]}..., recorded in protocol.json)")
    try:
        files = make_protocol_report(folders, out / "report", references=args.reference_file)
    except ValueError as err:
        if not str(err).startswith("no references for size"):
            raise  # a references file that does not match or changed is an error, not a skip
        print(f"no report: {err}")
        return 0
    print(f"report: {out / 'report' / 'report.md'} ({len(files)} files)")
    from benchmarks.reports import write_html_report

    print(f"page: {write_html_report(out)} (rankings, power and ECDFs first)")
    return 0
