"""Tests of benchmarks.storage: atomic parts, resume after a kill, exact round-trips, manifest."""

from __future__ import annotations

import dataclasses
import datetime as dt
import json
import os
import shutil
import subprocess
import sys
import tempfile
import zlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from benchmarks.storage import (
    EmptyStoreError,
    ResultStore,
    Unit,
    atomic_write_bytes,
    atomic_write_text,
    build_manifest,
    git_commit,
    git_dirty,
    package_versions,
    read_designs,
    read_manifest,
    read_retests,
    resolve_format,
    timing_totals,
    validate_evaluations,
    write_manifest,
)
from benchmarks.storage import table as storage_table

OPTIMIZERS = ("cmaes", "random")
SEEDS = (0, 1)
ITERATIONS = 4
BATCH = 3


def make_batch(
    optimizer: str,
    seed: int,
    iteration: int,
    *,
    suite: str = "optimizers",
    variant: str | None = None,
    n: int = BATCH,
    n_coefficients: int = 3,
) -> pd.DataFrame:
    """A deterministic synthetic batch; every third evaluation of odd iterations fails."""
    rng = np.random.default_rng([seed, iteration, zlib.crc32(optimizer.encode())])
    status = np.array(["ok"] * n, dtype=object)
    if iteration % 2 == 1:
        status[::3] = "failed"
    energy = 10.0 / (1 + iteration) + rng.standard_normal(n)
    energy[status != "ok"] = np.nan
    rows = {
        "suite": suite,
        "optimizer": optimizer,
        "seed": seed,
        "iteration": iteration,
        "candidate": np.arange(n),
        "eval_id": iteration * n + np.arange(n),
    }
    for i in range(1, n_coefficients + 1):
        rows[f"c{i}"] = rng.uniform(-1, 1, n)
    rows.update(
        free_energy=energy,
        goal_error=rng.random(n),
        confidence=rng.standard_normal(n),
        final_distance=rng.random(n),
        status=status,
        eval_time=rng.random(n),
        opt_time=np.full(n, 0.01),
        goal_x=0.0,
        goal_y=1.5,
        goal_z=0.1,
        goal_precision=20.0,
        box_mass=0.1,
    )
    if variant is not None:
        rows["variant"] = variant
    return pd.DataFrame(rows)


def planned_units() -> list[Unit]:
    return [
        Unit(suite="optimizers", optimizer=o, seed=s, iteration=i)
        for o in OPTIMIZERS
        for s in SEEDS
        for i in range(ITERATIONS)
    ]


def batch_of(unit: Unit) -> pd.DataFrame:
    return make_batch(unit.optimizer, unit.seed, unit.iteration, suite=unit.suite)


def write_all(store: ResultStore) -> None:
    for unit in planned_units():
        store.write_batch(batch_of(unit))


# --- writing and reading ---------------------------------------------------------------------


def test_read_returns_sorted_rows_with_hand_computed_best_so_far(tmp_path: Path) -> None:
    store = ResultStore(tmp_path / "run")
    # Write out of order: read() must sort.
    for unit in reversed(planned_units()):
        assert store.write_batch(batch_of(unit)) == unit
    df = store.read()

    assert len(df) == len(planned_units()) * BATCH
    keys = list(df[["optimizer", "seed", "iteration", "candidate"]].itertuples(index=False))
    assert keys == sorted(keys)
    for (_, _), run in df.groupby(["optimizer", "seed"]):
        best, expected = np.nan, []
        for value, status in zip(run["free_energy"], run["status"], strict=True):
            if status == "ok" and np.isfinite(value) and not value >= best:
                best = value
            expected.append(best)
        np.testing.assert_array_equal(run["best_so_far"].to_numpy(), expected)
    assert df["variant"].eq("").all()
    assert str(df["seed"].dtype) == "int64" and df["c1"].dtype == np.float64


def test_best_so_far_skips_failed_and_non_finite_values(tmp_path: Path) -> None:
    batch = make_batch("cmaes", 0, 0, n=5)
    batch["free_energy"] = [5.0, np.nan, 3.0, np.inf, 4.0]
    batch["status"] = ["ok", "failed", "invalid", "ok", "ok"]
    batch.loc[2, "free_energy"] = 3.0  # finite but invalid: does not count
    store = ResultStore(tmp_path)
    store.write_batch(batch)
    np.testing.assert_array_equal(store.read()["best_so_far"], [5.0, 5.0, 5.0, 5.0, 4.0])


def test_given_best_so_far_is_recomputed_not_trusted(tmp_path: Path) -> None:
    batch = make_batch("cmaes", 0, 0)
    batch["best_so_far"] = -1e9
    store = ResultStore(tmp_path)
    store.write_batch(batch)
    assert (store.read()["best_so_far"] > -1e9).all()


def test_same_rows_give_same_part_bytes(tmp_path: Path) -> None:
    a, b = ResultStore(tmp_path / "a"), ResultStore(tmp_path / "b")
    unit = a.write_batch(make_batch("cmaes", 3, 2))
    b.write_batch(make_batch("cmaes", 3, 2))
    assert a.part_path(unit).read_bytes() == b.part_path(unit).read_bytes()


def test_rewriting_a_stored_unit_needs_overwrite(tmp_path: Path) -> None:
    store = ResultStore(tmp_path)
    store.write_batch(make_batch("cmaes", 0, 0))
    with pytest.raises(FileExistsError, match="already stored"):
        store.write_batch(make_batch("cmaes", 0, 0))
    changed = make_batch("cmaes", 0, 0).assign(goal_error=7.0)
    store.write_batch(changed, overwrite=True)
    assert (store.read()["goal_error"] == 7.0).all()


def test_odd_names_round_trip_through_part_paths(tmp_path: Path) -> None:
    store = ResultStore(tmp_path)
    names = [("a/b c", "p=20% ü", "x:y"), ("..", "", "NA"), ("nan", "..", "%2F")]
    for suite, variant, optimizer in names:
        store.write_batch(make_batch(optimizer, 1, 0, suite=suite, variant=variant))
    expected = {Unit(suite=s, variant=v, optimizer=o, seed=1, iteration=0) for s, v, o in names}
    assert store.completed_units() == expected
    df = store.read()
    got = set(df[["suite", "variant", "optimizer"]].itertuples(index=False, name=None))
    assert got == set(names)
    assert all(p.is_relative_to(store.parts_dir) for p in map(store.part_path, expected))


def test_suites_with_different_coefficient_counts_share_a_store(tmp_path: Path) -> None:
    store = ResultStore(tmp_path)
    store.write_batch(make_batch("cmaes", 0, 0, suite="cubic", n_coefficients=3))
    store.write_batch(make_batch("cmaes", 0, 0, suite="quintic", n_coefficients=5))
    df = store.read()
    assert [c for c in df.columns if c.startswith("c") and c[1:].isdigit()] == [
        "c1",
        "c2",
        "c3",
        "c4",
        "c5",
    ]
    assert df.loc[df["suite"] == "cubic", "c5"].isna().all()
    assert df.loc[df["suite"] == "quintic", "c5"].notna().all()


# --- interruption and resume -------------------------------------------------------------------


@pytest.mark.slow
def test_resume_after_kill_skips_done_units_and_equals_uninterrupted_run(tmp_path: Path) -> None:
    uninterrupted = ResultStore(tmp_path / "full")
    write_all(uninterrupted)

    interrupted = ResultStore(tmp_path / "killed")
    plan = planned_units()
    for unit in plan[:5]:
        interrupted.write_batch(batch_of(unit))
    # The kill hits while unit 5 is being written: its temporary file is left half-written
    # and its part never appears.
    killed = interrupted.part_path(plan[5])
    leftover = killed.with_name(f".{killed.name}.4242.deadbeef.tmp")
    leftover.parent.mkdir(parents=True, exist_ok=True)
    leftover.write_bytes(batch_of(plan[5]).to_csv(index=False).encode()[:50])
    # Another worker had finished a later unit of a different run.
    interrupted.write_batch(batch_of(plan[9]))

    done = interrupted.completed_units()
    assert done == {*plan[:5], plan[9]}
    pending = interrupted.pending_units(plan)
    assert pending == [u for i, u in enumerate(plan) if i >= 5 and i != 9]
    assert interrupted.stale_temp_files() == [leftover]

    for unit in pending:
        interrupted.write_batch(batch_of(unit))
    assert interrupted.pending_units(plan) == []

    pd.testing.assert_frame_equal(interrupted.read(), uninterrupted.read(), check_exact=True)
    a = uninterrupted.consolidate(format="csv")
    b = interrupted.consolidate(format="csv")
    assert a.read_bytes() == b.read_bytes()
    assert interrupted.remove_stale_temp_files() == [leftover]
    assert not leftover.exists()


def test_partial_temp_file_alone_does_not_count_as_done(tmp_path: Path) -> None:
    store = ResultStore(tmp_path)
    unit = Unit(suite="s", optimizer="cmaes", seed=0, iteration=0)
    path = store.part_path(unit)
    path.parent.mkdir(parents=True)
    path.with_name(f".{path.name}.1.00000000.tmp").write_text("suite,optim")
    assert store.completed_units() == frozenset()
    assert not store.is_complete(unit)
    with pytest.raises(EmptyStoreError, match="no results"):
        store.read()


def test_atomic_write_keeps_old_file_when_replace_fails(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    target = tmp_path / "sub" / "file.txt"
    atomic_write_text(target, "old\n")

    def fail(*args: object) -> None:
        raise OSError("disk gone")

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(OSError, match="disk gone"):
        atomic_write_text(target, "new\n")
    assert target.read_text() == "old\n"
    assert sorted(p.name for p in target.parent.iterdir()) == ["file.txt"]


def test_atomic_write_bytes_is_exact_and_rejects_text(tmp_path: Path) -> None:
    data = b"a\r\nb\n\x00"
    assert atomic_write_bytes(tmp_path / "x.bin", data).read_bytes() == data
    assert atomic_write_text(tmp_path / "y.txt", "a\nb").read_bytes() == b"a\nb"
    with pytest.raises(TypeError, match="data must be bytes"):
        atomic_write_bytes(tmp_path / "z", "text")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="text must be str"):
        atomic_write_text(tmp_path / "z", b"bytes")  # type: ignore[arg-type]


# --- formats and exact round trips ---------------------------------------------------------------

EXTREME = np.array(
    [0.1, 1 / 3, -0.0, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308, -1e-300, np.pi]
)


def extreme_batch() -> pd.DataFrame:
    batch = make_batch("cmaes", 0, 0, suite="extreme", n=EXTREME.size)
    batch["status"] = "ok"
    for column in ("c1", "free_energy", "goal_error", "confidence", "eval_time"):
        batch[column] = np.abs(EXTREME) if column == "eval_time" else EXTREME
    batch["c2"] = np.roll(EXTREME, 3)
    batch.loc[2, "goal_error"] = np.nan
    batch.loc[3, "confidence"] = -np.inf
    return batch


def assert_bits_equal(a: pd.DataFrame, b: pd.DataFrame) -> None:
    pd.testing.assert_frame_equal(a, b, check_exact=True)
    for column in a.columns:
        if a[column].dtype == np.float64:
            x, y = a[column].to_numpy(), b[column].to_numpy()
            assert np.array_equal(np.isnan(x), np.isnan(y)), column
            keep = ~np.isnan(x)
            assert np.array_equal(x[keep].view(np.int64), y[keep].view(np.int64)), column


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_consolidated_file_round_trips_bit_identical_floats(tmp_path: Path, fmt: str) -> None:
    if fmt == "parquet":
        pytest.importorskip("pyarrow")
    store = ResultStore(tmp_path / "run")
    store.write_batch(extreme_batch())
    write_all(store)
    original = store.read()
    path = store.consolidate(format=fmt)
    assert path.name == f"evaluations.{fmt}"

    shared = tmp_path / "shared"  # a run folder handed on without its parts
    shared.mkdir()
    shutil.copy(path, shared / path.name)
    reread = ResultStore(shared).read()
    assert_bits_equal(reread, original)


@pytest.mark.slow
@settings(max_examples=40, deadline=None)
@given(
    st.lists(
        st.floats(allow_nan=False, allow_infinity=True, width=64),
        min_size=1,
        max_size=6,
    )
)
def test_any_double_survives_a_part_file(values: list[float]) -> None:
    batch = make_batch("pso", 0, 0, n=len(values))
    batch["status"] = "ok"
    batch["free_energy"] = values
    batch["c2"] = values
    with tempfile.TemporaryDirectory() as folder:
        store = ResultStore(folder)
        store.write_batch(batch)
        df = store.read()
    for column in ("free_energy", "c2"):
        expected = np.asarray(values, dtype=np.float64).view(np.int64)
        assert np.array_equal(df[column].to_numpy().view(np.int64), expected)


def test_format_rule_prefers_parquet_only_when_pyarrow_imports(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setattr(storage_table, "_pyarrow_available", lambda: False)
    assert resolve_format("auto") == "csv"
    assert resolve_format("csv") == "csv"
    with pytest.raises(ImportError, match=r"tooldesign\[parquet\]"):
        resolve_format("parquet")
    store = ResultStore(tmp_path)
    store.write_batch(make_batch("cmaes", 0, 0))
    assert store.consolidate().name == "evaluations.csv"

    monkeypatch.setattr(storage_table, "_pyarrow_available", lambda: True)
    assert resolve_format("auto") == "parquet"
    with pytest.raises(ValueError, match="format must be"):
        resolve_format("feather")


def test_consolidating_in_one_format_removes_the_other(tmp_path: Path) -> None:
    pytest.importorskip("pyarrow")
    store = ResultStore(tmp_path)
    store.write_batch(make_batch("cmaes", 0, 0))
    store.consolidate(format="csv")
    store.consolidate(format="parquet")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["evaluations.parquet", "parts"]


# --- bad input -----------------------------------------------------------------------------------


def test_reading_a_missing_folder_names_it(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="nowhere"):
        ResultStore(tmp_path / "nowhere").read()
    (tmp_path / "file").write_text("x")
    with pytest.raises(NotADirectoryError, match="not a folder"):
        ResultStore(tmp_path / "file").read()
    with pytest.raises(TypeError, match="run_folder must be a path"):
        ResultStore(3)  # type: ignore[arg-type]


@pytest.mark.parametrize("reader", [read_designs, read_retests])
def test_design_and_retest_readers_refuse_a_missing_folder_not_read_it_as_empty(
    reader, tmp_path: Path
) -> None:
    # A mistyped run folder used to read as a suite with no finished run ([]).
    with pytest.raises(FileNotFoundError, match=r"run folder .*nowhere does not exist"):
        reader(tmp_path / "nowhere")
    (tmp_path / "file").write_text("x")
    with pytest.raises(NotADirectoryError, match=r"run folder .*file is not a folder"):
        reader(tmp_path / "file")
    with pytest.raises(TypeError, match="run_folder must be a path, got int"):
        reader(3)
    # An existing folder where no run has finished (no designs/, no retest/) has none.
    assert reader(tmp_path) == []


def test_reading_an_empty_store_says_so(tmp_path: Path) -> None:
    with pytest.raises(EmptyStoreError, match=r"holds no results.*parts/"):
        ResultStore(tmp_path).read()
    assert issubclass(EmptyStoreError, ValueError)


@pytest.mark.parametrize(
    ("change", "error", "message"),
    [
        (lambda b: b.assign(free_energy=["x"] * len(b)), TypeError, "'free_energy' must hold"),
        (lambda b: b.assign(seed=0.5), TypeError, "'seed' must hold integers"),
        (lambda b: b.assign(seed=True), TypeError, "'seed' must hold integers"),
        (lambda b: b.assign(optimizer=1), TypeError, "'optimizer' must hold strings"),
        (lambda b: b.assign(extra=["a"] * len(b)), TypeError, "'extra' extra columns"),
        (lambda b: b.drop(columns="box_mass"), ValueError, r"missing columns \['box_mass'\]"),
        (lambda b: b.drop(columns="c2"), ValueError, "c1..cn"),
        (lambda b: b.assign(status="done"), ValueError, "'status' holds"),
        (lambda b: b.assign(seed=-1), ValueError, "'seed' must be >= 0"),
        (lambda b: b.assign(eval_time=-1.0), ValueError, "'eval_time'"),
        (lambda b: b.assign(suite=""), ValueError, "'suite' holds empty"),
        (lambda b: b.assign(optimizer=None), ValueError, "'optimizer' holds missing"),
        (lambda b: b.assign(status="ok", free_energy=np.nan), ValueError, "status 'ok'"),
        (lambda b: b.assign(candidate=0), ValueError, "duplicate evaluation"),
        (lambda b: b.assign(iteration=[0, 1, 1]), ValueError, "one unit"),
        (lambda b: b.iloc[:0], ValueError, "no rows"),
    ],
)
def test_write_batch_rejects_bad_rows_naming_the_problem(
    tmp_path: Path, change, error: type[Exception], message: str
) -> None:
    store = ResultStore(tmp_path)
    with pytest.raises(error, match=message):
        store.write_batch(change(make_batch("cmaes", 0, 0)))
    assert store.completed_units() == frozenset()


def test_write_batch_rejects_non_frames() -> None:
    with pytest.raises(TypeError, match="expected a pandas DataFrame"):
        validate_evaluations([{"suite": "s"}])  # type: ignore[arg-type]


@pytest.mark.slow
def test_a_corrupt_part_on_disk_is_named(tmp_path: Path) -> None:
    store = ResultStore(tmp_path)
    write_all(store)
    unit = planned_units()[3]
    path = store.part_path(unit)
    lines = path.read_text().splitlines(keepends=True)
    header = lines[0].split(",")
    seed_at = header.index("seed")
    fields = lines[1].split(",")
    fields[seed_at] = "abc"
    lines[1] = ",".join(fields)
    path.write_text("".join(lines))
    with pytest.raises(TypeError, match=rf"{path.name}.*'seed' must hold integers"):
        store.read()


@pytest.mark.slow
@pytest.mark.parametrize("content", ["", "suite,optimizer\n", 'a,"b\n'])
def test_an_unreadable_part_on_disk_is_named(tmp_path: Path, content: str) -> None:
    store = ResultStore(tmp_path)
    write_all(store)
    path = store.part_path(planned_units()[2])
    path.write_text(content)
    with pytest.raises(ValueError, match=path.name):
        store.read()


def test_a_part_under_the_wrong_unit_is_named(tmp_path: Path) -> None:
    store = ResultStore(tmp_path)
    unit = store.write_batch(make_batch("cmaes", 0, 0))
    wrong = Unit(suite="optimizers", optimizer="cmaes", seed=0, iteration=7)
    store.part_path(wrong).write_bytes(store.part_path(unit).read_bytes())
    with pytest.raises(ValueError, match="iteration=000007.csv: rows belong to"):
        store.read()


@pytest.mark.parametrize(
    ("fields", "error"),
    [
        ({"suite": ""}, ValueError),
        ({"seed": -1}, ValueError),
        ({"iteration": 1.0}, TypeError),
        ({"optimizer": 3}, TypeError),
    ],
)
def test_unit_validates_its_fields(fields: dict, error: type[Exception]) -> None:
    base = {"suite": "s", "optimizer": "o", "seed": 0, "iteration": 0}
    with pytest.raises(error, match=next(iter(fields))):
        Unit(**{**base, **fields})


def test_hand_named_files_are_not_taken_for_parts(tmp_path: Path) -> None:
    store = ResultStore(tmp_path)
    unit = store.write_batch(make_batch("cmaes", 0, 0))
    path = store.part_path(unit)
    shutil.copy(path, path.with_name("iteration=0.csv"))  # not zero-padded: not ours
    shutil.copy(path, path.with_name("iteration=000001.csv.bak"))
    assert store.completed_units() == {unit}


# --- manifest ------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, kw_only=True)
class _Config:
    optimizers: tuple[str, ...] = ("cmaes", "bo")
    seeds: int = 10
    goal: np.ndarray = dataclasses.field(default_factory=lambda: np.array([0.0, 1.5, 0.1]))
    out: Path = Path("runs/x")


@pytest.mark.slow
def test_manifest_round_trips_and_records_the_environment(tmp_path: Path) -> None:
    start = dt.datetime(2024, 5, 1, 12, 0, tzinfo=dt.timezone.utc)
    end = start + dt.timedelta(seconds=90)
    store = ResultStore(tmp_path)
    write_all(store)
    totals = timing_totals(store.read())
    manifest = build_manifest(config=_Config(), start_time=start, end_time=end, **totals)
    path = store.write_manifest(manifest)
    assert path == tmp_path / "manifest.json"
    loaded = read_manifest(tmp_path)
    assert loaded == json.loads(json.dumps(manifest))
    assert loaded["config"] == {
        "optimizers": ["cmaes", "bo"],
        "seeds": 10,
        "goal": [0.0, 1.5, 0.1],
        "out": "runs/x",
    }
    assert loaded["wall_time"] == 90.0
    assert loaded["start_time"] == "2024-05-01T12:00:00+00:00"
    assert loaded["packages"]["numpy"] == np.__version__
    assert "skopt" not in loaded["packages"]
    assert loaded["host"]["cpu_count"] == os.cpu_count()
    assert loaded["host"]["cpu"] and isinstance(loaded["host"]["cpu"], str)
    assert loaded["host"]["control_loop"].startswith(("built", "not built", "off"))
    df = store.read()
    assert loaded["simulation_time"] == pytest.approx(df["eval_time"].sum())
    assert loaded["optimizer_time"] == pytest.approx(0.01 * len(df))
    commit = loaded["git_commit"]
    assert commit is None or (len(commit) == 40 and int(commit, 16) >= 0)


def test_manifest_bytes_are_deterministic(tmp_path: Path) -> None:
    manifest = {"b": 1, "a": {"z": 0.5, "y": [1, 2]}}
    one = write_manifest(tmp_path / "one", manifest).read_bytes()
    two = write_manifest(tmp_path / "two", dict(reversed(manifest.items()))).read_bytes()
    assert one == two and one.endswith(b"\n")


def test_git_commit_outside_a_repository_is_none(tmp_path: Path) -> None:
    assert git_commit(tmp_path) is None
    assert git_commit(tmp_path / "missing") is None
    assert git_dirty(tmp_path) is None


def test_the_manifest_says_whether_the_code_differed_from_its_commit(tmp_path: Path) -> None:
    if shutil.which("git") is None:
        pytest.skip("git is not installed")
    repo = tmp_path / "repo"
    repo.mkdir()

    def git(*args: str) -> None:
        subprocess.run(["git", *args], cwd=repo, check=True, capture_output=True)

    git("init", "-q")
    (repo / "code.py").write_text("x = 1\n")
    git("add", "code.py")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-q", "-m", "one")
    assert git_dirty(repo) is False
    (repo / "notes.txt").write_text("untracked files are not the code\n")
    assert git_dirty(repo) is False
    (repo / "code.py").write_text("x = 2\n")
    assert git_dirty(repo) is True
    start = dt.datetime(2024, 5, 1, tzinfo=dt.timezone.utc)
    manifest = build_manifest(config={}, start_time=start, repo_dir=repo)
    assert manifest["git_dirty"] is True and len(manifest["git_commit"]) == 40


def test_the_manifest_records_the_optional_libraries_a_run_may_use() -> None:
    import importlib.metadata

    versions = package_versions()
    for name in ("trimesh", "optuna", "nevergrad", "dask", "stable-baselines3"):
        try:
            assert versions[name] == importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            assert name not in versions


def test_manifest_bad_input_is_named(tmp_path: Path) -> None:
    naive = dt.datetime(2024, 1, 1)
    aware = naive.replace(tzinfo=dt.timezone.utc)
    with pytest.raises(ValueError, match="start_time must be timezone-aware"):
        build_manifest(config={}, start_time=naive)
    with pytest.raises(TypeError, match="end_time must be a datetime"):
        build_manifest(config={}, start_time=aware, end_time="tomorrow")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"config\.w\[1\] is nan"):
        build_manifest(config={"w": [1.0, float("nan")]}, start_time=aware)
    with pytest.raises(TypeError, match=r"config\.f is a builtin_function_or_method"):
        build_manifest(config={"f": print}, start_time=aware)
    with pytest.raises(TypeError, match="config must be a mapping"):
        build_manifest(config=[1], start_time=aware)
    with pytest.raises(ValueError, match="wall_time"):
        build_manifest(config={}, start_time=aware, end_time=aware - dt.timedelta(seconds=1))
    with pytest.raises(FileNotFoundError, match="manifest.json"):
        read_manifest(tmp_path)
    (tmp_path / "manifest.json").write_text("[1, 2]")
    with pytest.raises(ValueError, match="JSON object"):
        read_manifest(tmp_path)
    (tmp_path / "manifest.json").write_text("{")
    with pytest.raises(ValueError, match="not valid JSON"):
        read_manifest(tmp_path)


def test_timing_totals_needs_timing_columns() -> None:
    with pytest.raises(ValueError, match="'eval_time'"):
        timing_totals(pd.DataFrame({"opt_time": [1.0]}))


@pytest.mark.slow
def test_an_install_inside_another_projects_repository_records_no_commit(tmp_path: Path) -> None:
    """The package in a project's ignored .venv must not record that project's commit."""
    if shutil.which("git") is None:
        pytest.skip("git is not installed")
    root = Path(__file__).resolve().parents[1]
    project = tmp_path / "project"
    site = project / ".venv" / "site"
    site.mkdir(parents=True)
    for name in ("benchmarks", "tooldesign_env", "optimizers"):
        shutil.copytree(root / name, site / name, ignore=shutil.ignore_patterns("__pycache__"))
    (project / ".gitignore").write_text(".venv/\n")
    (project / "main.py").write_text("print('their code')\n")
    for args in (
        ["init", "-q"],
        ["add", "."],
        ["-c", "user.name=t", "-c", "user.email=t@t", "commit", "-q", "-m", "theirs"],
    ):
        subprocess.run(["git", *args], cwd=project, check=True, capture_output=True)
    (project / "main.py").write_text("print('changed')\n")  # their tree is dirty
    code = "from benchmarks.storage import git_commit, git_dirty; print(git_commit(), git_dirty())"
    env = {**os.environ, "PYTHONPATH": str(site), "PYTHONSAFEPATH": "1"}
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["None", "None"]


@pytest.mark.parametrize("out", ["", "  "])
def test_an_empty_out_folder_is_refused_not_taken_as_the_current_one(out: str) -> None:
    from benchmarks.storage import check_out_dir

    with pytest.raises(ValueError, match="--out must name a folder"):
        check_out_dir(out)
