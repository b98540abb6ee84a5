"""Figures and tables of a stored ``rl`` suite run (reads its files only, never simulates)."""

from __future__ import annotations

import csv
import os
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["held_out_table", "plot_fixed_goal"]


def _read(path: Path) -> list[dict[str, str]]:
    if not path.is_file():
        raise FileNotFoundError(f"{path} does not exist: run the rl suite first")
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def plot_fixed_goal(
    results_dir: str | os.PathLike[str], out_png: str | os.PathLike[str] | None = None
) -> Path:
    """Best F so far against episodes at the fixed goal: median over seeds, and the range.

    Args:
        results_dir: a folder written by ``run_rl_suite`` (reads ``fixed_goal.csv``).
        out_png: the figure's path; ``<results_dir>/fixed_goal.png`` if None.

    Returns:
        The figure's path.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder = Path(results_dir)
    rows = _read(folder / "fixed_goal.csv")
    curves: dict[str, dict[str, list[float]]] = {}
    for row in rows:
        curves.setdefault(row["method"], {}).setdefault(row["seed"], []).append(
            float(row["best_so_far_F"])
        )
    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=110)
    for method, seeds in curves.items():
        n = min(len(v) for v in seeds.values())
        runs = np.array([v[:n] for v in seeds.values()])
        x = np.arange(1, n + 1)
        median = np.median(runs, axis=0)
        (line,) = ax.plot(x, median, label=f"{method} ({len(runs)} seeds)")
        ax.fill_between(x, runs.min(0), runs.max(0), color=line.get_color(), alpha=0.15)
    ax.set_xscale("log")
    ax.set_xlabel("episodes (tools simulated)")
    ax.set_ylabel("best F so far")
    ax.set_title("Default goal (0, 1.5, 0.1): median and range over seeds")
    summary = folder / "summary.json"
    if summary.is_file():
        import json

        straight = json.loads(summary.read_text()).get("fixed_goal", {}).get("straight_F")
        if straight is not None:
            ax.axhline(straight, color="k", ls="--", lw=1, label=f"straight tool ({straight:.0f})")
    finals = [float(r["best_so_far_F"]) for r in rows]
    # From the best of all to where the curves are after about 8 episodes.
    early = [float(r["best_so_far_F"]) for r in rows if r["episode"] == "8"]
    ax.set_ylim(min(finals) * 0.99, max(early or finals) * 1.02)
    ax.legend()
    ax.grid(alpha=0.3)
    out = Path(out_png) if out_png is not None else folder / "fixed_goal.png"
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)
    return out


def held_out_table(results_dir: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """Per approach on the held-out goals: median F, median F / straight tool's, episodes.

    Args:
        results_dir: a folder written by ``run_rl_suite`` (reads ``held_out.csv``).

    Returns:
        One dict per approach (``method`` or ``method@budget``), sorted by total episodes.
    """
    rows = _read(Path(results_dir) / "held_out.csv")
    straight = {r["goal_index"]: float(r["free_energy"]) for r in rows if r["method"] == "straight"}
    groups: dict[str, list[dict[str, str]]] = {}
    for r in rows:
        key = (
            r["method"]
            if r["budget_per_goal"] == "1"
            and r["method"]
            in (
                "straight",
                "ppo",
                "sac",
                "contextual",
            )
            else f"{r['method']}@{r['budget_per_goal']}"
        )
        groups.setdefault(key, []).append(r)
    table = []
    for key, group in groups.items():
        f = np.array([float(r["free_energy"]) for r in group])
        ratio = np.array([float(r["free_energy"]) / straight[r["goal_index"]] for r in group])
        table.append(
            {
                "approach": key,
                "median_F": float(np.median(f)),
                "median_F_over_straight": float(np.median(ratio)),
                "goals_better_than_straight_by_noise_floor": int(np.sum(ratio < 1 - 0.015)),
                "goals": len(group),
                "train_episodes": int(group[0]["train_episodes"]),
                "total_episodes": int(group[0]["total_episodes"]),
            }
        )
    return sorted(table, key=lambda t: (t["total_episodes"], t["approach"]))
