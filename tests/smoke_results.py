"""The committed smoke results, and the run folders they must be reproduced from bit for bit.

``tests/fixtures/smoke-results.json.gz`` holds every number that the four paper suites at size
``smoke`` and one small ``tooldesign design`` run store: evaluations, final designs, robustness
tests and report tables. Wall times, dates, versions and paths are left out; every float is kept
as its ``repr``, so two runs match only if they agree to the last bit.

``tests/test_smoke_reproduction.py`` reruns them and compares. The last bits depend on the
platform (``tests/platforms.py``), so the fixture keeps one set per platform. Record this
platform's set (with the code before a change to be checked, or after a change that is *meant*
to move numbers, and say so in the commit) with::

    python tests/smoke_results.py --write

After a change meant to move the numbers, ``--write --drop-others`` keeps this platform's set
alone: the others hold the old numbers, and a platform without a set skips the comparison
(saying how to record one). The sets of the 13-link arm were dropped so when the hand was merged
into the last arm link by default (2026-11-25). When every evaluation gained ``final_height``
and ``final_tilt`` (2026-11-27), the AMD EPYC set was recorded again (without those two it
equals its old set to the bit: no number moved) and the Intel Xeon set was kept as it was: a
set recorded before the two values existed is compared on the keys it holds
(:func:`comparable`), so that platform keeps its bit-for-bit check of everything else.
"""

from __future__ import annotations

import argparse
import gzip
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pandas as pd
from platforms import platform_id

FIXTURE = Path(__file__).parent / "fixtures" / "smoke-results.json.gz"
SUITES = ("optimizers", "precision-sweep", "robustness", "mass-perturbation")
DESIGN_ARGS = ("--iterations", "2", "--batch-size", "4", "--seed", "3", "--no-video")
_DROPPED_KEYS = ("config", "packages", "git_commit", "git_dirty", "files", "run_folder", "command")


def _dropped(key: str) -> bool:
    return "time" in key or key in _DROPPED_KEYS


def _exact(value: Any) -> Any:
    """Floats as their repr (bit-exact in JSON), containers recursively, volatile keys dropped."""
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, dict):
        return {k: _exact(v) for k, v in sorted(value.items()) if not _dropped(str(k))}
    if isinstance(value, list):
        return [_exact(v) for v in value]
    return value


def _table(path: Path) -> list[dict[str, Any]]:
    frame = pd.read_csv(path, keep_default_na=False, dtype=str)
    frame = frame[[c for c in frame.columns if not _dropped(c)]]
    return [dict(row) for row in frame.sort_values(list(frame.columns)).to_dict("records")]


def canonical(folder: Path) -> dict[str, Any]:
    """Every stored number of a run folder, keyed by the file's path inside it."""
    out: dict[str, Any] = {}
    parts = sorted(folder.glob("parts/**/*.csv"))
    if parts:
        rows = [row for part in parts for row in _table(part)]
        out["parts"] = sorted(rows, key=lambda r: json.dumps(r, sort_keys=True))
    for path in sorted(folder.glob("report/*.csv")) + sorted(folder.glob("evaluations.csv")):
        out[path.relative_to(folder).as_posix()] = _table(path)
    for path in sorted(folder.glob("designs/**/*.json")) + sorted(folder.glob("*.json")):
        if path.name == "manifest.json":
            continue
        out[path.relative_to(folder).as_posix()] = _exact(json.loads(path.read_text()))
    return out


def run_all(root: Path, workers: int = 1) -> dict[str, Any]:
    """Run the four smoke suites and the design run under ``root``; their canonical numbers."""
    results: dict[str, Any] = {}
    common = ["--workers", str(workers), "--no-progress"]
    for suite in SUITES:
        out = root / suite
        cmd = [sys.executable, "-m", "benchmarks", suite, "--size", "smoke", "--out", str(out)]
        subprocess.run(cmd + common, check=True, capture_output=True, text=True)
        results[suite] = canonical(out)
    out = root / "design"
    cmd = [sys.executable, "-c", "from benchmarks.cli import main; import sys; sys.exit(main())"]
    subprocess.run(
        [*cmd, "design", *DESIGN_ARGS, "--out", str(out), *common],
        check=True,
        capture_output=True,
        text=True,
    )
    results["design"] = canonical(out)
    return results


#: Values every evaluation stores since 2026-11-27; sets recorded before lack them.
STANDING_KEYS = ("final_height", "final_tilt")

#: Keys a design run writes since later on 2026-11-27: every evaluation's ``success`` (a
#: column of the log), and in ``design.json`` the best design's ``success``, the lowest-F
#: succeeding design (``best_succeeding``) and the counts (``succeeded``, ``success_unknown``).
#: They are read from the stored final pose, so no number a recorded set holds moved.
SUCCESS_KEYS = ("success", "best_succeeding", "succeeded", "success_unknown")

#: The mass-perturbation report's columns ``success_m<mass>`` (the same day): whether the box
#: ends within the tolerance at each box mass, from the stored box paths.
MASS_SUCCESS_PREFIX = "success_m"


def _keys(value: Any) -> set[str]:
    """Every key of the dicts nested in ``value``."""
    if isinstance(value, dict):
        return {str(k) for k in value} | {k for v in value.values() for k in _keys(v)}
    if isinstance(value, list):
        return {k for v in value for k in _keys(v)}
    return set()


def _without(value: Any, keys: tuple[str, ...]) -> Any:
    if isinstance(value, dict):
        return {k: _without(v, keys) for k, v in value.items() if k not in keys}
    if isinstance(value, list):
        return [_without(v, keys) for v in value]
    return value


def _holds(value: Any, key: str) -> bool:
    if isinstance(value, dict):
        return key in value or any(_holds(v, key) for v in value.values())
    if isinstance(value, list):
        return any(_holds(v, key) for v in value)
    return False


def comparable(fresh: Any, recorded: Any) -> Any:
    """``fresh`` as ``recorded`` can be compared with it: without the keys recorded sets of
    before lacked (:data:`STANDING_KEYS`, :data:`SUCCESS_KEYS`), each one that ``recorded``
    does not hold anywhere."""
    added = {*STANDING_KEYS, *SUCCESS_KEYS} | {
        k for k in _keys(fresh) if k.startswith(MASS_SUCCESS_PREFIX)
    }
    missing = tuple(sorted(k for k in added if not _holds(recorded, k)))
    return _without(fresh, missing) if missing else fresh


def read_variants() -> dict[str, dict[str, Any]]:
    """The committed smoke results, one set per platform (``platform_id``)."""
    with gzip.open(FIXTURE, "rt", encoding="utf-8") as f:
        variants: dict[str, dict[str, Any]] = json.load(f)["variants"]
    return variants


def read_fixture() -> dict[str, Any] | None:
    """The committed smoke results of this platform, or None when it has none."""
    return read_variants().get(platform_id())


def main() -> None:
    """Write the fixture (``--write``) from fresh runs in a temporary folder."""
    import tempfile

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="overwrite the committed fixture")
    parser.add_argument("--from", dest="source", type=Path, help="use existing run folders")
    parser.add_argument(
        "--drop-others",
        action="store_true",
        help="with --write, keep this platform's set alone: after a change meant to move the "
        "numbers, the sets of other platforms hold the old ones (a platform with no set skips)",
    )
    args = parser.parse_args()
    if args.source is not None:
        results = {name: canonical(args.source / name) for name in (*SUITES, "design")}
    else:
        with tempfile.TemporaryDirectory() as tmp:
            results = run_all(Path(tmp))
    variants = read_variants() if FIXTURE.exists() and not args.drop_others else {}
    if args.write:
        variants[platform_id()] = results
        text = json.dumps({"variants": variants}, sort_keys=True, indent=0)
        FIXTURE.parent.mkdir(parents=True, exist_ok=True)
        with gzip.GzipFile(FIXTURE, "wb", mtime=0) as f:
            f.write(text.encode())
        print(f"wrote the results of {platform_id()} to {FIXTURE} ({FIXTURE.stat().st_size} bytes)")
    else:
        same = results == variants.get(platform_id())
        print("identical to the committed smoke results" if same else "DIFFERENT")
        sys.exit(0 if same else 1)


if __name__ == "__main__":
    main()
