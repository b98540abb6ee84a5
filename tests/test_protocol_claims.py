"""Claim (a) judged under the benchmark protocol on the reproduction page (issue 32, item 8).

The judgement's rule on hand-made report tables (fast), the refusals of bad folders and bad
``--protocol`` values (fast), and, on a real smoke run (slow), the page's numbers read back
against the protocol report's own CSV files, a tampered report or cell refused, and the default
folder ``RESULTS/protocol-full`` judged by ``tooldesign reproduce``.
"""

from __future__ import annotations

import csv
import inspect
import math
import shutil
from pathlib import Path

import pandas as pd
import pytest

from benchmarks.cli import main
from benchmarks.protocol import make_protocol_report, protocol_config
from benchmarks.protocol.claims import (
    CLAIM_TABLES,
    PROTOCOL_ALPHA,
    judge_claim_a,
    protocol_claim,
    read_claim_tables,
)
from benchmarks.protocol.suite import write_protocol_record
from benchmarks.reports.reproduction import (
    PROTOCOL_FOLDER,
    PROTOCOL_HEADING,
    PROTOCOL_ROW,
    reproduction_page,
)

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
FOUR = ("bo", "cmaes", "pso", "random")


def test_the_claims_level_is_the_reports() -> None:
    default = inspect.signature(make_protocol_report).parameters["alpha"].default
    assert default == PROTOCOL_ALPHA


# --- the rule, on hand-made tables --------------------------------------------------------------


def _tables(
    groups: dict[str, dict[tuple[str, str], tuple[float, bool] | tuple[float, bool, bool]]],
    *,
    n: int = 24,
    min_n: int = 11,
    optimizers: tuple[str, ...] = FOUR,
) -> dict[str, pd.DataFrame]:
    """Report tables with the given (a - b, significant[, beyond floor]) per pair and group.

    Other pairs: 0, not significant. The final-F difference goes the score's way: -100
    [-110, -90] per unit sign beyond the floor of 50 (the default for a given pair), -10
    [-30, 10] within it when ``beyond floor`` is False; 0 [-10, 10] for a 0 difference.
    """
    comparisons, ranks, power, references = [], [], [], []
    for group, given in groups.items():
        means = {o: 0.5 for o in optimizers}
        for k, a in enumerate(optimizers):
            for b in optimizers[k + 1 :]:
                diff, significant, *rest = given.get((a, b), (0.0, False))
                beyond = bool(rest[0]) if rest else diff != 0
                sign = (diff > 0) - (diff < 0)
                f_diff = (-100.0 if beyond else -10.0) * sign + 0.0
                half = 10.0 if beyond or sign == 0 else 20.0
                means[a] += diff / 2
                means[b] -= diff / 2
                comparisons.append(
                    {
                        "a": a,
                        "b": b,
                        "n": n,
                        "mean_diff": diff,
                        "ci_low": diff - 0.01,
                        "ci_high": diff + 0.01,
                        "d_z": diff * 10,
                        "p": 1e-4 if significant else 0.5,
                        "p_holm": 6e-4 if significant else 1.0,
                        "significant": significant,
                        "f_diff": f_diff,
                        "f_diff_low": f_diff - half,
                        "f_diff_high": f_diff + half,
                        "floor": 50.0,
                        "beyond_floor": beyond,
                        "d": group,
                    }
                )
                for measure, detectable in (("score", 0.02), ("final F", 80.0)):
                    power.append(
                        {
                            "a": a,
                            "b": b,
                            "n": n,
                            "min_n": min_n,
                            "separable": n >= min_n,
                            "detectable": detectable if n >= min_n else math.inf,
                            "instances_needed": 30.0,
                            "seeds_needed": 5.0,
                            "d": group,
                            "measure": measure,
                        }
                    )
        order = sorted(optimizers, key=lambda o: -means[o])
        for rank, o in enumerate(order, 1):
            ranks.append({"optimizer": o, "P(rank 1)": 1.0 if rank == 1 else 0.0,
                          "mean": means[o], "rank": rank, "d": group})  # fmt: skip
        if group != "all":
            references += [
                {"d": group, "instance": "i1", "noise floor": 40.0},
                {"d": group, "instance": "i2", "noise floor": 60.0},
            ]
    return {
        "comparisons.csv": pd.DataFrame(comparisons),
        "ranks.csv": pd.DataFrame(ranks),
        "power.csv": pd.DataFrame(power),
        "references.csv": pd.DataFrame(references),
    }


def _judge(given, **kwargs):
    (judged,) = judge_claim_a(_tables({"3": given}, **kwargs), ["3"])
    return judged


def test_cmaes_sooner_than_every_other_optimizer_holds() -> None:
    # Pairs are alphabetical: "bo vs cmaes" is bo minus cmaes, so CMA-ES sooner is negative.
    judged = _judge(
        {
            ("bo", "cmaes"): (-0.05, True),
            ("cmaes", "pso"): (0.04, True),
            ("cmaes", "random"): (0.1, True),
        }
    )
    assert judged.verdict == "holds"
    assert judged.text.startswith(
        "**holds**: CMA-ES is told apart as faster than every other non-random optimizer"
    )
    assert "faster than random sampling too" in judged.text
    assert {v.other: round(v.diff, 9) for v in judged.versus} == {
        "bo": 0.05,
        "pso": 0.04,
        "random": 0.1,
    }
    assert ("cmaes", "bo") in judged.told_apart and ("bo", "pso") in judged.not_told_apart
    bo = next(v for v in judged.versus if v.other == "bo")
    assert (bo.low, bo.high) == pytest.approx((0.04, 0.06))  # the interval turned with the sign
    assert judged.detectable == (0.02, 0.02) and judged.detectable_f == (80.0, 80.0)
    assert judged.noise_floor == 50.0


def test_sooner_than_some_non_random_optimizer_holds_in_part() -> None:
    judged = _judge({("cmaes", "pso"): (0.04, True), ("bo", "pso"): (0.03, True)})
    assert judged.verdict == "holds in part"
    assert "faster than pso" in judged.text and "not from bo; not told apart from random" in (
        judged.text
    )
    assert set(judged.told_apart) == {("cmaes", "pso"), ("bo", "pso")}


def test_beating_random_sampling_only_is_not_shown_and_says_so() -> None:
    # Random sampling is the baseline every method beats: beating it alone is not "in part".
    judged = _judge({("cmaes", "random"): (0.1, True), ("bo", "pso"): (0.03, True)})
    assert judged.verdict == "not shown (faster than random sampling only)"
    assert judged.text.startswith("**not shown** (faster than random sampling only): CMA-ES")
    assert "from none of bo, pso" in judged.text
    assert set(judged.told_apart) == {("cmaes", "random"), ("bo", "pso")}


def test_a_significant_pair_within_the_noise_floor_is_not_told_apart() -> None:
    # Holm p < 0.01 in score, but the final designs differ by less than the noise floor.
    judged = _judge(
        {
            ("bo", "cmaes"): (-0.05, True, False),
            ("cmaes", "pso"): (0.04, True),
            ("cmaes", "random"): (0.1, True),
        }
    )
    assert ("cmaes", "bo") not in judged.told_apart and ("bo", "cmaes") in judged.not_told_apart
    assert judged.verdict == "holds in part" and "not from bo" in judged.text
    bo = next(v for v in judged.versus if v.other == "bo")
    assert bo.significant and not bo.beyond_floor and not bo.told_apart
    assert (bo.f_diff, bo.f_low, bo.f_high) == (-10.0, -30.0, 10.0)  # turned: CMA-ES minus bo
    assert "a property of the problem" in judged.sentence and "bo ~ cmaes" in judged.sentence
    # An optimizer significantly sooner but within the floor does not reverse the claim either.
    worse = _judge({("bo", "cmaes"): (0.05, True, False), ("cmaes", "pso"): (0.04, True)})
    assert worse.verdict == "holds in part"


def test_another_optimizer_significantly_sooner_is_does_not_hold() -> None:
    judged = _judge({("bo", "cmaes"): (0.05, True), ("cmaes", "random"): (0.1, True)})
    assert judged.verdict == "does not hold"
    assert judged.text.startswith("**does not hold**: bo reaches the targets significantly sooner")
    assert "-0.05 [-0.06, -0.04]" in judged.text and "CMA-ES is sooner than random" in judged.text


def test_told_apart_from_none_is_not_shown_and_says_why() -> None:
    judged = _judge({("cmaes", "random"): (0.1, False)})
    assert judged.verdict == "not shown"
    assert "not told apart from bo, pso, random" in judged.text
    # Below the fewest instances any pair needs, the verdict says the run could not tell.
    few = _judge({("cmaes", "random"): (0.1, False)}, n=6)
    assert few.verdict == "not shown" and not few.separable
    assert "with 6 instances no pair can be told apart" in few.text and "at least 11" in few.text
    assert few.detectable == (math.inf, math.inf)


def test_a_run_without_cmaes_is_not_tested() -> None:
    judged = _judge({}, optimizers=("bo", "random"))
    assert judged.verdict == "not tested" and "the run has no cmaes" in judged.text


def test_the_summary_verdict_over_the_dimensions() -> None:
    from benchmarks.protocol.claims import _overall

    sooner = {("bo", "cmaes"): (-0.05, True), ("cmaes", "pso"): (0.04, True),
              ("cmaes", "random"): (0.1, True)}  # fmt: skip
    part = {("cmaes", "pso"): (0.04, True)}
    random_only = {("cmaes", "random"): (0.1, True)}
    worse = {("bo", "cmaes"): (0.05, True)}

    def overall(*given):
        groups = {str(d): g for d, g in zip((3, 5, 8, "all"), given, strict=False)}
        return _overall(judge_claim_a(_tables(groups), list(groups)))

    assert overall(sooner, sooner, sooner, {}).startswith("**holds** at every dimension (")
    assert overall(sooner, part, {}, sooner).startswith("**holds in part** (d = 3: holds; ")
    assert overall(sooner, worse, part, part).startswith("**does not hold** at d = 5 (")
    assert overall({}, {}, {}, sooner).startswith("**not shown** at any dimension (")
    assert overall({}, {}, {}, sooner).endswith("pooled: holds)")
    assert overall(random_only, {}, random_only, sooner).startswith(
        "**not shown** (faster than random sampling only, at d = 3, 8) (d = 3: not shown "
        "(faster than random sampling only); d = 5: not shown; "
    )
    assert overall(random_only, part, {}, {}).startswith("**holds in part** (")
    assert overall(random_only, worse, {}, {}).startswith("**does not hold** at d = 5 (")


def test_the_floor_is_the_first_tasks_when_the_references_list_every_task() -> None:
    # A run with the task axis lists every task's cells in references.csv; the judged sections
    # are the first task's (push's), so another task's floors must not move the group's floor.
    given = {("cmaes", "random"): (0.1, True)}
    push_only = _tables({"3": given, "all": given})
    with_tasks = _tables({"3": given, "all": given})
    references = push_only["references.csv"].assign(task="push")
    hook = [{"task": "hook", "d": "3", "instance": f"hook/i{k}", "noise floor": 5.0}
            for k in range(1, 6)]  # fmt: skip
    with_tasks["references.csv"] = pd.concat([references, pd.DataFrame(hook)], ignore_index=True)
    alone = judge_claim_a(push_only, ["3", "all"])
    both = judge_claim_a(with_tasks, ["3", "all"])
    assert [j.noise_floor for j in both] == [j.noise_floor for j in alone] == [50.0, 50.0]


@pytest.mark.slow  # the exact power computation of 24 instances takes seconds
def test_the_statistics_own_tables_of_four_optimizers_are_judged() -> None:
    """Tables made by the protocol's statistics, as its report makes them, on 24 instances."""
    import numpy as np

    from benchmarks.protocol.effects import floor_effects
    from benchmarks.protocol.statistics import paired_comparisons, power_analysis, rank_stability

    rng = np.random.default_rng(0)
    speed = {"cmaes": 0.7, "pso": 0.6, "bo": 0.6, "random": 0.45}
    rows = [
        {
            "instance": f"i{i:02d}",
            "optimizer": o,
            "seed": seed,
            "score": mean + 0.1 * base + rng.normal(0, 0.02),
        }  # fmt: skip
        for i, base in enumerate(rng.normal(0, 1, 24))
        for o, mean in speed.items()
        for seed in range(3)
    ]
    scores = pd.DataFrame(rows)
    # Final F goes with the score: 1000 F per unit of score lower, beyond a floor of 20.
    scores["final_f"] = 2000.0 - 1000.0 * scores["score"]
    floors = {f"i{i:02d}": 20.0 for i in range(24)}
    comparisons = paired_comparisons(scores, alpha=PROTOCOL_ALPHA).merge(
        floor_effects(scores, floors), on=["a", "b"]
    )
    in_f = power_analysis(scores.assign(score=scores["final_f"]), alpha=PROTOCOL_ALPHA)
    tables = {
        "comparisons.csv": comparisons.assign(d="5"),
        "ranks.csv": rank_stability(scores, resamples=50)
        .reset_index(names="optimizer")
        .assign(d="5"),
        "power.csv": pd.concat(
            [
                power_analysis(scores, alpha=PROTOCOL_ALPHA).assign(d="5", measure="score"),
                in_f.assign(d="5", measure="final F"),
            ]
        ),
        "references.csv": pd.DataFrame({"d": ["5"], "instance": ["i1"], "noise floor": [50.0]}),
    }
    (judged,) = judge_claim_a(tables, ["5"])
    assert judged.verdict == "holds" and judged.ranking[0][0] == "cmaes"
    assert {v.other for v in judged.versus} == {"bo", "pso", "random"}
    assert all(v.diff > 0 and v.low > 0 for v in judged.versus)
    assert ("bo", "pso") in judged.not_told_apart and ("pso", "random") in judged.told_apart
    assert judged.instances == 24 and judged.min_instances == 11 and judged.separable
    assert 0 < judged.detectable[0] <= judged.detectable[1] < 0.1
    # bo and pso differ by noise alone: their F interval lies within the floor of 20.
    assert "a property of the problem" in judged.sentence and "bo ~ pso" in judged.sentence


def test_judge_refuses_tables_without_their_columns() -> None:
    tables = _tables({"3": {}})
    tables["comparisons.csv"] = tables["comparisons.csv"].drop(columns="p_holm")
    with pytest.raises(ValueError, match=r"lacks the columns \['p_holm'\]"):
        judge_claim_a(tables, ["3"])
    with pytest.raises(ValueError, match="groups must name at least one group"):
        judge_claim_a(_tables({"3": {}}), [])


# --- folders: read through the gate, refused in words --------------------------------------------

QUICK = protocol_config("quick")


def _folder(tmp_path: Path, tables: dict[str, pd.DataFrame] | None = None) -> Path:
    """A protocol folder of the quick plan with a hand-made report (no cells)."""
    folder = tmp_path / "run"
    folder.mkdir()
    write_protocol_record(folder, QUICK)
    (folder / "report").mkdir()
    if tables is None:
        groups = {"3": {("cmaes", "random"): (0.1, False)}, "5": {}, "8": {}, "all": {}}
        tables = _tables(groups, n=6)
    for name, frame in tables.items():
        frame.to_csv(folder / "report" / name, index=False)
    return folder


def test_a_folders_report_becomes_the_pages_section(tmp_path: Path) -> None:
    folder = _folder(tmp_path)
    claim = protocol_claim(folder, check=False)
    assert claim.lines[0] == PROTOCOL_HEADING
    assert claim.verdict.startswith("**not shown** at any dimension (d = 3: not shown; ")
    text = "\n".join(claim.lines)
    assert "size `quick`: 6 instances (6 public, 0 held out) x d = 3, 5, 8" in text
    assert (
        "| 3 | random | +0.1 [0.09, 0.11] | 1 | 1 | -100 [-110, -90] (floor 50) | yes | no | inf "
        "| 30 |" in text
    )
    assert "- **Verdict, d = 3** (told apart: Holm p < 0.01 on the ECDF area AND" in text
    assert "| all | 6 (d blocks averaged) |" in text  # 6 instances, not 6 blocks
    assert claim.made_by == (
        f"tooldesign bench protocol --size quick --with-references --out {folder}",
    )


def test_a_linked_or_missing_table_and_another_runs_report_are_refused(tmp_path: Path) -> None:
    folder = _folder(tmp_path)
    ranks = folder / "report" / "ranks.csv"
    elsewhere = tmp_path / "ranks.csv"
    ranks.rename(elsewhere)
    with pytest.raises(
        FileNotFoundError, match=r"ranks.csv is missing: .*tooldesign bench protocol"
    ):
        protocol_claim(folder, check=False)
    ranks.symlink_to(elsewhere)
    with pytest.raises(ValueError, match="symbolic link"):
        protocol_claim(folder, check=False)
    ranks.unlink()
    frame = pd.read_csv(elsewhere)
    frame.loc[frame["optimizer"] == "pso", "optimizer"] = "nevergrad"
    frame.to_csv(ranks, index=False)
    with pytest.raises(ValueError, match="the report is of another run"):
        read_claim_tables(folder)


def test_a_users_report_merged_with_a_baseline_is_neither_judged_nor_overwritten(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # bench protocol --optimizer mine --baseline BUILTINS writes a report of both into the
    # user's folder, whose protocol.json records the user's optimizer alone.
    folder = _folder(tmp_path)
    write_protocol_record(folder, QUICK.replace(optimizers=("random",)))
    with pytest.raises(ValueError, match=r"merged with other run folders' \(bo, cmaes, pso:"):
        read_claim_tables(folder)
    before = (folder / "report" / "ranks.csv").read_bytes()
    results = tmp_path / "results"
    results.mkdir()
    with pytest.raises(SystemExit) as refused:
        main(["reproduce", "--results", str(results), "--protocol", str(folder),
              "--out", str(tmp_path / "page.md")])  # fmt: skip
    assert refused.value.code == 2
    assert "point --protocol at the built-ins' run folder" in capsys.readouterr().err
    assert (folder / "report" / "ranks.csv").read_bytes() == before


def test_a_table_with_bad_values_is_refused(tmp_path: Path) -> None:
    folder = _folder(tmp_path)
    path = folder / "report" / "comparisons.csv"
    frame = pd.read_csv(path)
    frame["significant"] = frame["significant"].astype(str)
    frame.loc[0, "significant"] = "maybe"
    frame.to_csv(path, index=False)
    with pytest.raises(ValueError, match="column 'significant' holds 'maybe'"):
        protocol_claim(folder, check=False)
    frame.drop(columns="d").to_csv(path, index=False)
    with pytest.raises(ValueError, match=r"lacks the columns \['d'\]"):
        protocol_claim(folder, check=False)


def test_a_report_without_the_cells_it_came_from_is_refused(tmp_path: Path) -> None:
    # The check computes the report again from the cells: a folder with none cannot be trusted.
    with pytest.raises(ValueError, match="has no results: run the protocol"):
        protocol_claim(_folder(tmp_path))


def test_a_folder_that_is_not_a_protocol_run_is_refused(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="is not a folder"):
        protocol_claim(tmp_path / "absent")
    with pytest.raises(ValueError, match="is not a protocol run folder"):
        protocol_claim(tmp_path)


@pytest.mark.parametrize("kind", ["absent", "file", "empty", "results"])
def test_reproduce_refuses_a_bad_protocol_option_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], kind: str
) -> None:
    results = tmp_path / "results"
    results.mkdir()
    given = {
        "absent": tmp_path / "absent",
        "file": tmp_path / "file.txt",
        "empty": tmp_path / "empty",
        "results": results,
    }[kind]
    if kind == "file":
        given.write_text("not a folder\n")
    if kind == "empty":
        given.mkdir()
    page = tmp_path / "page.md"
    args = ["reproduce", "--results", str(results), "--skip-reports", "--out", str(page)]
    with pytest.raises(SystemExit) as refused:
        main([*args, "--protocol", str(given)])
    assert refused.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    expected = "is not a folder" if kind in ("absent", "file") else "not a protocol run folder"
    assert expected in err and str(given) in err
    assert not page.exists()


def test_a_default_protocol_folder_that_is_a_file_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    results = tmp_path / "results"
    results.mkdir()
    (results / PROTOCOL_FOLDER).write_text("not a folder\n")
    with pytest.raises(SystemExit):
        main(
            ["reproduce", "--results", str(results), "--skip-reports", "--out", str(tmp_path / "p")]
        )
    err = capsys.readouterr().err
    assert f"the default protocol folder {results / PROTOCOL_FOLDER} is not a folder" in err


def test_the_page_is_not_made_without_judging_a_protocol_run_it_has(tmp_path: Path) -> None:
    (tmp_path / PROTOCOL_FOLDER).mkdir()
    with pytest.raises(ValueError, match="holds a protocol run, which claim .a. must be judged"):
        reproduction_page(tmp_path)


# --- a real smoke run -----------------------------------------------------------------------------


def _csv(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def _g(text: str, digits: int) -> str:
    value = float(text)
    if math.isnan(value):
        return "n/a"
    return "inf" if math.isinf(value) else format(value, f".{digits}g")


@pytest.fixture(scope="module")
def reported(protocol_smoke: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the smoke run with the report its own command writes."""
    copy = tmp_path_factory.mktemp("claims") / "smoke"
    shutil.copytree(protocol_smoke, copy)
    args = ["bench", "protocol", "--size", "smoke", "--executor", "serial", "--no-progress"]
    assert main([*args, "--out", str(copy)]) == 0  # resumes: no work, the report written
    return copy


@pytest.mark.slow
def test_the_pages_section_has_the_numbers_of_the_protocols_own_report(
    reported: Path, tmp_path: Path
) -> None:
    page = tmp_path / "page.md"
    args = ["reproduce", "--results", str(RESULTS), "--skip-reports", "--out", str(page)]
    assert main([*args, "--protocol", str(reported)]) == 0
    text = page.read_text(encoding="utf-8")
    section = text.split(PROTOCOL_HEADING + "\n", 1)[1].split("\n## ", 1)[0]
    report = reported / "report"
    comparisons = _csv(report / "comparisons.csv")
    power = _csv(report / "power.csv")
    assert {row["d"] for row in comparisons} == {"3", "5", "all"}
    for row in comparisons:  # smoke has one pair: cmaes against random
        assert (row["a"], row["b"]) == ("cmaes", "random")
        sign = "+" if float(row["mean_diff"]) > 0 else ""
        pw = next(p for p in power if p["d"] == row["d"] and p["measure"] == "score")
        expected = (
            f"| {row['d']} | random | {sign}{_g(row['mean_diff'], 3)} "
            f"[{_g(row['ci_low'], 3)}, {_g(row['ci_high'], 3)}] | {_g(row['d_z'], 3)} | "
            f"{_g(row['p_holm'], 3)} | {'+' if float(row['f_diff']) > 0 else ''}"
            f"{_g(row['f_diff'], 3)} [{_g(row['f_diff_low'], 3)}, {_g(row['f_diff_high'], 3)}] "
            f"(floor {_g(row['floor'], 3)}) | {'no' if row['beyond_floor'] == 'False' else 'yes'} "
            f"| {'no' if row['told_apart'] == 'False' else 'yes'}"
        )
        assert expected in section, expected
        assert f"| {_g(pw['detectable'], 3)} |" in section.split(expected, 1)[1].split("\n")[0]
    for group in ("3", "5", "all"):
        ranked = sorted(
            (r for r in _csv(report / "ranks.csv") if r["d"] == group), key=lambda r: int(r["rank"])
        )
        cell = ", ".join(
            f"{r['optimizer']} {_g(r['mean'], 3)} ({_g(r['P(rank 1)'], 2)})" for r in ranked
        )
        assert f" | {cell} | **not shown**: with " in section, cell
        refs = pd.DataFrame(_csv(report / "references.csv"))
        refs = refs[(refs["d"] == group) | (group == "all")].astype({"noise floor": float})
        # The group's one floor: pooled, the median of the instances' means over their d.
        floors = refs.groupby("instance")["noise floor"].mean().tolist()
        min_n = next(p["min_n"] for p in power if p["d"] == group)
        blocks = next(r["n"] for r in comparisons if r["d"] == group)
        floor = format(float(pd.Series(floors).median()), ".4g")
        assert f"| {group} | {blocks} ({min_n}) | none (inf) | none (inf) | {floor} |" in section
    # Smoke's two instances cannot separate any pair, as its report says for each group.
    assert (report / "report.md").read_text().count("This section cannot separate any pair") == 3
    assert section.count("no pair can be told apart") == 3
    row = next(line for line in text.splitlines() if line.startswith(PROTOCOL_ROW))
    assert row.endswith("| **not shown** at any dimension (d = 3: not shown; d = 5: not shown; "
                        "pooled: not shown) |")  # fmt: skip
    assert "| (a) CMA-ES lowers F fastest, 10 seeds of the `optimizers` suite" in text
    assert f"tooldesign bench protocol --size smoke --with-references --out {reported}" in text


@pytest.mark.slow
def test_a_tampered_report_or_cell_is_refused(reported: Path, tmp_path: Path) -> None:
    copy = tmp_path / "copy"
    shutil.copytree(reported, copy)
    assert protocol_claim(copy).verdict.startswith("**not shown**")  # as written: accepted
    path = copy / "report" / "comparisons.csv"
    frame = pd.read_csv(path, dtype={"d": str})
    frame.loc[0, "mean_diff"] += 0.5
    frame.to_csv(path, index=False)
    with pytest.raises(ValueError, match=r"comparisons.csv is not what the run's cells and refer"):
        protocol_claim(copy)
    # A cell's stored results changed: refused by its manifest's checksums.
    shutil.rmtree(copy)
    shutil.copytree(reported, copy)
    part = next(
        p
        for p in sorted((copy / "cells" / "d3" / "i01").rglob("*"))
        if "parts" in p.parts and p.is_file()
    )
    part.write_bytes(part.read_bytes() + b"\n")
    with pytest.raises(ValueError, match=part.name):
        protocol_claim(copy)


@pytest.mark.slow
def test_reproduce_judges_the_default_folder_and_writes_its_report_first(
    reported: Path, tmp_path: Path
) -> None:
    results = tmp_path / "results"
    results.mkdir()
    for suite in ("optimizers", "robustness"):
        shutil.copytree(RESULTS / suite, results / suite)
    folder = results / PROTOCOL_FOLDER
    shutil.copytree(reported, folder)
    # An edited table is written again from the cells (the suites' reports are too).
    path = folder / "report" / "ranks.csv"
    path.write_text(path.read_text().replace("cmaes", "cmaes2"))
    page = tmp_path / "page.md"
    assert main(["reproduce", "--results", str(results), "--out", str(page)]) == 0
    text = page.read_text(encoding="utf-8")
    assert "cmaes2" not in path.read_text()
    assert f"`docs/results/{PROTOCOL_FOLDER}/report/report.md`" in text
    assert f"--out docs/results/{PROTOCOL_FOLDER}" in text
    row = next(line for line in text.splitlines() if line.startswith(PROTOCOL_ROW))
    assert "| **not shown** at any dimension" in row
    # Without a protocol folder the page says the claim is not tested there, and how to test it.
    shutil.rmtree(folder)
    assert main(["reproduce", "--results", str(results), "--skip-reports", "--out", str(page)]) == 0
    text = page.read_text(encoding="utf-8")
    row = next(line for line in text.splitlines() if line.startswith(PROTOCOL_ROW))
    assert "| **not tested**: no protocol run folder" in row
    section = text.split(PROTOCOL_HEADING + "\n", 1)[1]
    assert "tooldesign bench protocol --size full --with-references --out docs/results/" in section


def test_every_table_the_judgement_reads_is_one_the_report_writes() -> None:
    source = inspect.getsource(make_protocol_report)
    for name in CLAIM_TABLES:
        assert f'"{name}"' in source, name
