"""``tooldesign bench``: run a benchmark suite into one run folder, then write its report.

``tooldesign bench rl`` runs the rl suite (:mod:`benchmarks.rl`), which has its own sizes and
options (:mod:`benchmarks.cli.rl_suite`).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from benchmarks.cli._common import (
    BUILTIN_SUITES,
    PROTOCOL_SIZES,
    PROTOCOL_SUITE_NAME,
    RL_SIZES,
    RL_SUITE_NAME,
    SECTION_SHAPES,
    SIZES,
    add_max_retries_argument,
    add_scene_argument,
    check_out_folder,
    out_path,
    unique_pairs,
)
from benchmarks.cli.protocol import (
    PROTOCOL_ONLY_OPTIONS,
    add_protocol_arguments,
    run_protocol_command,
)
from benchmarks.cli.rl_suite import RL_ONLY_OPTIONS, add_rl_suite_arguments, run_rl_command
from benchmarks.execution import EXECUTORS

if TYPE_CHECKING:
    from benchmarks.suites import SuiteConfig


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``tooldesign bench`` on the dispatcher's subparsers."""
    parser = subparsers.add_parser(
        "bench",
        help="run a benchmark suite (optimizers, precision-sweep, robustness, ...)",
        description=(
            "Run a benchmark suite into one run folder, resuming what is there, and write its "
            "report. See docs/benchmarks.md."
        ),
    )
    parser.add_argument(
        "suite",
        nargs="?",
        metavar="SUITE",
        help=f"a built-in suite: {', '.join(BUILTIN_SUITES)}, {RL_SUITE_NAME} (the RL "
        f"baselines, docs/rl.md) or {PROTOCOL_SUITE_NAME} (the benchmark protocol, "
        "docs/protocol.md); or omit it and give --config",
    )
    parser.add_argument(
        "--size",
        default=None,
        help=f"size of the suite: {' or '.join(SIZES)} (default: full; a suite file may define "
        f"its own; the rl suite: {', '.join(RL_SIZES)}; the protocol: "
        f"{', '.join(PROTOCOL_SIZES)})",
    )
    parser.add_argument(
        "--out",
        type=out_path,
        default=None,
        metavar="DIR",
        help="run folder (required except with the protocol's --buildable and --verify-references)",
    )
    parser.add_argument(
        "--config",
        type=Path,
        default=None,
        metavar="FILE",
        help="a suite file (.toml or .json); see docs/benchmarks.md",
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="worker processes (default: the CPUs this process may use; the rl suite: 1)",
    )
    parser.add_argument(
        "--executor", choices=EXECUTORS, default=None, help="where designs are evaluated"
    )
    parser.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDR",
        help="Dask scheduler address, e.g. tcp://host:8786 (implies --executor dask)",
    )
    add_max_retries_argument(parser, None)
    parser.add_argument(
        "--section-shape",
        choices=SECTION_SHAPES,
        default=None,
        help="the tool's section in every run: round or the paper's square (default: the "
        "suite's own, round unless its file says otherwise; not for the rl suite)",
    )
    add_scene_argument(parser, "in every run, over the suite's own [scene] (not for the rl suite)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument(
        "--dump-config",
        type=Path,
        default=None,
        metavar="FILE",
        help="write the resolved suite to FILE (.toml or .json) and exit without running",
    )
    add_rl_suite_arguments(parser, title=f"the {RL_SUITE_NAME} suite only")
    add_protocol_arguments(parser, title=f"the {PROTOCOL_SUITE_NAME} suite only")
    parser.set_defaults(run=_run)
    return cast("argparse.ArgumentParser", parser)


def config_from_args(args: argparse.Namespace) -> SuiteConfig:
    """The suite of parsed ``tooldesign bench`` arguments."""
    from benchmarks.suites import builtin_suite, load_suite

    if args.size is not None and args.size not in SIZES and args.config is None:
        raise ValueError(f"unknown size {args.size!r}; sizes: {', '.join(SIZES)}")
    if args.config is not None:
        config = load_suite(args.config, size=args.size)
        if args.suite is not None and args.suite != config.name:
            raise ValueError(
                f"SUITE {args.suite!r} does not match the name {config.name!r} in {args.config}; "
                "omit SUITE with --config"
            )
    elif args.suite is None:
        raise ValueError(f"give a SUITE ({', '.join(BUILTIN_SUITES)}) or --config FILE")
    else:
        config = builtin_suite(args.suite, args.size or "full")
    changes: dict[str, Any] = {}
    if args.workers is not None:
        changes["workers"] = args.workers
    if args.scheduler is not None:
        changes["scheduler"] = args.scheduler
        changes["executor"] = args.executor or "dask"
    if args.executor is not None:
        changes["executor"] = args.executor
    if args.max_retries is not None:
        changes["max_retries"] = args.max_retries
    if args.section_shape is not None:
        changes["section_shape"] = args.section_shape
    if args.scene:
        changes["scene"] = {**dict(config.scene), **unique_pairs(args.scene, "--scene")}
    return config.replace(**changes) if changes else config


def _run(args: argparse.Namespace) -> int:
    checks_only = args.suite == PROTOCOL_SUITE_NAME and (
        args.buildable is not None or args.verify_references
    )
    if args.out is None and not checks_only:
        raise ValueError("--out DIR is required: the run folder (see tooldesign bench --help)")
    if args.suite == RL_SUITE_NAME:
        if args.section_shape is not None:
            raise ValueError(
                f"--section-shape {args.section_shape}: not for the {RL_SUITE_NAME} suite, whose "
                "envs use the default tool (round)"
            )
        if args.scene:
            raise ValueError(
                f"--scene {args.scene[0][0]}=...: not for the {RL_SUITE_NAME} suite, whose envs "
                "use the default scene"
            )
        if _given(args, PROTOCOL_ONLY_OPTIONS):
            flags = _given(args, PROTOCOL_ONLY_OPTIONS)
            raise ValueError(f"{flags}: for the {PROTOCOL_SUITE_NAME} suite only")
        return run_rl_command(args, default_size="full")
    if args.suite == PROTOCOL_SUITE_NAME:
        if _given(args, RL_ONLY_OPTIONS):
            raise ValueError(f"{_given(args, RL_ONLY_OPTIONS)}: for the {RL_SUITE_NAME} suite only")
        return run_protocol_command(args)
    for names, suite in (
        (RL_ONLY_OPTIONS, RL_SUITE_NAME),
        (PROTOCOL_ONLY_OPTIONS, PROTOCOL_SUITE_NAME),
    ):
        if _given(args, names):
            raise ValueError(f"{_given(args, names)}: for the {suite} suite only")
    # Before the suites, the simulation and the plotting are imported (seconds): the same
    # refusals as theirs, at once.
    if args.config is None and args.suite is not None and args.suite not in BUILTIN_SUITES:
        raise ValueError(
            f"unknown suite {args.suite!r}; built-in suites: {', '.join(BUILTIN_SUITES)} (or "
            "give a suite file with --config)"
        )
    if args.dump_config is None:
        check_out_folder(args.out)
    from benchmarks.reports import make_suite_report
    from benchmarks.suites import run_suite, save_suite, summary_text

    config = config_from_args(args)
    if args.dump_config is not None:
        _check_optimizer_settings(config)
        print(f"suite written to {save_suite(config, args.dump_config)}")
        return 0
    size = args.size or ("full" if args.config is None else None)
    # A suite file may be kept in the folder of its results (docs/results/cage/suite.toml).
    own = [args.config] if args.config is not None else []
    result = run_suite(config, args.out, progress=not args.no_progress, size=size, own_files=own)
    report = make_suite_report(result.out_dir)
    print(summary_text(result))
    if report:
        print(f"report: {report[0].parent} ({len(report)} files)")
    return 0


def _given(args: argparse.Namespace, names: tuple[str, ...]) -> str:
    """The flags of ``names`` given on the command line, as ``--a, --b`` ("" if none)."""
    return ", ".join(f"--{n.replace('_', '-')}" for n in names if getattr(args, n) is not None)


def _check_optimizer_settings(config: SuiteConfig) -> None:
    """Refuse a suite whose optimizers ``run_suite`` would refuse, with the error it would give.

    Each optimizer is made once with its settings, as ``run_suite`` does before it makes a file
    (no simulation). An optimizer whose backend or plugin cannot be imported here is not
    refused, as the file may be meant for a machine that has it: a warning says that its
    settings were not checked.
    """
    import warnings

    from benchmarks.suites import check_optimizers

    for spec in config.optimizers:
        try:
            check_optimizers(config.replace(optimizers=(spec,)))
        except ValueError as err:
            if not isinstance(err.__cause__, ImportError):
                raise
            warnings.warn(
                f"the settings of optimizer {spec.name!r} are not checked: {err.__cause__}",
                UserWarning,
                stacklevel=2,
            )
