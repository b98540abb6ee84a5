"""The README's pictures and numbers, from one command.

``tooldesign readme`` runs the README's design command (CMA-ES, seed 0, 15 iterations of
8 tools, p^X = 20), evaluates the straight tool C = (0, 0, 0) on the same task, and writes into
``docs/images/``:

* ``designed_tool.png`` (Figure 3d), ``box_paths.png`` (Figure 3c), ``rollout.gif``;
* ``readme.json``: the numbers quoted in the README and on the docs' first page.

It then rewrites the block between ``<!-- readme-numbers:start -->`` and
``<!-- readme-numbers:end -->`` in ``README.md`` and ``docs/index.md`` from ``readme.json``.
``tests/test_readme_numbers.py`` checks that both blocks are what ``readme.json`` renders to, so
a number in the README cannot drift from what the command measured. The run takes minutes
(about 6 on 2 cores); its run folder is kept under ``--work``.

Run: ``tooldesign readme [--iterations 15] [--workers N] [--work DIR]``.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any, cast

from benchmarks.reports import markdown
from tooldesign_env.schema import METRICS

__all__ = ["BLOCK_END", "BLOCK_START", "add_parser", "measure", "render_block", "replace_block"]

BLOCK_NAME = "readme-numbers"
BLOCK_START, BLOCK_END = markdown.block_markers(BLOCK_NAME)
NUMBERS_FILE = "readme.json"
IMAGES = {
    "fig3d_final_tool.png": "designed_tool.png",
    "fig3c_box_paths.png": "box_paths.png",
    "rollout.gif": "rollout.gif",
}


def render_block(numbers: Mapping[str, Any], images: str) -> str:
    """The README block (between the markers, exclusive) for the numbers of ``readme.json``.

    Args:
        numbers: the content of ``readme.json``.
        images: the folder of the images relative to the page (``docs/images`` for the README,
            ``images`` for ``docs/index.md``).

    Returns:
        Markdown text, ending with a newline.

    Raises:
        KeyError: a number is missing from ``numbers``.
    """
    d, s = numbers["designed"], numbers["straight"]
    coeffs = ", ".join(f"{c:.3g}" for c in d["coefficients"])
    closer = d["final_distance"] < s["final_distance"]
    comparison = (
        f"closer to the goal than the straight tool C = (0, 0, 0) ({s['final_distance']:.2f} m)"
        if closer
        else f"while the straight tool C = (0, 0, 0) gets within {s['final_distance']:.2f} m"
    )
    return (
        f"The tool that command designs (seed {numbers['seed']}, p^X = "
        f"{numbers['goal_precision']:g}, C = ({coeffs}), F = {d['free_energy']:.0f}), and the box "
        "paths of the best tool of each iteration (start: black circle, ends: crosses, goal: red "
        "star; the best tool in red):\n"
        "\n"
        f"![A designed tool]({images}/designed_tool.png)\n"
        f"![Box paths of the best tools per iteration]({images}/box_paths.png)\n"
        f"![The designed tool in use]({images}/rollout.gif)\n"
        "\n"
        f"**What to expect.** The designed tool leaves the box {d['final_distance']:.2f} m from "
        f"the goal, {comparison}; F is {d['free_energy']:.0f} for the designed tool and "
        f"{s['free_energy']:.0f} for the straight one. The designer minimizes F, not the "
        "distance: F trades the goal "
        f"error (designed {d['goal_error']:.0f}, straight {s['goal_error']:.0f}) for control "
        f"confidence (designed {d['confidence']:.0f}, straight {s['confidence']:.0f}), and "
        "p^X sets the exchange rate. These numbers come from `tooldesign readme`, "
        "which also draws the pictures.\n"
    )


def replace_block(text: str, block: str) -> str:
    """``text`` with the part between the markers replaced by ``block``.

    Raises:
        ValueError: the markers are missing, repeated or out of order.
    """
    return markdown.replace_block(text, BLOCK_NAME, block)


def current_block(text: str) -> str:
    """The part between the markers (exclusive, without the newline after the start marker).

    Raises:
        ValueError: the markers are missing, repeated or out of order.
    """
    return markdown.current_block(text, BLOCK_NAME)


def _terms(info: Mapping[str, Any]) -> dict[str, Any]:
    return {k: float(info[k]) for k in METRICS}


def measure(
    *, iterations: int, batch_size: int, seed: int, workers: int | None, work: Path
) -> tuple[dict[str, Any], Path]:
    """Run the README's design and evaluate the straight tool; returns (numbers, run folder)."""
    from benchmarks.design import DesignConfig, run_design
    from benchmarks.storage import platform_id
    from tooldesign_env import ToolDesignEnv

    config = DesignConfig(
        optimizer="cmaes",
        seed=seed,
        iterations=iterations,
        batch_size=batch_size,
        workers=workers,
    )
    run = work / "design"
    result = run_design(config, run, resume=True, video=True)
    from benchmarks.reports import write_design_report

    write_design_report(run)
    env = ToolDesignEnv(goal=config.goal, goal_precision=config.goal_precision)
    try:
        env.reset(seed=0)
        straight = env.step([0.0, 0.0, 0.0])[4]
    finally:
        env.close()
    designed = {
        "coefficients": [float(c) for c in result.coefficients],
        "free_energy": result.free_energy,
        "goal_error": result.goal_error,
        "confidence": result.confidence,
        "final_distance": result.final_distance,
    }
    numbers = {
        "command": (
            f"tooldesign design --optimizer cmaes --seed {seed} --iterations {iterations} "
            f"--batch-size {batch_size}"
        ),
        "seed": seed,
        "iterations": iterations,
        "batch_size": batch_size,
        "goal_precision": config.goal_precision,
        "goal": list(config.goal),
        "estimator": config.estimator,
        # the last bits of F depend on the CPU kind: tests/test_readme_numbers.py re-evaluates
        # both tools and expects these numbers bit for bit on this platform only
        "platform": platform_id(),
        "designed": designed,
        "straight": {"coefficients": [0.0, 0.0, 0.0], **_terms(straight)},
    }
    return numbers, run


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an int >= 1, got {text}")
    return value


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``tooldesign readme``."""
    parser = subparsers.add_parser(
        "readme",
        help="regenerate the README's pictures and numbers (a design run of minutes)",
        description=(__doc__ or "").splitlines()[0],
    )
    parser.add_argument(
        "--iterations", type=_positive, default=15, help="CMA-ES iterations (default: 15)"
    )
    parser.add_argument(
        "--batch-size", type=_positive, default=8, help="tools per iteration (default: 8)"
    )
    parser.add_argument("--seed", type=int, default=0, help="the design's seed (default: 0)")
    parser.add_argument(
        "--workers", type=_positive, default=None, help="processes (default: every core)"
    )
    parser.add_argument(
        "--root", type=Path, default=Path.cwd(), help="the repository (default: here)"
    )
    parser.add_argument(
        "--work", type=Path, default=None, help="keep the run folder here (default: a temp dir)"
    )
    parser.set_defaults(run=_run)
    return cast("argparse.ArgumentParser", parser)


def _run(args: argparse.Namespace) -> int:
    """Regenerate the README's images and numbers; returns the exit code."""
    root = args.root.resolve()
    pages = {root / "README.md": "docs/images", root / "docs" / "index.md": "images"}
    for page in pages:
        if not page.is_file():
            raise ValueError(f"{page} not found; give the repository with --root")
        try:
            current_block(page.read_text(encoding="utf-8"))
        except ValueError as exc:
            raise ValueError(f"{page}: {exc}") from None
    work = args.work or Path(tempfile.mkdtemp(prefix="tooldesign-readme-"))
    numbers, run = measure(
        iterations=args.iterations,
        batch_size=args.batch_size,
        seed=args.seed,
        workers=args.workers,
        work=work,
    )
    from benchmarks.storage import atomic_write_bytes, atomic_write_text

    images = root / "docs" / "images"
    images.mkdir(parents=True, exist_ok=True)
    # Every file is written whole or not at all: an interrupted run leaves the old README.
    for source, target in IMAGES.items():
        if (run / source).exists():
            atomic_write_bytes(images / target, (run / source).read_bytes())
    atomic_write_text(images / NUMBERS_FILE, json.dumps(numbers, indent=2) + "\n")
    for page, prefix in pages.items():
        text = page.read_text(encoding="utf-8")
        atomic_write_text(page, replace_block(text, render_block(numbers, prefix)))
    print(f"wrote {images / NUMBERS_FILE}, the images and the blocks of {len(pages)} pages")
    print(f"run folder: {run}")
    return 0
