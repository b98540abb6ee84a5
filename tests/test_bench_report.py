"""Tests of benchmarks.reports.comparison on synthetic run folders."""

from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from benchmarks.reports.comparison import (
    DPI,
    FIGSIZE,
    convergence_table,
    make_report,
    new_figure,
    optimizer_colors,
    pairwise_table,
    plot_convergence,
    summary_table,
)
from benchmarks.storage import EmptyStoreError, ResultStore

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
OFFSETS = {"cmaes": 0.0, "random": 2.0}
N_BOOT = 200


def make_batch(optimizer: str, seed: int, iteration: int, *, suite: str = "opt") -> pd.DataFrame:
    """A batch whose F falls with iterations; random ends 2 higher than cmaes."""
    rng = np.random.default_rng([seed, iteration, zlib.crc32(optimizer.encode())])
    n = 4
    return pd.DataFrame(
        {
            "suite": suite,
            "optimizer": optimizer,
            "seed": seed,
            "iteration": iteration,
            "candidate": np.arange(n),
            "eval_id": iteration * n + np.arange(n),
            "c1": rng.uniform(-1, 1, n),
            "c2": rng.uniform(-1, 1, n),
            "c3": rng.uniform(-1, 1, n),
            "free_energy": OFFSETS[optimizer] + 10.0 / (1 + iteration) + 0.1 * rng.random(n),
            "goal_error": rng.random(n),
            "confidence": rng.standard_normal(n),
            "final_distance": rng.random(n),
            "status": "ok",
            "eval_time": rng.random(n),
            "opt_time": 0.01,
            "goal_x": 0.0,
            "goal_y": 1.5,
            "goal_z": 0.1,
            "goal_precision": 20.0,
            "box_mass": 0.1,
        }
    )


def make_store(folder: Path, *, suites: tuple[str, ...] = ("opt",), seeds: int = 4) -> Path:
    store = ResultStore(folder)
    for suite in suites:
        for optimizer in OFFSETS:
            for seed in range(seeds):
                for iteration in range(5):
                    store.write_batch(make_batch(optimizer, seed, iteration, suite=suite))
    return folder


@pytest.mark.slow
def test_report_writes_figure_and_tables(tmp_path: Path) -> None:
    run = make_store(tmp_path / "run")
    paths = make_report(run, n_boot=N_BOOT)
    names = [p.name for p in paths]
    assert names == [
        "convergence-opt.png",
        "summary.csv",
        "summary.md",
        "pairwise.csv",
        "pairwise.md",
    ]
    assert all(p.parent == run / "report" and p.is_file() for p in paths)
    png = paths[0].read_bytes()
    assert png.startswith(PNG_SIGNATURE)
    width, height = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
    assert (width, height) == (round(FIGSIZE[0] * DPI), round(FIGSIZE[1] * DPI))
    assert b"Software" not in png and b"Matplotlib" not in png

    summary = pd.read_csv(run / "report" / "summary.csv")
    assert summary["optimizer"].tolist() == ["cmaes", "random"]
    assert (summary["runs"] == 4).all() and (summary["iterations_max"] == 5).all()
    low, mean, high = (
        summary[c] for c in ("final_free_energy_low", "final_free_energy", "final_free_energy_high")
    )
    assert ((low <= mean) & (mean <= high)).all()
    # random is 2 higher by construction, so cmaes wins on final F and AUC.
    gap = summary["final_free_energy"].iloc[1] - summary["final_free_energy"].iloc[0]
    assert gap == pytest.approx(2.0, abs=0.1)
    assert summary["auc"].iloc[0] < summary["auc"].iloc[1]

    pairwise = pd.read_csv(run / "report" / "pairwise.csv", keep_default_na=False)
    assert pairwise["metric"].tolist() == ["final_free_energy", "auc"]
    assert (pairwise["a"] == "cmaes").all() and (pairwise["a12"] == 0.0).all()
    # Exact two-sided test, 4 vs 4, U = 0: p = 2 / C(8, 4).
    assert pairwise["p"].tolist() == pytest.approx([2 / 70, 2 / 70])

    markdown = (run / "report" / "summary.md").read_text()
    assert "| cmaes | 4 | 5 |" in markdown and "## opt" in markdown
    assert "A12 < 0.5 means `a` is better" in (run / "report" / "pairwise.md").read_text()


@pytest.mark.slow
def test_same_store_gives_same_bytes(tmp_path: Path) -> None:
    run = make_store(tmp_path / "run")
    first = {p.name: p.read_bytes() for p in make_report(run, n_boot=N_BOOT)}
    second = {p.name: p.read_bytes() for p in make_report(run, n_boot=N_BOOT)}
    assert first == second  # CSV, Markdown and, with one matplotlib, the PNG too
    # The default t interval draws nothing: the seed does not change it.
    make_report(run, out_dir=tmp_path / "t1", n_boot=N_BOOT, seed=1)
    assert (tmp_path / "t1" / "summary.csv").read_bytes() == first["summary.csv"]
    # The bootstrap's seed decides its bounds, and the same seed gives the same bytes.
    boot = {
        seed: make_report(
            run, out_dir=tmp_path / f"boot{seed}", n_boot=N_BOOT, seed=seed, interval="bootstrap"
        )
        for seed in (0, 1)
    }
    summary = {seed: (tmp_path / f"boot{seed}" / "summary.csv").read_bytes() for seed in (0, 1)}
    assert summary[0] != summary[1] and summary[0] != first["summary.csv"]
    assert len(boot[1]) == len(first)
    again = make_report(run, out_dir=tmp_path / "again", n_boot=N_BOOT, interval="bootstrap")
    assert again[0].parent.joinpath("summary.csv").read_bytes() == summary[0]
    with pytest.raises(ValueError, match="interval must be one of"):
        make_report(run, out_dir=tmp_path / "bad", interval="percentile")
    assert not (tmp_path / "bad").exists()  # refused before anything was written


@pytest.mark.slow
def test_report_has_one_figure_per_suite(tmp_path: Path) -> None:
    run = make_store(tmp_path / "run", suites=("alpha", "beta/2"), seeds=2)
    paths = make_report(run, n_boot=N_BOOT)
    pngs = sorted(p.name for p in paths if p.suffix == ".png")
    assert pngs[0] == "convergence-alpha.png"
    assert pngs[1].startswith("convergence-beta_2-") and len(pngs) == 2
    summary = pd.read_csv(run / "report" / "summary.csv")
    assert summary["suite"].tolist() == ["alpha", "alpha", "beta/2", "beta/2"]


@pytest.mark.slow
def test_single_optimizer_gives_empty_pairwise_table(tmp_path: Path) -> None:
    store = ResultStore(tmp_path)
    for seed in range(2):
        store.write_batch(make_batch("cmaes", seed, 0))
    make_report(tmp_path, n_boot=N_BOOT)
    assert "nothing to compare" in (tmp_path / "report" / "pairwise.md").read_text()
    header = (tmp_path / "report" / "pairwise.csv").read_text().splitlines()
    assert header == [
        "suite,variant,metric,a,b,U,p,p_holm,a12,significant,n_a,n_b,note,"
        "mean_difference,beyond_noise"
    ]


@pytest.mark.slow
def test_one_seed_gives_nan_p_with_a_note_not_a_crash(tmp_path: Path) -> None:
    make_store(tmp_path, seeds=1)
    make_report(tmp_path, n_boot=N_BOOT)
    pairwise = pd.read_csv(tmp_path / "report" / "pairwise.csv", keep_default_na=False)
    assert (pairwise["p"] == "").all()
    assert pairwise["note"].str.contains("fewer than 2").all()


@pytest.mark.slow
def test_convergence_table_and_plot_are_reusable(tmp_path: Path) -> None:
    df = ResultStore(make_store(tmp_path)).read()
    table = convergence_table(df, n_boot=N_BOOT)
    assert len(table) == 2 * 5 and (table["n_seeds"] == 4).all()
    assert ((table["low"] <= table["mean"]) & (table["mean"] <= table["high"])).all()
    # The best so far never rises.
    for _, line in table.groupby("optimizer"):
        assert (np.diff(line["mean"]) <= 0).all()

    figure, ax = new_figure()
    assert plot_convergence(df, ax, x="evaluations", n_boot=N_BOOT, title="T") is ax
    assert ax.get_title() == "T" and ax.get_xlabel() == "evaluations"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["cmaes (n=4)", "random (n=4)"]
    assert ax.lines[0].get_xdata()[-1] == 20.0  # 5 iterations of 4 evaluations
    assert plot_convergence(df, n_boot=N_BOOT).figure is not figure


@pytest.mark.slow
def test_plot_convergence_bad_input(tmp_path: Path) -> None:
    df = ResultStore(make_store(tmp_path, suites=("a", "b"), seeds=1)).read()
    with pytest.raises(ValueError, match="one \\(suite, variant\\); the rows hold 2"):
        plot_convergence(df)
    with pytest.raises(ValueError, match="x must be"):
        plot_convergence(df[df["suite"] == "a"], x="time")


def test_tables_follow_report_order() -> None:
    assert list(optimizer_colors(["zeta", "random", "alpha", "cmaes"])) == [
        "cmaes",
        "random",
        "alpha",
        "zeta",
    ]
    assert optimizer_colors(["cmaes"])["cmaes"] == "tab:blue"


def test_summary_and_pairwise_work_without_a_store() -> None:
    df = pd.concat([make_batch(o, s, i) for o in OFFSETS for s in range(3) for i in range(3)])
    summary = summary_table(df, n_boot=N_BOOT)
    assert summary["runs"].tolist() == [3, 3]
    assert len(pairwise_table(df)) == 2


# --- bad input -----------------------------------------------------------------------------------


def test_report_of_missing_folder_names_it(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="no-such-run"):
        make_report(tmp_path / "no-such-run")


def test_report_of_empty_store_says_so(tmp_path: Path) -> None:
    with pytest.raises(EmptyStoreError, match="holds no results"):
        make_report(tmp_path)
    assert not (tmp_path / "report").exists()


def test_report_of_store_with_wrong_column_type_names_file_and_column(tmp_path: Path) -> None:
    make_store(tmp_path, seeds=1)
    part = next((tmp_path / "parts").rglob("iteration=000002.csv"))
    frame = pd.read_csv(part, keep_default_na=False)
    frame["free_energy"] = "high"
    part.write_text(frame.to_csv(index=False))
    with pytest.raises(TypeError, match=r"iteration=000002\.csv.*'free_energy' must hold numbers"):
        make_report(tmp_path)


def test_report_arguments_are_checked(tmp_path: Path) -> None:
    make_store(tmp_path, seeds=1)
    with pytest.raises(ValueError, match="level"):
        make_report(tmp_path, level=1.5)
    with pytest.raises(ValueError, match="alpha"):
        make_report(tmp_path, alpha=0.0)
