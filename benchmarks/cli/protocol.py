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
    from benchmarks.protocol.report import find_references, folder_references

    path = find_references(folders, size)
    if path is None:
        return True
    expected = None
    for folder in folders:
        found = folder_references(folder)
        if found is not None:
            expected = found[1]
            break
    cells = load_references(path, expected_sha256=expected)
    return any((i.label, d) not in cells for i, d in config.cells())


def _verify(args: argparse.Namespace, config: Any, size: str, say: Any) -> int:
    """``--verify-references``: 0 if every value is within its noise floor, else 1."""
    from benchmarks.protocol import packaged_references, verify_references
    from benchmarks.protocol.references import verify_verdict

    for name in ("references", "with_references", "optimizer", "baseline", "buildable", "out"):
        if getattr(args, name, None) is not None:
            raise ValueError(
                f"--verify-references checks references only: no --{name.replace('_', '-')} "
                "(it writes nothing)"
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
        if args.buildable < 1:
            raise ValueError(f"--buildable must be an int >= 1, got {args.buildable}")
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
        path = compute_references(config, args.out, say=say)
        print(f"references: {path}")
        return 0
    if args.baseline is not None:
        for folder in args.baseline:
            if Path(folder).resolve() == Path(args.out).resolve():
                raise ValueError(f"--baseline {folder} is the run folder --out itself")
            # Refuse a folder that is not a finished protocol run, or holds a link, before
            # running (load_runs refuses links below it).
            load_runs(folder)
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
