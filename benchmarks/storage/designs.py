"""The layout of design files: a design run's folder, and a suite's per-run design files.

Layout (names percent-encoded as in part paths)::

    run_folder/designs/variant=<v>/optimizer=<o>/seed=<n>.json        the run's best design,
                                                                       its test, its counts
    run_folder/designs/variant=<v>/optimizer=<o>/seed=<n>.paths.json  box paths (optional)

A design file is written last, atomically: its presence marks the run as complete.
"""

from __future__ import annotations

import json
import os
import urllib.parse
from pathlib import Path
from typing import Any

__all__ = [
    "RETEST_DIR",
    "read_retests",
    "retest_path",
    "DESIGN_RUN_FILES",
    "DESIGNS_DIR",
    "DESIGN_VERSION",
    "design_path",
    "paths_path",
    "read_designs",
]

DESIGN_RUN_FILES: dict[str, str] = {
    "card": "design.json",
    "stl": "tool.stl",
    "obj": "tool.obj",
    "urdf": "tool.urdf",
    "evaluations": "evaluations.csv",
    "robustness": "robustness.json",
    "robustness_png": "robustness.png",
    "fig3a": "fig3a_tool_curves.png",
    "fig3b": "fig3b_free_energy.png",
    "fig3c": "fig3c_box_paths.png",
    "fig3d": "fig3d_final_tool.png",
    "fig3": "figure3.png",
    "box_paths": "box_paths.json",
    "video": "rollout.gif",
    "html": "report.html",
}

"""Files of a finished ``tooldesign design`` run folder, besides ``manifest.json`` and ``parts/``.

``box_paths.json`` holds the box paths the figures draw (the best design of each iteration, and
the robustness test's), rounded to :data:`~tooldesign_env.schema.PATH_DECIMALS`; ``rollout.gif``
is written unless the video is turned off.
"""

DESIGNS_DIR = "designs"
"""Folder of the per-run design files in a run folder."""

DESIGN_VERSION = 1
"""``format_version`` of a design file."""


def _q(name: str) -> str:
    return urllib.parse.quote(name, safe="")


def design_path(
    run_folder: str | os.PathLike[str], *, variant: str, optimizer: str, seed: int
) -> Path:
    """The design file of a run: ``designs/variant=<v>/optimizer=<o>/seed=<n>.json``."""
    return (
        Path(run_folder)
        / DESIGNS_DIR
        / f"variant={_q(variant)}"
        / f"optimizer={_q(optimizer)}"
        / f"seed={int(seed)}.json"
    )


def paths_path(design_file: str | os.PathLike[str]) -> Path:
    """The box-path file next to a design file (``seed=<n>.paths.json``)."""
    path = Path(design_file)
    return path.with_name(path.name.removesuffix(".json") + ".paths.json")


def read_designs(run_folder: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The design files of a run folder, in a fixed order (variant, optimizer, seed).

    Args:
        run_folder: A suite run folder.

    Returns:
        One dict per finished run (the JSON of its design file); ``paths`` is added, loaded from
        its paths file, when there is one. Empty if the folder has no ``designs/``.

    Raises:
        ValueError: If a design file is not valid JSON.
    """
    folder = Path(run_folder) / DESIGNS_DIR
    if not folder.is_dir():
        return []
    records = []
    for path in sorted(folder.rglob("seed=*.json")):
        if path.name.endswith(".paths.json") or path.name.startswith("."):
            continue
        try:
            record = json.loads(path.read_text(encoding="utf-8"))
            extra = paths_path(path)
            if extra.is_file():
                record["paths"] = json.loads(extra.read_text(encoding="utf-8"))
        except json.JSONDecodeError as err:
            raise ValueError(f"{path}: not a valid design file: {err}") from err
        records.append(record)
    order = {"variant": str, "optimizer": str, "seed": int}
    records.sort(key=lambda r: tuple(t(r.get(k, "")) for k, t in order.items()))
    return records


RETEST_DIR = "retest"
"""Folder of the retest files in a run folder."""


def retest_path(run_folder: Path, design_file: Path) -> Path:
    """The retest file of a design file: ``retest/`` mirrors ``designs/``."""
    return run_folder / RETEST_DIR / design_file.relative_to(run_folder / DESIGNS_DIR)


def read_retests(run_folder: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """Every retest file of a run folder (empty if it was not retested), in a fixed order."""
    folder = Path(run_folder) / RETEST_DIR
    if not folder.is_dir():
        return []
    out = []
    for path in sorted(folder.rglob("seed=*.json")):
        try:
            out.append(json.loads(path.read_text(encoding="utf-8")))
        except ValueError as err:
            raise ValueError(f"{path}: not a valid retest file: {err}") from err
    return out
