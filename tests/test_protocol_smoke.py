"""The protocol end to end at size smoke: run, IOHprofiler round trip, a user's run merged."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from benchmarks.protocol import (
    export_ioh,
    load_runs,
    make_protocol_report,
    run_protocol,
)

ROOT = Path(__file__).resolve().parents[1]
PLUGIN = ROOT / "tests" / "fixtures" / "external_plugin"

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def smoke_run(protocol_smoke):
    return protocol_smoke  # run once per session (conftest.py), shared with test_protocol_claims


def test_smoke_run_has_every_cell_and_resumes_without_work(smoke_run):
    config, runs = load_runs(smoke_run)
    assert config.size == "smoke"
    counts = runs.groupby(["degree", "instance", "optimizer"]).size()
    assert len(counts) == 2 * 2 * 2
    assert counts.xs(3, level="degree").eq(8).all() and counts.xs(5, level="degree").eq(12).all()
    # A rerun finds every run done and changes no result.
    run_protocol(config.replace(executor="serial"), smoke_run, progress=False)
    _, again = load_runs(smoke_run)
    pd.testing.assert_frame_equal(runs, again)


def test_smoke_report_has_the_tables_and_figures(smoke_run, tmp_path):
    files = make_protocol_report([smoke_run], tmp_path / "report")
    names = {f.name for f in files}
    assert {"report.md", "runs.csv", "runtimes.csv", "references.csv", "ecdf_pooled.png"} <= names
    runs = pd.read_csv(tmp_path / "report" / "runs.csv")
    assert runs["score"].between(0, 1).all()
    times = pd.read_csv(tmp_path / "report" / "runtimes.csv")
    # A finite runtime lies within the budget; censored ones are inf.
    finite = times[np.isfinite(times["runtime"])]
    assert (finite["runtime"] <= finite["budget"]).all() and (finite["runtime"] >= 1).all()
    text = (tmp_path / "report" / "report.md").read_text()
    for heading in ("Area under the ECDF", "Expected running time", "Power", "Ranking", "F_ref"):
        assert heading in text


def test_ioh_export_is_read_back_by_iohinspector(smoke_run, tmp_path):
    iohinspector = pytest.importorskip("iohinspector")
    _, runs = load_runs(smoke_run)
    export_ioh(runs, tmp_path / "ioh")
    manager = iohinspector.DataManager()
    manager.add_folder(str(tmp_path / "ioh"))
    overview = manager.overview.to_pandas()
    assert len(overview) == runs.groupby(["optimizer", "degree", "instance", "seed"]).ngroups
    data = manager.load(True, True).to_pandas()
    for (optimizer, degree, number), run in runs.groupby(
        ["optimizer", "degree", "instance_number"]
    ):
        row = overview[
            (overview["algorithm_name"] == optimizer)
            & (overview["dimension"] == degree)
            & (overview["instance"] == number)
        ]
        assert len(row) == 1
        assert int(row["evals"].iloc[0]) == len(run)
        assert float(row["best_y"].iloc[0]) == run["free_energy"].min()  # bit for bit
        logged = data[data["data_id"] == row["data_id"].iloc[0]].sort_values("evaluations")
        f = run.sort_values("evaluation")["free_energy"].to_numpy()
        best = np.minimum.accumulate(f)
        at = logged["evaluations"].to_numpy(dtype=int) - 1
        assert logged["raw_y"].tolist() == f[at].tolist()  # each logged evaluation's own F
        # Every improvement is logged: the best so far read back equals the run's everywhere.
        assert np.minimum.accumulate(logged["raw_y"].to_numpy()).tolist() == best[at].tolist()
        assert set(np.flatnonzero(np.diff(best, prepend=np.inf) < 0)) <= set(at.tolist())


def test_a_users_plugin_runs_alone_and_is_reported_beside_the_builtins(smoke_run, tmp_path):
    out = tmp_path / "mine"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(PLUGIN), str(ROOT)])}
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "benchmarks",
            "protocol",
            "--size",
            "smoke",
            "--optimizer",
            "tooldesign_hillclimb:HillClimb",
            "--baseline",
            str(smoke_run),
            "--executor",
            "serial",
            "--no-progress",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env=env,
    )
    assert done.returncode == 0, done.stderr
    runs = pd.read_csv(out / "report" / "runs.csv")
    assert set(runs["optimizer"]) == {"tooldesign_hillclimb:HillClimb", "cmaes", "random"}
    # Only the user's optimizer ran in its folder.
    _, mine = load_runs(out)
    assert set(mine["optimizer"]) == {"tooldesign_hillclimb:HillClimb"}
    assert (out / "ioh" / "tooldesign_hillclimb%3AHillClimb").is_dir()
    # The built-ins' folder cannot be reported twice beside itself.
    with pytest.raises(ValueError, match="is in both"):
        make_protocol_report([smoke_run, smoke_run], tmp_path / "twice")


def test_an_unfinished_folder_is_not_reported(smoke_run, tmp_path):
    import json
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(smoke_run, copy)
    record = json.loads((copy / "protocol.json").read_text())
    record["config"]["n_seeds"] = 2  # as if the second seed's runs had not been made yet
    (copy / "protocol.json").write_text(json.dumps(record))
    with pytest.raises(ValueError, match="unfinished .2 of 4 runs started, 16 of 32 evaluations"):
        load_runs(copy)


def test_the_export_equals_what_the_ioh_packages_own_logger_writes(smoke_run, tmp_path):
    """The same runs replayed through ``ioh``'s Analyzer: the same runs, evaluations and values."""
    ioh = pytest.importorskip("ioh")
    import json

    _, runs = load_runs(smoke_run)
    runs = runs[runs["optimizer"] == "cmaes"]
    export_ioh(runs, tmp_path / "ours")
    values: list[float] = []
    ioh.wrap_problem(
        lambda x: values.pop(0),
        name="push",
        optimization_type=ioh.OptimizationType.MIN,
        lb=-1.5,
        ub=1.5,
    )
    logger = ioh.logger.Analyzer(
        root=str(tmp_path), folder_name="theirs", algorithm_name="cmaes", store_positions=False
    )
    for (degree, number, _seed), run in runs.groupby(["degree", "instance_number", "seed"]):
        problem = ioh.get_problem("push", instance=int(number), dimension=int(degree))
        problem.attach_logger(logger)
        for _, row in run.sort_values("evaluation").iterrows():
            values.append(float(row["free_energy"]))
            problem(row[[f"c{k}" for k in range(1, int(degree) + 1)]].to_numpy(dtype=float))
        problem.reset()
    logger.close()
    (theirs,) = (tmp_path / "theirs").glob("IOHprofiler_f*_push.json")
    ours = tmp_path / "ours" / "cmaes" / "IOHprofiler_f1_push.json"
    meta_theirs, meta_ours = json.loads(theirs.read_text()), json.loads(ours.read_text())
    assert meta_ours["attributes"] == meta_theirs["attributes"]
    assert meta_ours["maximization"] == meta_theirs["maximization"]
    for a, b in zip(meta_ours["scenarios"], meta_theirs["scenarios"], strict=True):
        assert a["dimension"] == b["dimension"]
        assert [(r["instance"], r["evals"]) for r in a["runs"]] == [
            (r["instance"], r["evals"]) for r in b["runs"]
        ]
        assert [r["best"]["y"] for r in a["runs"]] == pytest.approx(
            [r["best"]["y"] for r in b["runs"]], rel=1e-9
        )
        mine = (ours.parent / a["path"]).read_text().split()
        other = (theirs.parent / b["path"]).read_text().split()
        assert len(mine) == len(other)
        for x, y in zip(mine, other, strict=True):
            if x in ("evaluations", "raw_y"):
                assert x == y
            else:
                assert float(x) == pytest.approx(float(y), rel=1e-9)


def _tiny_plan(size):
    from benchmarks.protocol.references import ReferencePlan

    return ReferencePlan(
        grid_points=2, restarts=1, restart_evaluations_per_degree=1, pool_per_degree=3, nudges=2
    )


def test_with_references_computes_them_into_the_folder_and_reports(
    smoke_run, tmp_path, monkeypatch
):
    """The whole benchmark in one command when a size has no committed references."""
    import json
    import shutil

    from benchmarks.cli import main
    from benchmarks.protocol import references, report

    copy = tmp_path / "run"
    shutil.copytree(smoke_run, copy)
    monkeypatch.setattr(report, "packaged_references", lambda size: None)
    monkeypatch.setattr(references, "reference_plan", _tiny_plan)
    args = ["bench", "protocol", "--size", "smoke", "--executor", "serial", "--no-progress"]
    assert main([*args, "--out", str(copy)]) == 0  # no references: the report is skipped
    assert not (copy / "report" / "report.md").exists()
    assert main([*args, "--with-references", "--out", str(copy)]) == 0
    data = json.loads((copy / "references.json").read_text())
    assert {(c["instance"], c["degree"]) for c in data["cells"]} == {
        (i, d) for i in ("i01", "i02") for d in (3, 5)
    }
    for cell in data["cells"]:
        pool = cell["random_pool"]
        assert len(pool) == max(3 * cell["degree"], 8 if cell["degree"] == 3 else 12)
        assert cell["f_ref"] <= min(pool) and cell["noise_floor"] > 0
    assert not (copy / "references.json.cells").exists()
    from benchmarks.storage import platform_id

    assert data["platform"] == platform_id()  # where they reproduce to the bit
    assert "references.json" in (copy / "report" / "report.md").read_text()
    # A rerun computes nothing again: the file's cells are kept.
    before = (copy / "references.json").read_bytes()
    references.compute_references(
        references.ProtocolConfig.from_json(
            json.loads((copy / "protocol.json").read_text())["config"]
        ).replace(executor="serial"),
        copy / "references.json",
    )
    assert (copy / "references.json").read_bytes() == before
    # The folder records the file's SHA-256; a resumed run keeps it; a swapped file is refused.
    recorded = json.loads((copy / "protocol.json").read_text())["references_sha256"]
    assert recorded == __import__("hashlib").sha256(before).hexdigest()
    assert main([*args, "--out", str(copy)]) == 0
    assert json.loads((copy / "protocol.json").read_text())["references_sha256"] == recorded
    swapped = json.loads(before)
    swapped["cells"][0]["f_ref"] -= 1000.0
    (copy / "references.json").write_text(json.dumps(swapped, indent=1) + "\n")
    with pytest.raises(ValueError, match="not the references this run folder recorded"):
        report.make_protocol_report([copy], tmp_path / "swapped")
    with pytest.raises(SystemExit) as refused:  # the command refuses it too (exit 2)
        main([*args, "--out", str(copy)])
    assert refused.value.code == 2


def test_a_report_says_when_a_section_cannot_separate_any_pair(smoke_run, tmp_path):
    make_protocol_report([smoke_run], tmp_path / "report")
    text = (tmp_path / "report" / "report.md").read_text()
    # Two instances, one pair: the exact test's smallest p is 2 / 2^2 = 0.5.
    assert text.count("This section cannot separate any pair") == 3  # d = 3, d = 5, pooled
    power = pd.read_csv(tmp_path / "report" / "power.csv")
    assert np.isinf(power["detectable"]).all() and (~power["separable"]).all()
    # The AUC table's interval is a t interval (a percentile bootstrap covers too little with
    # few instances); d_z's bootstrap interval is another matter.
    heading = next(line for line in text.splitlines() if line.startswith("## Area under the ECDF"))
    assert "Student t interval" in heading and "bootstrap" not in heading
