"""The rl suite in the harness: its run folder, resume, report and command line.

The smoke run (``rl_smoke``, conftest.py) is what ``tooldesign bench rl --size smoke`` writes;
the interrupted runs here run one or two of its parts and must store exactly its rows.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_kill import run_until

from benchmarks.cli import main
from benchmarks.reports import make_suite_report
from benchmarks.rl import rl_suite_config, run_rl_suite
from benchmarks.rl.suite import (
    RL_SUITE_KIND,
    RUNTIME_FIELDS,
    SIZES,
    VARIANTS,
    RLSuiteConfig,
)
from benchmarks.storage import (
    PART_CHECKSUMS,
    ResultStore,
    ResumeError,
    RunSession,
    Unit,
    file_sha256,
)

ROOT = Path(__file__).resolve().parents[1]
TIMING = ["eval_time", "opt_time"]


def _documented(heading: str, first_column: str) -> list[str]:
    """The backticked names of the first column of a table in docs/results-format.md's rl part."""
    text = (ROOT / "docs" / "results-format.md").read_text(encoding="utf-8")
    section = text[text.index(f"## {heading}") :]
    table = section[section.index(f"| {first_column} |") :].split("\n\n")[0]
    names: list[str] = []
    for line in table.splitlines()[2:]:
        names += re.findall(r"`([^`]+)`", line.split("|")[1])
    return names


def _episodes(folder: Path) -> pd.DataFrame:
    return ResultStore(folder).read().drop(columns=TIMING)


def _rows_of(log: pd.DataFrame, variants: set[str]) -> pd.DataFrame:
    return log[log["variant"].isin(variants)].reset_index(drop=True)


def _assert_same_rows(mine: pd.DataFrame, reference: pd.DataFrame) -> None:
    """Equal rows; columns the reference has beyond mine are empty in these rows."""
    reference = reference.reset_index(drop=True)
    assert reference.drop(columns=list(mine.columns)).isna().all().all()
    pd.testing.assert_frame_equal(mine, reference[list(mine.columns)])


# --- the stored files match the documented format ---------------------------------------------


@pytest.mark.slow
def test_every_episode_stores_whether_the_box_stands(rl_smoke: Path) -> None:
    # The push task's success asks the box to stand at the goal: every row keeps the box's
    # final height and tilt beside its distance, so the report applies the whole test.
    log = ResultStore(rl_smoke).read()
    ok = log[log["status"] == "ok"]
    assert len(ok) and ok[["final_height", "final_tilt"]].notna().all().all()
    assert ((ok["final_height"] > 0) & (ok["final_height"] < 0.5)).all()
    assert ((ok["final_tilt"] >= 0) & (ok["final_tilt"] <= np.pi)).all()


@pytest.mark.slow
def test_the_smoke_run_folder_is_as_documented(rl_smoke: Path) -> None:
    manifest = json.loads((rl_smoke / "manifest.json").read_text())
    assert manifest["extra"]["kind"] == RL_SUITE_KIND
    assert manifest["config"]["size"]["name"] == "smoke" and manifest["end_time"]
    # Every part is recorded with its checksum.
    store = ResultStore(rl_smoke)
    parts = {
        store.part_path(u).relative_to(rl_smoke).as_posix(): u for u in store.completed_units()
    }
    recorded = manifest["extra"][PART_CHECKSUMS]
    assert set(recorded) == set(parts)
    assert all(file_sha256(rl_smoke / p) == sha for p, sha in recorded.items())
    assert all(u.iteration == 0 and u.suite == "rl" for u in parts.values())

    log = store.read()
    # The columns: the evaluation log's, with the rl suite's extra columns, all documented.
    documented = _documented("The rl suite", "column")
    expected = {c.strip() for name in documented for c in name.split(",")}
    assert set(log.columns) - {"best_so_far"} == expected
    # The variants, as documented and as the code names them.
    assert _documented("The rl suite", "variant") == list(VARIANTS)
    assert set(log["variant"]) == set(VARIANTS)
    assert (log.loc[log["status"] == "ok", "free_energy"].notna()).all()

    size, config = SIZES["smoke"], manifest["config"]
    fixed = log[log["variant"] == "fixed"]
    for _, run in fixed.groupby(["optimizer", "seed"]):
        assert list(run["candidate"]) == list(range(size.fixed_episodes))
    for prefix in ("", "mass-"):
        zero = log[log["variant"] == f"{prefix}zero-shot"]
        for _, run in zero.groupby(["optimizer", "seed"]):
            assert list(run["goal_index"]) == list(range(size.held_out_goals))
            np.testing.assert_array_equal(
                run[["goal_x", "goal_y", "goal_z"]], config["held_out_goals"]
            )
        held = log[log["variant"] == f"{prefix}held-out"]
        assert held.groupby(["optimizer", "seed"]).size().eq(max(config["budgets"])).all()
    # The mass part: training on random masses in the range, tests at the held-out masses.
    low, high = config["mass_range"]
    train = log[log["variant"] == "mass-train"]
    assert set(train["optimizer"]) == {"ppo", "sac", "contextual"}
    assert train["box_mass"].between(low, high).all() and train["box_mass"].nunique() > 2
    for method in ("ppo", "sac"):
        zero = log[(log["variant"] == "mass-zero-shot") & (log["optimizer"] == method)]
        np.testing.assert_array_equal(zero["box_mass"], config["held_out_masses"])
    assert (log[log["variant"] == "zero-shot"]["box_mass"] == 0.1).all()

    policies = sorted(p.name for p in (rl_smoke / "policies").iterdir())
    assert policies == [
        "contextual.json",
        "mass-contextual.json",
        "mass-ppo.json",
        "mass-ppo.safetensors",
        "mass-sac.json",
        "mass-sac.safetensors",
        "ppo.json",
        "ppo.safetensors",
        "sac.json",
        "sac.safetensors",
    ]
    card = json.loads((rl_smoke / "policies" / "mass-contextual.json").read_text())
    assert card["mass_range"] == config["mass_range"] and len(card["policy"]["masses"]) == 2

    report = sorted(p.name for p in (rl_smoke / "report").iterdir())
    documented_report = {
        n for name in _documented("The rl suite", "file") for n in name.split(", ") if "*" not in n
    }
    assert documented_report <= set(report)
    assert {n for n in report if n.startswith("held-out-mass")} == {
        f"held-out-mass{s}" for s in (".csv", ".md", ".png", "-per-goal.csv", "-per-goal.md")
    }


@pytest.mark.slow
def test_the_report_is_made_from_the_stored_files_alone(rl_smoke: Path, tmp_path: Path) -> None:
    # Only what a shared folder keeps: the manifest and the consolidated log (no parts).
    shared = tmp_path / "shared"
    shared.mkdir()
    for name in ("manifest.json", "evaluations.parquet"):
        (shared / name).write_bytes((rl_smoke / name).read_bytes())
    files = make_suite_report(shared)
    assert {f.name for f in files} == {p.name for p in (rl_smoke / "report").iterdir()}
    for f in files:
        if f.suffix in (".csv", ".md", ".json"):
            assert f.read_bytes() == (rl_smoke / "report" / f.name).read_bytes(), f.name
    summary = json.loads((shared / "report" / "summary.json").read_text())
    approaches = {a["approach"]: a for a in summary["task"]["approaches"]}
    assert approaches["straight"]["median_F_over_straight"] == 1.0
    assert approaches["ppo"]["total_episodes"] == approaches["ppo"]["train_episodes"] + 2
    assert {"contextual", "sac", "cmaes@1", "random@5"} <= set(approaches)
    equal = summary["task"]["equal_budget"]
    assert sum(map(int, approaches["contextual"][f"vs_random_{equal}"].split("/"))) == 2
    fixed = pd.read_csv(shared / "report" / "fixed-goal.csv")
    assert set(fixed["method"]) == {"random", "cmaes", "ppo", "sac"}
    page = (shared / "report" / "rl.md").read_text()
    for figure in ("fixed-goal.png", "held-out.png", "held-out-mass.png"):
        assert f"]({figure})" in page


def test_the_report_refuses_other_folders(tmp_path: Path) -> None:
    from benchmarks.reports.rl import make_rl_report

    with pytest.raises(FileNotFoundError):
        make_rl_report(tmp_path / "absent")
    RunSession(tmp_path / "suite", kind="suite", config={"name": "x"}, resume=False).checkpoint()
    with pytest.raises(ValueError, match="not an rl suite run folder"):
        make_rl_report(tmp_path / "suite")


# --- resume --------------------------------------------------------------------------------


@pytest.mark.slow
def test_resume_after_sigkill_stores_what_an_uninterrupted_run_stores(
    rl_smoke: Path, tmp_path: Path
) -> None:
    out = tmp_path / "killed"
    args = ["bench", "rl", "--size", "smoke", "--out", str(out), "--no-progress"]
    args += ["--parts", "fixed", "--methods", "random", "ppo"]
    fixed_seed = int(_episodes(rl_smoke).query("variant == 'fixed'")["seed"].iloc[0])
    first = Unit(suite="rl", variant="fixed", optimizer="random", seed=fixed_seed, iteration=0)
    # Killed as soon as the first run's part is on disk (PPO's runs are still to come) ...
    run_until(args, ResultStore(out).part_path(first))
    assert not (out / "evaluations.parquet").exists()
    # ... and the same command finishes it.
    assert main(args) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert len(manifest["extra"]["sessions"]) == 2
    variants = {"fixed", "fixed-policy"}
    reference = _rows_of(_episodes(rl_smoke), variants)
    reference = reference[reference["optimizer"].isin(["random", "ppo", "straight"])]
    _assert_same_rows(_episodes(out), reference)


@pytest.mark.slow
def test_a_unit_stopped_between_its_parts_is_redone_and_checked(
    rl_smoke: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "stopped"
    config = rl_suite_config("smoke", parts=("task",))
    real = RunSession.write_batch

    def stop_at_zero_shot_of_ppo(self: RunSession, rows: pd.DataFrame) -> Unit:
        if rows["variant"].iloc[0] == "zero-shot" and rows["optimizer"].iloc[0] == "ppo":
            raise KeyboardInterrupt("stopped between PPO's training part and its zero-shot part")
        return real(self, rows)

    monkeypatch.setattr(RunSession, "write_batch", stop_at_zero_shot_of_ppo)
    with pytest.raises(KeyboardInterrupt):
        run_rl_suite(config, out)
    monkeypatch.setattr(RunSession, "write_batch", real)
    store = ResultStore(out)
    train = next(u for u in store.completed_units() if u.variant == "train")
    before = store.part_path(train).read_bytes()
    assert {u.variant for u in store.completed_units()} == {"zero-shot", "train"}

    result = run_rl_suite(config, out)
    assert result.units_run == result.units - 1  # all but the straight tool's
    assert store.part_path(train).read_bytes() == before  # checked, not rewritten
    _assert_same_rows(
        _episodes(out), _rows_of(_episodes(rl_smoke), {"train", "zero-shot", "held-out"})
    )
    for card in ("contextual.json", "ppo.json", "sac.json"):
        assert (out / "policies" / card).read_bytes() == (rl_smoke / "policies" / card).read_bytes()


@pytest.mark.slow
def test_resume_refuses_other_settings_and_edited_parts(tmp_path: Path) -> None:
    out = tmp_path / "run"
    config = rl_suite_config("smoke", parts=("fixed",), methods=("random",))
    run_rl_suite(config, out)
    with pytest.raises(ResumeError, match="(?s)other settings.*methods"):
        run_rl_suite(rl_suite_config("smoke", parts=("fixed",), methods=("cmaes",)), out)
    with pytest.raises(ResumeError, match="(?s)other settings.*mass_range"):
        run_rl_suite(
            rl_suite_config("smoke", parts=("fixed",), methods=("random",), mass_range=(0.2, 1)),
            out,
        )
    with pytest.raises(ValueError, match="not empty"):
        run_rl_suite(config, out, resume=False)
    store = ResultStore(out)
    part = next(store.part_path(u) for u in store.completed_units() if u.optimizer == "random")
    part.write_text(part.read_text() + "\n")
    with pytest.raises(ResumeError, match="cannot resume"):
        run_rl_suite(config, out)
    assert RUNTIME_FIELDS == {"workers"}  # the one setting a resume may change


@pytest.mark.slow
@pytest.mark.parametrize(
    ("field", "default", "before"),
    [("section_shape", "round", "square"), ("merge_fixed_links", True, False)],
)
def test_a_folder_made_with_an_older_default_is_not_resumed_with_todays(
    tmp_path: Path, field: str, default: object, before: object
) -> None:
    # The square tool, and the 13-link arm, were the defaults of the folders made before.
    from benchmarks.rl.suite import ADDED_FIELDS

    out = tmp_path / "run"
    config = rl_suite_config("smoke", parts=("fixed",), methods=("random",))
    assert config.to_json()[field] == default
    assert ADDED_FIELDS[field] == before
    run_rl_suite(config, out)
    run_rl_suite(config, out)  # the same settings: resumes (nothing left to do)
    manifest = json.loads((out / "manifest.json").read_text())
    del manifest["config"][field]  # as the folders made before the field existed
    (out / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(ResumeError, match=f"(?s)other settings.*{field}") as refused:
        run_rl_suite(config, out)
    # No size and options of this version make the folder's settings: no command to offer.
    assert "this version cannot continue it" in str(refused.value)
    assert "tooldesign bench rl" not in str(refused.value)


@pytest.mark.slow
def test_resuming_with_another_size_names_the_differences_in_short_lines(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    recorded = rl_suite_config("smoke", parts=("fixed",), methods=("random",))
    RunSession(
        out, kind=RL_SUITE_KIND, config=recorded.to_json(), resume=False, extra={}
    ).checkpoint()
    argv = ["bench", "rl", "--size", "short", "--seeds", "2", "--out", str(out)]
    with pytest.raises(SystemExit) as exit_info:
        main([*argv, "--parts", "fixed", "task", "--methods", "random", "--no-progress"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    # It was one line of thousands of characters: every field of both configs, in full.
    assert 4 <= len(lines) <= 10 and all(len(line) < 200 for line in lines), err
    assert str(out) in lines[0] and "other settings" in lines[0]
    # The fields the options set come first, recorded -> requested; the rest are counted.
    assert lines[1:4] == [
        '  size.name: "smoke" -> "short"',
        "  size.seeds: 1 -> 2",
        '  parts: ["fixed"] -> ["fixed", "task"]',
    ]
    assert re.fullmatch(r"  and \d+ more \(.*\)", lines[-3]), err
    command = lines[-2].removeprefix("continue it with: ")
    assert command == f"tooldesign bench rl --size smoke --methods random --parts fixed --out {out}"
    # ... and that command does continue it.
    assert main([*command.split()[1:], "--no-progress"]) == 0
    assert {u.optimizer for u in ResultStore(out).completed_units()} == {"random", "straight"}


@pytest.mark.slow
def test_a_redone_unit_that_differs_from_its_stored_part_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "run"
    config = rl_suite_config("smoke", parts=("fixed",), methods=("ppo",))
    run_rl_suite(config, out)
    store = ResultStore(out)
    fixed, policy = (
        next(u for u in store.completed_units() if u.variant == v and u.optimizer == "ppo")
        for v in ("fixed", "fixed-policy")
    )
    # PPO's unit looks interrupted before its last part, and its first part says other things.
    manifest = json.loads((out / "manifest.json").read_text())
    checksums = manifest["extra"][PART_CHECKSUMS]
    del checksums[store.part_path(policy).relative_to(out).as_posix()]
    store.part_path(policy).unlink()
    path = store.part_path(fixed)
    frame = pd.read_csv(path)
    frame.loc[0, "c1"] += 0.5
    path.write_text(frame.to_csv(index=False, lineterminator="\n"))
    checksums[path.relative_to(out).as_posix()] = file_sha256(path)
    (out / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(ResumeError, match="gave other results"):
        run_rl_suite(config, out)
    assert not store.part_path(policy).exists()


def test_parts_the_suite_does_not_plan_are_refused(tmp_path: Path) -> None:
    out = tmp_path / "run"
    config = rl_suite_config("smoke", parts=("fixed",), methods=("random",))
    RunSession(
        out, kind=RL_SUITE_KIND, config=config.to_json(), resume=False, extra={}
    ).checkpoint()
    stray = ResultStore(out).part_path(Unit(suite="rl", optimizer="dqn", seed=1, iteration=0))
    stray.parent.mkdir(parents=True)
    stray.write_text("suite\n")
    session = json.loads((out / "manifest.json").read_text())
    session["extra"][PART_CHECKSUMS] = {stray.relative_to(out).as_posix(): file_sha256(stray)}
    (out / "manifest.json").write_text(json.dumps(session))
    with pytest.raises(ResumeError, match="does not plan"):
        run_rl_suite(config, out)


# --- configuration and command line ----------------------------------------------------------


def test_the_sizes_are_the_documented_ones() -> None:
    full = rl_suite_config("full")
    assert full.size.seeds == 10 and full.size.fixed_episodes == 1024
    assert full.size.held_out_goals == 20 and set(full.size.budgets) == {50, 100, 200}
    assert full.budgets == (1, 50, 53, 100, 200)  # 53: the equal total of 1,024 + 20 episodes
    assert rl_suite_config("short").size.fixed_episodes == 256
    smoke = rl_suite_config("smoke")
    assert smoke.planned_episodes() < 150 and isinstance(smoke, RLSuiteConfig)
    # The same choice in another order is the same config (a resume compares them).
    a = rl_suite_config("smoke", methods=("ppo", "random"), parts=("task", "fixed"))
    b = rl_suite_config("smoke", methods=("random", "ppo"), parts=("fixed", "task"))
    assert a.to_json() == b.to_json()
    assert json.loads(json.dumps(a.to_json())) == a.to_json()


@pytest.mark.parametrize(
    ("kwargs", "error", "words"),
    [
        ({"size": "huge"}, ValueError, "unknown size 'huge'"),
        ({"size": "paper"}, ValueError, "smoke, short, full"),
        ({"size": 3}, TypeError, "size"),
        ({"seeds": 0}, ValueError, "seeds"),
        ({"seeds": 1.5}, TypeError, "seeds"),
        ({"methods": ("dqn",)}, ValueError, "got dqn"),
        ({"methods": "ppo"}, ValueError, "methods"),
        ({"parts": ()}, ValueError, "parts"),
        ({"parts": ("all",)}, ValueError, "fixed, task, mass"),
        ({"mass_range": (0.9, 0.1)}, ValueError, "low <= high"),
        ({"mass_range": (0.0, 0.5)}, ValueError, "1e-06 <= low"),
        ({"mass_range": "light"}, TypeError, "mass_range"),
        ({"workers": 0}, ValueError, "workers"),
    ],
)
def test_bad_suite_settings_raise(kwargs: dict, error: type, words: str) -> None:
    with pytest.raises(error, match=re.escape(words)):
        rl_suite_config(**kwargs)


def test_the_suite_mass_range_has_the_env_floor(tmp_path: Path, capsys) -> None:
    # 1e-9 passed the suite's `0 < low`, wrote manifest.json and a part file, then the env
    # refused it: the folder could be neither resumed nor reused.
    from benchmarks.cli import main
    from tooldesign_env.rl import ToolDesignRLEnv
    from tooldesign_env.specs import MASS_RANGE_MIN

    rl_suite_config(parts=("mass",), mass_range=(MASS_RANGE_MIN, MASS_RANGE_MIN))
    ToolDesignRLEnv(mass_range=(MASS_RANGE_MIN, MASS_RANGE_MIN)).close()
    low = MASS_RANGE_MIN / 2
    with pytest.raises(ValueError, match="mass_range"):
        ToolDesignRLEnv(mass_range=(low, low))
    with pytest.raises(ValueError, match=re.escape(f"{MASS_RANGE_MIN:g} <= low")):
        rl_suite_config(parts=("mass",), mass_range=(low, low))
    out = tmp_path / "rl"
    argv = ["bench", "rl", "--size", "smoke", "--out", str(out), "--parts", "mass"]
    argv += ["--methods", "random", "--no-progress", "--mass-range", "1e-9", "1e-9"]
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    assert "mass_range must satisfy 1e-06 <= low" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["bench", "rl", "--size", "huge"], "unknown size 'huge' of the rl suite"),
        (["bench", "rl", "--size", "smoke", "--parts", "fixed", "all"], "got fixed all"),
        (["bench", "rl", "--methods", "dqn"], "got dqn"),
        (["bench", "rl", "--mass-range", "0.9", "0.1"], "got 0.9 0.1"),
        (["bench", "rl", "--mass-range", "heavy", "0.1"], "got heavy 0.1"),
        (["bench", "rl", "--seeds", "two"], "--seeds must be an int >= 1, got 'two'"),
        (["bench", "rl", "--seeds", "0"], "seeds must be an int >= 1, got 0"),
        (["bench", "rl", "--workers", "0"], "workers must be an int >= 1, got 0"),
        (["bench", "rl", "--executor", "serial"], "--executor is not available for the rl"),
        (["bench", "rl", "--dump-config", "x.toml"], "--dump-config is not available"),
        (["bench", "rl", "--max-retries", "2"], "--max-retries is not available for the rl"),
        (["bench", "rl", "--section-shape", "square"], "--section-shape square: not for the rl"),
        (["bench", "optimizers", "--parts", "fixed"], "--parts: for the rl suite only"),
        (["bench", "optimizers", "--mass-range", "0.1", "0.2"], "--mass-range: for the rl"),
        (["rl", "suite", "--workers", "many"], "--workers must be an int >= 1, got 'many'"),
        (["rl", "suite", "--size", "paper"], "sizes: smoke, short, full"),
    ],
)
def test_bad_rl_suite_options_exit_2_with_one_line(
    argv: list[str], words: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    with pytest.raises(SystemExit) as exit_info:
        main([*argv, "--out", str(out)])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and words in err, err
    assert not out.exists()  # nothing was started


def test_bench_help_lists_the_rl_suite_and_its_sizes(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["bench", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "rl (the RL baselines" in text and "smoke, short, full" in text
    for option in ("--seeds", "--methods", "--parts", "--mass-range"):
        assert option in text


def test_the_fixed_goal_table_tests_the_seeds_against_random_sampling():
    from benchmarks.reports.rl import fixed_goal_table

    rng = np.random.default_rng(0)
    rows = []
    for method, shift in (("random", 0.0), ("cmaes", -500.0), ("ppo", 0.0)):
        for seed in range(10):
            values = 8000.0 + shift + rng.normal(0.0, 50.0, 16)
            rows += [
                {
                    "variant": "fixed",
                    "optimizer": method,
                    "seed": seed,
                    "candidate": k,
                    "free_energy": v,
                }
                for k, v in enumerate(values)
            ]
    table = fixed_goal_table(pd.DataFrame(rows), 0.015).set_index(["method", "episodes"])
    cmaes, ppo = table.loc[("cmaes", 16)], table.loc[("ppo", 16)]
    assert cmaes["a12"] == 0.0 and cmaes["significant"] and cmaes["p_holm"] < 1e-3
    assert 0.2 < ppo["a12"] < 0.8 and not ppo["significant"]
    assert np.isnan(table.loc[("random", 16), "p_holm"])
    # One seed each: nothing to test.
    one = pd.DataFrame([r for r in rows if r["seed"] == 0])
    assert fixed_goal_table(one, 0.015)["p_holm"].isna().all()
