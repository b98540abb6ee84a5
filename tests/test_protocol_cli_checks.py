"""``tooldesign bench protocol`` refuses what its run or report would refuse, before a cell runs.

A mistyped ``--optimizer``, a ``--baseline`` of another plan or with the same optimizer,
references that lack the run's cells, and flags that another flag would silently ignore are
refused in one line naming the value, before ``protocol.json`` is written (review of issue 32,
findings 6, 7 and 9). Every refusal here comes before any simulation.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

import optimizers
from benchmarks.cli import main
from benchmarks.protocol import make_protocol_report, protocol_config, run_protocol
from benchmarks.protocol.suite import PROTOCOL_FILE, check_mergeable, read_protocol

ROOT = Path(__file__).resolve().parents[1]
QUICK = ROOT / "docs" / "results" / "protocol-quick"


def _refused(capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    """The one line ``tooldesign bench protocol ARGV`` exits with (code 2)."""
    with pytest.raises(SystemExit) as exited:
        main(["bench", "protocol", "--no-progress", *argv])
    assert exited.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


@pytest.mark.parametrize(
    ("name", "allowed"),
    [
        ("nosuch", ("available: ", "random")),  # an unknown registry name
        ("nosuchmod:Cls", ("--optimizer takes a registered name (", "random")),  # no import
        ("json:JSONDecoder", ("not an ask/tell optimizer", "optimizers.Optimizer subclass")),
    ],
)
def test_a_bad_optimizer_is_refused_before_protocol_json(capsys, tmp_path, name, allowed):
    out = tmp_path / "run"
    line = _refused(capsys, "--size", "quick", "--optimizer", name, "--out", str(out))
    assert f"--optimizer {name}: " in line and all(words in line for words in allowed), line
    assert not out.exists()  # no protocol.json: the corrected command is not blocked
    with pytest.raises((TypeError, ValueError), match=f"optimizer '{name}'"):
        run_protocol(protocol_config("smoke", optimizer=name), out, progress=False)
    assert not out.exists()


def test_make_refuses_a_class_that_is_not_an_optimizer():
    with pytest.raises(TypeError, match=r"json\.decoder\.JSONDecoder, not an ask/tell optimizer"):
        optimizers.make("json:JSONDecoder", bounds=np.array([[-1.0, 1.0]]), batch_size=2)


def test_a_record_left_by_a_refused_name_does_not_block_the_corrected_run(tmp_path, monkeypatch):
    # What versions before the check left: protocol.json of a name that cannot be made, alone.
    out = tmp_path / "run"
    out.mkdir()
    left = {"format": 1, "config": protocol_config("smoke", optimizer="nosuch").to_json()}
    (out / PROTOCOL_FILE).write_text(json.dumps(left))
    cells: list[Path] = []
    monkeypatch.setattr(
        "benchmarks.suites.run_suite", lambda config, folder, **kw: cells.append(Path(folder))
    )
    said: list[str] = []
    fixed = protocol_config("smoke", optimizer="random")
    run_protocol(fixed, out, progress=False, say=said.append)
    assert [o.name for o in read_protocol(out).optimizers] == ["random"]
    assert "replaced" in said[0] and "'nosuch'" in said[0]
    assert len(cells) == len(fixed.cells())
    # A record of a name that can be made, or one with anything run beside it, still blocks.
    for record, extra in ((protocol_config("smoke").to_json(), None), (left["config"], "x")):
        other = tmp_path / f"other-{extra}"
        other.mkdir()
        (other / PROTOCOL_FILE).write_text(json.dumps({"format": 1, "config": record}))
        if extra:
            (other / "cells").mkdir()
            (other / "cells" / "manifest.json").write_text("{}")
        with pytest.raises(ValueError, match="another configuration"):
            run_protocol(fixed, other, progress=False)


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        # finding 9: each pair used to ignore one flag without a word
        (
            ["--references", "--reference-file", "mine.json", "--out", "NEW.json"],
            "--references computes the references into --out NEW.json: no --reference-file "
            "mine.json",
        ),
        (
            ["--with-references", "--reference-file", "mine.json", "--out", "NEW"],
            "--reference-file mine.json measures against that file: give one",
        ),
        (["--buildable", "5", "--out", "NEW"], "at every degree and exits: no --size, --out"),
        (["--buildable", "5", "--verify-references"], "and exits: no --size, --verify-references"),
        (
            ["--references", "--max-retries", "1", "--out", "NEW.json"],
            "--max-retries 1 is for the runs' cells: --references evaluates without retries",
        ),
        (["--verify-references", "--max-retries", "1"], "only: no --max-retries"),
        # references the report would refuse after the run
        (["--reference-file", "NEW.json", "--out", "NEW"], "NEW.json does not exist"),
        # (The committed full references now hold every task's cells, so --tasks all is no
        # longer refused here; a references file lacking a task's cells is refused early in
        # test_protocol_tasks.py's test_with_references_extends_committed_push_only_references.)
    ],
    ids=lambda v: " ".join(v)[:40] if isinstance(v, list) else "",
)
def test_flags_that_would_be_ignored_or_fail_late_are_refused(capsys, tmp_path, argv, words):
    new = str(tmp_path / "new")
    argv = [a.replace("NEW", new) for a in argv]
    line = _refused(capsys, "--size", "quick", *argv)
    assert words.replace("NEW", new) in line, line
    assert not list(tmp_path.iterdir())  # nothing made: no folder, no protocol.json


def test_a_folder_kept_without_its_part_files_is_refused_before_protocol_json(tmp_path):
    out = tmp_path / "kept"
    config = protocol_config("smoke")
    record = json.dumps({"format": 1, "config": config.to_json()})
    (out / "cells" / "d3" / "i01").mkdir(parents=True)
    (out / PROTOCOL_FILE).write_text(record)
    manifest = {"extra": {"part_sha256": {"parts/x.csv": "0" * 64}}}
    (out / "cells" / "d3" / "i01" / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(ValueError, match=r"kept without its cells' part files .*tooldesign report"):
        run_protocol(config.replace(workers=1), out, progress=False)
    assert (out / PROTOCOL_FILE).read_text() == record  # not written again


@pytest.mark.slow  # reads the committed quick folder's 18 cells (a few seconds)
@pytest.mark.skipif(not (QUICK / PROTOCOL_FILE).is_file(), reason="no committed quick run")
def test_a_baseline_the_report_would_refuse_is_refused_before_the_run(capsys, tmp_path):
    out = tmp_path / "run"
    # The committed quick run has every task: a run beside it must have them too.
    beside = ("--tasks", "all", "--baseline", str(QUICK), "--out", str(out))
    line = _refused(capsys, "--size", "quick", "--optimizer", "cmaes", *beside)
    assert line.endswith(f"optimizer 'cmaes' is in both {out} and {QUICK}; give it another label")
    line = _refused(capsys, "--size", "full", "--optimizer", "random", *beside)
    plan = f"{QUICK} is a protocol run of another plan than {out} (they differ in instances,"
    assert plan in line
    assert not out.exists()
    # The report refuses with the same words: one rule (check_mergeable) for both.
    copy = tmp_path / "copy"
    shutil.copytree(QUICK, copy)
    with pytest.raises(ValueError, match=f"optimizer 'cmaes' is in both {QUICK} and {copy}"):
        make_protocol_report([QUICK, copy], tmp_path / "report")
    full = protocol_config("full", optimizer="x:Y")
    with pytest.raises(ValueError, match=r"another plan than A \(they differ in instances"):
        check_mergeable([("A", read_protocol(QUICK)), ("B", full)])


def test_check_mergeable_refuses_no_plan_and_a_plan_without_a_config() -> None:
    with pytest.raises(ValueError, match=r"plans must be a non-empty sequence .*got \[\]"):
        check_mergeable([])
    with pytest.raises(
        ValueError, match=r"a plan must be a \(folder, ProtocolConfig\) pair, got \('x', None\)"
    ):
        check_mergeable([("x", None)])  # type: ignore[list-item]
