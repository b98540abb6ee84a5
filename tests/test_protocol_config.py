"""The protocol's instances, sizes, references file and entry points: form and bad input."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from benchmarks.protocol import (
    DEGREES,
    PROTOCOL_SIZES,
    ProtocolConfig,
    ReferencePlan,
    bounds_of,
    buildable_fraction,
    compute_references,
    export_ioh,
    load_instances,
    load_references,
    make_protocol_report,
    packaged_references,
    protocol_config,
    run_protocol,
    select_instances,
)
from benchmarks.protocol.instances import draw_instances, instances_json
from benchmarks.protocol.suite import PROTOCOL_FILE

ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def test_committed_instance_set_is_the_drawn_one_and_split_24_16_8():
    instances = load_instances()
    assert len(instances) >= 24
    assert instances == draw_instances()  # drawn once with the fixed seed, committed
    sets = [i.set for i in instances]
    assert sets.count("public") == 16 and sets.count("held-out") == 8
    for i in instances:
        assert -0.5 <= i.goal[0] <= 0.5 and 0.5 <= i.goal[1] <= 1.5 and i.goal[2] == 0.1
        assert 0.1 <= i.box_mass <= 0.9 and 0.3 <= i.box_friction <= 0.5


def test_instance_file_round_trips(tmp_path):
    path = tmp_path / "instances.json"
    path.write_text(instances_json(draw_instances(n=4)))
    assert load_instances(path=path) == draw_instances(n=4)


def test_sizes_and_budgets():
    full = protocol_config("full")
    assert full.degrees == DEGREES == (3, 5, 8)
    assert [full.budget(d) for d in full.degrees] == [120, 200, 320]
    assert len(full.instances) == 24 and full.n_seeds == 3
    # 24 instances x 3 seeds x 4 optimizers x (120 + 200 + 320)
    assert full.evaluations() == 24 * 3 * 4 * 640
    quick = protocol_config("quick")
    assert quick.evaluations() == 6 * 2 * 4 * (32 + 56 + 80)
    smoke = protocol_config("smoke")
    assert smoke.evaluations() == 80


def test_every_optimizer_gets_the_same_seeds_and_a_users_run_gets_the_builtins():
    full = protocol_config("full")
    mine = protocol_config("full", optimizer="mypkg.mod:MyOpt")
    assert [o.name for o in mine.optimizers] == ["mypkg.mod:MyOpt"]
    for instance, degree in full.cells()[:5]:
        assert (
            full.cell_suite(instance, degree).seeds() == mine.cell_suite(instance, degree).seeds()
        )
    seeds = {full.cell_seed(i, d) for i, d in full.cells()}
    assert len(seeds) == len(full.cells())  # cells are independent streams


def test_bounds_keep_the_linear_coefficient_narrow():
    assert bounds_of(5) == ((-1.5, 1.5),) * 4 + ((-0.5, 0.5),)


def test_smoke_references_are_committed_and_cover_the_smoke_cells():
    path = packaged_references("smoke")
    assert path is not None
    refs = load_references(path)
    smoke = protocol_config("smoke")
    for instance, degree in smoke.cells():
        cell = refs[(instance.id, degree)]
        assert len(cell["random_pool"]) >= smoke.budget(degree)
        assert cell["noise_floor"] > 0
        assert cell["f_ref"] <= min(cell["random_pool"]) and cell["f_ref"] <= cell["f_straight"]


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: protocol_config("medium"), "unknown size 'medium'"),
        (lambda: protocol_config("quick").replace(instances=("i99",)), "unknown instance ids"),
        (lambda: protocol_config("quick").replace(degrees=(3, 3)), "distinct"),
        (lambda: protocol_config("quick").replace(instances=("i01", "i01")), "distinct"),
        (lambda: protocol_config("quick").replace(degrees=(0,)), "degree must be an int"),
        (lambda: protocol_config("quick").replace(n_seeds=0), "n_seeds must be an int >= 1"),
        (lambda: protocol_config("quick").replace(optimizers=()), "at least one optimizer"),
        (lambda: ProtocolConfig(size="quick", instances=("i01",), batch_size=True), "batch_size"),
        (lambda: load_instances(7), "no committed instance set of version 7"),
        (lambda: draw_instances(n=1), "n must be an int >= 2"),
        (lambda: select_instances(load_instances(), sets=("private",)), "unknown instance sets"),
        (lambda: select_instances(load_instances(), ids=["x"]), "unknown instance ids"),
        (lambda: bounds_of(2.5), "degree must be an int"),
        (lambda: buildable_fraction(3, 0), "n must be an int"),
        (lambda: export_ioh(pd.DataFrame({"optimizer": ["a"]}), "x"), "lacks columns"),
        (lambda: make_protocol_report([]), "at least one protocol run folder"),
        (lambda: ReferencePlan(nudges=1), "nudges must be an int >= 2"),
        (lambda: ReferencePlan(grid_points=1), "grid_points must be 0"),
        (
            lambda: compute_references(protocol_config("smoke"), "refs.txt"),
            "must end in .json",
        ),
    ],
)
def test_bad_input_is_refused_with_a_message(call, match):
    with pytest.raises((ValueError, TypeError), match=match):
        call()


def test_references_file_errors(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        load_references(tmp_path / "none.json")
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"format": "something else", "cells": []}))
    with pytest.raises(ValueError, match="not a protocol references file"):
        load_references(bad)
    nan = tmp_path / "nan.json"
    cell = {"instance": "i01", "degree": 3, "f_ref": "nan", "noise_floor": 1, "f_straight": 1}
    header = {"format": "tooldesign-protocol-references", "version": 1}
    nan.write_text(json.dumps({**header, "cells": [cell]}))
    with pytest.raises(ValueError, match="f_ref of i01 d=3 not finite"):
        load_references(nan)
    old = tmp_path / "old.json"
    old.write_text(json.dumps({"format": "tooldesign-protocol-references", "version": 0}))
    with pytest.raises(ValueError, match="version is 0, not 1"):
        load_references(old)


def test_run_protocol_refuses_other_folders(tmp_path):
    (tmp_path / "other.txt").write_text("mine")
    with pytest.raises(ValueError, match="not empty and is not a protocol run folder"):
        run_protocol(protocol_config("smoke"), tmp_path, progress=False)
    with pytest.raises(TypeError, match="must be a ProtocolConfig"):
        run_protocol("smoke", tmp_path / "new")  # type: ignore[arg-type]
    folder = tmp_path / "run"
    folder.mkdir()
    record = {"format": 1, "config": protocol_config("quick").to_json()}
    (folder / PROTOCOL_FILE).write_text(json.dumps(record))
    with pytest.raises(ValueError, match="another configuration"):
        run_protocol(protocol_config("smoke"), folder, progress=False)
    with pytest.raises(ValueError, match="has no results"):
        make_protocol_report([folder])
    with pytest.raises(ValueError, match="not a protocol run folder"):
        make_protocol_report([tmp_path / "nothing"])


_MAIN = "import sys; from benchmarks.cli import main; sys.exit(main(sys.argv[1:]))"


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", _MAIN, *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["bench", "protocol", "--size", "huge", "--out", "x"], "unknown size 'huge'"),
        (["bench", "protocol", "--seeds", "2", "--out", "x"], "--seeds: for the rl suite only"),
        (["bench", "optimizers", "--baseline", "y", "--out", "x"], "--baseline: for the protocol"),
        (["bench", "rl", "--optimizer", "cmaes", "--out", "x"], "--optimizer: for the protocol"),
        (["bench", "protocol", "--buildable", "0", "--out", "x"], "--buildable must be an int"),
        (["bench", "protocol", "--scene", "box_yaw=0.1", "--out", "x"], "--scene is not"),
        (
            ["bench", "protocol", "--references", "--optimizer", "cmaes", "--out", "x.json"],
            "--references computes references only",
        ),
    ],
)
def test_cli_bad_input_is_one_line(args, match, tmp_path):
    done = _cli(*args)
    assert done.returncode == 2, done.stderr
    assert match in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
    assert not (ROOT / "x").exists()


def test_buildable_fraction_of_a_few_designs_without_the_scene():
    counted = buildable_fraction(5, 20, seed=3, check_box=False)
    assert counted.n == 20 and 0 <= counted.buildable <= 20 and counted.usable is None
    assert "d = 5" in counted.text()
    assert np.isfinite(counted.buildable / counted.n)


def test_the_command_lines_constants_agree_with_the_protocols():
    from benchmarks.cli import _common
    from benchmarks.protocol import PROTOCOL_SUITE_NAME

    assert _common.PROTOCOL_SUITE_NAME == PROTOCOL_SUITE_NAME
    assert _common.PROTOCOL_SIZES == PROTOCOL_SIZES


@pytest.mark.slow
def test_buildable_fraction_builds_the_scene_and_counts_usable_tools():
    # build() returns a BuildResult with no truth value: the count must read .usable.
    counted = buildable_fraction(3, 3, seed=0, check_box=True)
    assert counted.usable is not None and 0 <= counted.usable <= counted.buildable <= 3
    assert "usable" in counted.text()


@pytest.mark.slow
def test_cli_buildable_prints_every_degree():
    done = _cli("bench", "protocol", "--buildable", "2")  # --out: refused, it writes nothing
    assert done.returncode == 0, done.stderr
    assert [line.split(":")[0] for line in done.stdout.splitlines()] == ["d = 3", "d = 5", "d = 8"]
    assert "usable" in done.stdout
