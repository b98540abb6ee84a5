"""Figure 3 panels: iterations on a colour bar, the best tool highlighted, no point clipped."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import json
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from matplotlib.colors import to_rgba

from benchmarks.cli import main
from benchmarks.design import DesignConfig, run_design
from benchmarks.design import loop as design_loop
from benchmarks.reports import plots
from benchmarks.reports.design_figures import (
    _panel_curves,
    _panel_free_energy,
    _panel_paths,
    read_design_run,
    write_design_report,
)
from benchmarks.storage import DESIGN_RUN_FILES
from tooldesign_env import ToolSpec

RED = to_rgba("red")


def _bests(n=20):
    f = np.linspace(100.0, 50.0, n)
    f[min(7, n - 1)] = 40.0  # the best is not the last iteration
    return pd.DataFrame({"iteration": np.arange(n), "free_energy": f, "status": "ok"})


def _red_lines(ax):
    # The goal star is red too, but a marker without a line.
    lines = ax.get_lines()
    return [x for x in lines if to_rgba(x.get_color()) == RED and x.get_linestyle() != "None"]


def test_tool_curves_use_a_colour_bar_and_highlight_the_best():
    bests = _bests()
    designs = [np.array([0.0, 0.01 * k, 0.0]) for k in range(len(bests))]
    fig, ax = plots.new_figure()
    _panel_curves(ax, designs, bests, None, ToolSpec())
    assert len(fig.axes) == 2 and fig.axes[1].get_ylabel() == "iteration"
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    # The "+" at the origin is named too (issue 34: it was unexplained).
    assert texts == ["best tool (iteration 7)", plots.GRASP_LABEL]
    assert _red_lines(ax)


def test_box_paths_highlight_the_best_path():
    bests = _bests(5)
    bests.loc[:, "free_energy"] = [5.0, 4.0, 1.0, 3.0, 2.0]
    paths = [np.c_[np.linspace(0, 1, 4), np.full(4, k), np.zeros(4)] for k in range(5)]
    fig, ax = plots.new_figure()
    _panel_paths(ax, paths, bests, None, (0.0, 1.5, 0.1))
    (red,) = _red_lines(ax)
    np.testing.assert_array_equal(red.get_ydata(), np.full(4, 2.0))
    assert len(fig.axes) == 2


@pytest.mark.slow
def test_free_energy_axis_shows_every_evaluation_even_an_outlier():
    bests = _bests(4)
    evaluations = pd.DataFrame(
        {
            "iteration": [0, 0, 1, 1, 2, 2, 3, 3],
            "free_energy": [100.0, 20000.0, 90.0, 95.0, 80.0, 85.0, 70.0, 75.0],
            "status": "ok",
            "best_so_far": [100.0, 100.0, 90.0, 90.0, 80.0, 80.0, 70.0, 70.0],
        }
    )
    fig, ax = plots.new_figure()
    _panel_free_energy(ax, evaluations, bests)
    low, high = ax.get_ylim()
    assert low <= evaluations["free_energy"].min() and high >= 20000.0
    assert ax.get_yscale() == "log"
    assert len(_tick_labels(fig, ax)) >= 4


def _tick_labels(fig, ax):
    """The y tick labels a reader sees: inside the axis range and not empty."""
    fig.canvas.draw()
    low, high = ax.get_ylim()
    return [
        t.get_text()
        for t, v in zip(ax.get_yticklabels(), ax.get_yticks(), strict=True)
        if low <= v <= high and t.get_text()
    ]


def test_free_energy_log_axis_within_a_decade_has_readable_labels():
    # Issue 34: F from 8000 to 25000 on a log axis carried one label, 10^4.
    bests = pd.DataFrame({"iteration": [0, 1], "free_energy": [8945.4, 8337.5], "status": "ok"})
    f = [8945.4, 24582.5, 20809.5, 9654.2, 8337.5, 13063.5, 11021.4, 9398.2]
    evaluations = pd.DataFrame(
        {
            "iteration": [0, 0, 0, 0, 1, 1, 1, 1],
            "free_energy": f,
            "status": "ok",
            "best_so_far": [8945.4] * 4 + [8337.5] * 4,
        }
    )
    fig, ax = plots.new_figure()
    _panel_free_energy(ax, evaluations, bests)
    assert ax.get_yscale() == "log" and "log scale" in ax.get_ylabel()
    labels = _tick_labels(fig, ax)
    assert len(labels) >= 4 and all("10^" not in t and "$" not in t for t in labels), labels
    values = [float(t.replace(",", "")) for t in labels]
    assert min(values) <= 8337.5  # a labelled tick at or below the best F
    low, high = ax.get_ylim()
    assert low <= min(f) and high >= max(f)


def test_box_paths_name_every_marker_and_draw_the_goal_on_top():
    bests = _bests(3)
    paths = [np.c_[np.linspace(1, 0, 4), np.linspace(0.7, 1.5, 4), np.zeros(4)]] * 3
    fig, ax = plots.new_figure()
    _panel_paths(ax, paths, bests, None, (0.0, 1.5, 0.1))
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert texts[0] == "best tool"
    assert {plots.START_LABEL, plots.END_LABEL} <= set(texts)
    assert any(t.startswith(plots.GOAL_LABEL) and t.endswith(" m") for t in texts), texts
    (goal,) = [x for x in ax.get_lines() if x.get_marker() == "*"]
    assert goal.get_zorder() > max(x.get_zorder() for x in ax.get_lines() if x is not goal)
    assert "(m)" in ax.get_title() and "(m)" in ax.get_xlabel() and "(m)" in ax.get_ylabel()


def test_the_final_tool_panel_names_its_shapes_and_says_f_has_no_unit():
    from benchmarks.reports.design_figures import _panel_tool

    fig, ax = plots.new_figure()
    _panel_tool(ax, np.array([0.2, -0.3, 0.07]), 8337.49, ToolSpec())
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "centreline" in texts and plots.GRASP_LABEL in texts
    assert any(t.startswith("collision capsules from above") for t in texts), texts
    assert "F = 8,337 (dimensionless)" in ax.get_title()


@pytest.mark.slow
def test_the_robustness_figure_title_says_what_the_number_means(
    design_run: Path, tmp_path: Path
) -> None:
    import benchmarks.reports.design_figures as figures

    folder = tmp_path / "run"
    shutil.copytree(design_run, folder)

    titles = []
    real = figures.plots.save_png

    def spy(figure, path):
        titles.extend(ax.get_title() for ax in figure.axes)
        return real(figure, path)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(figures.plots, "save_png", spy)
        figures.write_design_report(folder)
    (title,) = [t for t in titles if "robustness =" in t]
    assert "mm per step" in title and "1.0 m" in title and "4 masses x 5 steps" in title


# --- a damaged design run folder: one error naming the file and the field, nothing written ------

PATH = np.linspace([1.2, 0.7, 0.1], [0.0, 1.2, 0.1], 5)


def _fake_rows(executor, designs, task, **kwargs):
    """A fake evaluator (F = |C|^2 - 1): the report needs stored files, not the physics."""
    rows = []
    for coeffs in np.asarray(designs, dtype=float):
        energy = float(np.sum(coeffs**2)) - 1.0
        rows.append(
            {
                "free_energy": energy,
                "goal_error": energy + 1.0,
                "confidence": 1.0,
                "final_distance": 0.5,
                "eval_time": 0.001,
                "message": "",
                "status": "ok",
                **({"box_trajectory": PATH} if kwargs.get("keep_trajectory") else {}),
            }
        )
    return rows


def _fake_robustness(executor, fn, requests):
    masses = list(requests[0].masses)
    result = {"robustness": -1.0, "accuracy": -2.0, "control_deviation": 3.0}
    result.update(nominal_mass=0.1, masses=masses, nominal_box_trajectory=PATH)
    return [({**result, "box_trajectories": [PATH] * len(masses)}, None, 0.0)]


@pytest.fixture(scope="module")
def design_run(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    out = tmp_path_factory.mktemp("design-report") / "run"
    config = DesignConfig(optimizer="random", seed=0, iterations=2, batch_size=3, executor="serial")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(design_loop, "evaluate_batch", _fake_rows)
        patch.setattr(design_loop, "map_robust", _fake_robustness)
        run_design(config, out, progress=False)
    yield out


def _edit_json(name: str, edit: Callable[[dict], None]) -> Callable[[Path], None]:
    def apply(folder: Path) -> None:
        path = folder / name
        data = json.loads(path.read_text(encoding="utf-8"))
        edit(data)
        path.write_text(json.dumps(data), encoding="utf-8")

    return apply


def _write(name: str, content: bytes) -> Callable[[Path], None]:
    return lambda folder: (folder / name).write_bytes(content)


def _truncate(name: str) -> Callable[[Path], None]:
    return lambda folder: (folder / name).write_bytes((folder / name).read_bytes()[:50])


def _config(edit: Callable[[dict], None]) -> Callable[[dict], None]:
    return lambda manifest: edit(manifest["config"])


DAMAGES = {
    "card-empty": (_write("design.json", b"{}"), r"design\.json: field 'coefficients'"),
    "card-truncated": (_truncate("design.json"), r"design\.json: not a valid design card"),
    "card-not-utf8": (_write("design.json", b"\xff\xfe{}"), r"design\.json: .*not UTF-8"),
    "card-nan": (
        _write("design.json", b'{"coefficients": [NaN, 0, 0], "free_energy": 1}'),
        r"design\.json: .*NaN",
    ),
    "card-degree": (
        _edit_json("design.json", lambda d: d.update(coefficients=[0.1, 0.2])),
        r"design\.json: field 'coefficients' must hold 3 numbers",
    ),
    "paths-empty": (_write("box_paths.json", b"{}"), r"box_paths\.json: field 'iterations'"),
    "paths-short": (
        _edit_json("box_paths.json", lambda d: d["iteration_bests"].pop()),
        r"box_paths\.json: field 'iteration_bests' must hold one path per iteration",
    ),
    "paths-point": (
        _edit_json("box_paths.json", lambda d: d["nominal"].append([1, "x"])),
        r"box_paths\.json: field 'nominal\[5\]' must be a point",
    ),
    "robustness-empty": (
        _write("robustness.json", b"{}"),
        r"robustness\.json: field 'robustness' must be a finite number, got nothing",
    ),
    "robustness-list": (
        _write("robustness.json", b"[]"),
        r"robustness\.json: not a valid robustness file: it must hold a JSON object, got list",
    ),
    "config-goal-int": (
        _edit_json("manifest.json", _config(lambda c: c.update(goal=5))),
        r"manifest\.json: field 'config\.goal' must be a list of 3 finite numbers",
    ),
    "config-goal-nan": (
        _edit_json("manifest.json", _config(lambda c: c.update(goal=[float("nan"), 1.5, 0.1]))),
        r"manifest\.json: field 'config\.goal'",
    ),
    "config-null": (
        _edit_json("manifest.json", lambda m: m.update(config=None)),
        r"manifest\.json: field 'config' must be a JSON object .*, got null",
    ),
    "config-bounds": (
        _edit_json("manifest.json", _config(lambda c: c.update(bounds=[[0, "a"]]))),
        r"manifest\.json: field 'config\.bounds'",
    ),
}


def _unrecord(folder: Path, *keys: str) -> None:
    """Remove files' checksums from the manifest, as in a folder written before they existed."""
    path = folder / "manifest.json"
    manifest = json.loads(path.read_text(encoding="utf-8"))
    for key in keys:
        del manifest["extra"]["file_sha256"][DESIGN_RUN_FILES[key]]
    path.write_text(json.dumps(manifest), encoding="utf-8")


@pytest.mark.slow
@pytest.mark.parametrize("key", ["card", "robustness", "box_paths"])
def test_an_edit_that_keeps_the_form_is_caught_by_the_recorded_checksum(
    design_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], key: str
) -> None:
    folder = tmp_path / "run"
    shutil.copytree(design_run, folder)
    path = folder / DESIGN_RUN_FILES[key]
    path.write_text(json.dumps(json.loads(path.read_text(encoding="utf-8"))) + " ")
    with pytest.raises(SystemExit) as caught:
        main(["report", str(folder)])
    assert caught.value.code == 2
    err = capsys.readouterr().err
    assert f"{DESIGN_RUN_FILES[key]} has changed since it was written" in err, err


def _snapshot(folder: Path) -> dict[Path, bytes]:
    return {p: p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.slow
def test_an_intact_design_run_is_reported(design_run: Path, tmp_path: Path) -> None:
    folder = tmp_path / "run"
    shutil.copytree(design_run, folder)
    assert main(["report", str(folder)]) == 0
    assert (folder / DESIGN_RUN_FILES["fig3"]).is_file()
    assert read_design_run(folder).spec.degree == 3


@pytest.mark.slow
@pytest.mark.parametrize(("damage", "message"), DAMAGES.values(), ids=DAMAGES.keys())
def test_a_damaged_design_run_is_refused_naming_the_file_and_field_before_any_write(
    design_run: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    damage: Callable[[Path], None],
    message: str,
) -> None:
    """Audit item 4: no KeyError traceback, no error without a file, no half-written report.

    The folder's manifest is made as a folder written before the card and the tests were
    checksummed (2026-11-26): their fields are what is checked then.
    """
    folder = tmp_path / "run"
    shutil.copytree(design_run, folder)
    _unrecord(folder, "card", "robustness", "box_paths")
    damage(folder)
    before = _snapshot(folder)
    with pytest.raises(ValueError, match=message):
        write_design_report(folder)
    capsys.readouterr()
    with pytest.raises(SystemExit) as caught:
        main(["report", str(folder)])
    assert caught.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("tooldesign report: error: ") and err.count("\n") == 1, err
    assert _snapshot(folder) == before  # not even the generic report/ was written


def test_the_card_stores_the_straight_tool_scored_on_the_run_task(design_run: Path) -> None:
    # report.html sets the design beside the straight tool (C = 0); the run stores its scores
    # (here the fake evaluator's F = |C|^2 - 1 = -1).
    card = json.loads((design_run / DESIGN_RUN_FILES["card"]).read_text(encoding="utf-8"))
    straight = card["straight_tool"]
    assert straight["coefficients"] == [0.0, 0.0, 0.0] and straight["status"] == "ok"
    assert straight["free_energy"] == -1.0 and straight["final_distance"] == 0.5


@pytest.mark.slow
def test_no_phase_after_the_progress_bar_is_silent(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # Issue 34: after the bar reached 100 %, a run printed nothing for up to a minute.
    monkeypatch.setattr(design_loop, "evaluate_batch", _fake_rows)
    monkeypatch.setattr(design_loop, "map_robust", _fake_robustness)
    out = tmp_path / "run"
    argv = ["design", "--optimizer", "random", "--iterations", "1", "--batch-size", "2"]
    assert main([*argv, "--executor", "serial", "--no-video", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    for phase in (
        "design random: meshes, box paths and robustness test of the final tool ... done (",
        "design random: drawing Figure 3, robustness.png and report.html ... done (",
    ):
        assert phase in err, err
    assert err.index("meshes, box paths") < err.index("drawing Figure 3")
    assert (
        main(
            [
                *argv,
                "--executor",
                "serial",
                "--no-video",
                "--no-progress",
                "--out",
                str(tmp_path / "quiet"),
            ]
        )
        == 0
    )
    assert "... done" not in capsys.readouterr().err


def test_a_phase_that_fails_says_stopped() -> None:
    import io

    from benchmarks.design.progress import phase

    stream = io.StringIO()
    with pytest.raises(KeyError), phase("design x: work", stream=stream):
        raise KeyError("boom")
    assert stream.getvalue() == "design x: work ... stopped\n"
    with phase("silent", enabled=False, stream=stream):
        pass
    assert "silent" not in stream.getvalue()
