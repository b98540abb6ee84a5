"""The runs of a protocol folder in the IOHprofiler format, for IOHanalyzer and iohinspector.

The format is the one the ``ioh`` package's ``logger.Analyzer`` writes (its documented layout,
written here directly so that exporting needs no extra package; a test reads it back with
``iohinspector``). In IOHprofiler's terms a task is one **function** (push id 1, then hook
2, obstacle 3, puck 4: its place in the task registry, ``tooldesign_env.tasks.task_names``, plus
one; a user's task gets 5, 6, ... in the order tasks were registered in the process, so its id
may differ between processes, while its file names carry its name), a protocol instance is an
IOH **instance** (its number in its task's set), the tool degree d is the **dimension**, and
each (instance, seed) run of an optimizer is one **run**::

    ioh/<optimizer>/IOHprofiler_f1_push.json            meta: algorithm, scenarios, runs
                                                        (<optimizer> percent-encoded)
    ioh/<optimizer>/data_f1_push/IOHprofiler_f1_DIM<d>.dat
    ioh/<optimizer>/IOHprofiler_f2_hook.json            another task's (the task axis)
    ioh/<optimizer>/data_f2_hook/IOHprofiler_f2_DIM<d>.dat

Each ``.dat`` holds, per run in the order of the JSON's ``runs``, a header line
``evaluations raw_y`` and one line per improvement of the best-so-far F (the first evaluation
included), then the run's last evaluation if it did not improve, as ``ioh``'s Analyzer logs by
default (a test replays runs through it and compares). ``raw_y`` is the F of that evaluation
(minimized); F is written with 17 significant digits, so the numbers read back are the run
folder's bit for bit. A failed evaluation (NaN F) counts in ``evaluations`` and improves
nothing.
"""

from __future__ import annotations

import json
import os
import urllib.parse
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

__all__ = ["IOH_FOLDER", "export_ioh"]

IOH_FOLDER = "ioh"


def function_id(task: str) -> int:
    """The IOH function id of a task: its place in the task registry plus one (push is 1)."""
    from tooldesign_env.tasks import task_names

    names = task_names()
    if task not in names:
        raise ValueError(f"unknown task {task!r}; known tasks: {', '.join(names)}")
    return names.index(task) + 1


def _number(value: float) -> str:
    return repr(float(value))


def export_ioh(
    runs: pd.DataFrame,
    out_dir: str | os.PathLike[str],
    *,
    algorithm_info: Mapping[str, str] | None = None,
    run_folder: str | os.PathLike[str] | None = None,
) -> list[Path]:
    """Write the runs in the IOHprofiler format under ``out_dir``.

    Args:
        runs: One row per evaluation: ``optimizer``, ``instance_number``, ``degree``, ``seed``,
            ``evaluation`` (1-based order within its run), ``free_energy`` and the coefficient
            columns ``c1..cd`` (for the best point); ``task`` if not push alone.
        out_dir: The folder to write (``<run folder>/ioh``); files in it are replaced.
        algorithm_info: Per optimizer, the text of the meta's ``algorithm.info``.
        run_folder: The run folder ``out_dir`` lies in (its parent if ``None``): nothing is
            written through a symbolic link below it (``ioh/`` or an optimizer's folder
            replaced by a link to another folder is refused).

    Raises:
        ValueError: Missing columns; ``benchmarks.storage.UnsafeRunFileError`` (a ValueError)
            for a linked folder.

    Returns:
        The meta files written, one per optimizer and task.
    """
    from benchmarks.storage import atomic_write_text, check_write_folder

    required = ("optimizer", "instance_number", "degree", "seed", "evaluation", "free_energy")
    missing = [c for c in required if c not in runs.columns]
    if missing:
        raise ValueError(f"runs lacks columns {missing}")
    out = Path(out_dir)
    root = Path(run_folder) if run_folder is not None else out.parent
    check_write_folder(root, out)
    written = []
    if "task" not in runs.columns:
        runs = runs.assign(task="push")
    for (optimizer, task), frame in runs.groupby(["optimizer", "task"], sort=True):
        folder = out / urllib.parse.quote(str(optimizer), safe="")  # a module:Class label too
        fid, fname = function_id(str(task)), str(task)
        data_dir = folder / f"data_f{fid}_{fname}"
        check_write_folder(root, data_dir)
        data_dir.mkdir(parents=True, exist_ok=True)
        check_write_folder(root, data_dir)
        scenarios = []
        for degree, by_dim in frame.groupby("degree", sort=True):
            columns = [f"c{k}" for k in range(1, int(degree) + 1)]
            lines: list[str] = []
            meta_runs: list[dict[str, Any]] = []
            for (number, _seed), run in by_dim.groupby(["instance_number", "seed"], sort=True):
                run = run.sort_values("evaluation")
                f = run["free_energy"].to_numpy(dtype=np.float64)
                lines.append("evaluations raw_y")
                best = np.inf
                best_row = None
                last = -1
                for k, value in enumerate(f):
                    if np.isfinite(value) and (value < best or best_row is None):
                        best = value
                        best_row = k
                        last = k
                        lines.append(f"{int(run['evaluation'].iloc[k])} {_number(value)}")
                if last != len(f) - 1 and np.isfinite(f[-1]):
                    # ioh's Analyzer closes a run with its last evaluation, improving or not.
                    lines.append(f"{int(run['evaluation'].iloc[-1])} {_number(f[-1])}")
                entry: dict[str, Any] = {"instance": int(number), "evals": len(f)}
                if best_row is not None:
                    x = run[columns].iloc[best_row].to_numpy(dtype=np.float64).tolist()
                    entry["best"] = {
                        "evals": int(run["evaluation"].iloc[best_row]),
                        "y": float(best),
                        "x": x,
                    }
                meta_runs.append(entry)
            path = data_dir / f"IOHprofiler_f{fid}_DIM{int(degree)}.dat"
            atomic_write_text(path, "\n".join(lines) + "\n")
            scenarios.append(
                {
                    "dimension": int(degree),
                    "path": f"{data_dir.name}/{path.name}",
                    "runs": meta_runs,
                }
            )
        meta = {
            "version": "0.3.22",
            "suite": "tooldesign-protocol",
            "function_id": fid,
            "function_name": fname,
            "maximization": False,
            "algorithm": {
                "name": str(optimizer),
                "info": (algorithm_info or {}).get(str(optimizer), ""),
            },
            "attributes": ["evaluations", "raw_y"],
            "scenarios": scenarios,
        }
        target = folder / f"IOHprofiler_f{fid}_{fname}.json"
        atomic_write_text(target, json.dumps(meta, indent=1) + "\n")
        written.append(target)
    return written
