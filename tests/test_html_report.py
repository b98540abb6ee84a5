"""The self-contained HTML report: everything embedded, and nothing broken in a real browser."""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import subprocess

import numpy as np
import pytest
from PIL import Image

from benchmarks.cli import main
from benchmarks.reports.html import REPORT_FILE, write_html_report
from benchmarks.storage.manifest import FILE_CHECKSUMS
from benchmarks.storage.runfolder import record_report_files

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")

# Injected into a copy of the report: record script errors from the start, and after load list
# the images that did not decode, into a div that --dump-dom prints.
PROBE_HEAD = (
    "<script>window.__errors=[];window.addEventListener('error',function(e){"
    "window.__errors.push(String(e.message||(e.target&&e.target.alt)||'error'))},true);</script>"
)
PROBE_TAIL = (
    "<script>window.addEventListener('load',function(){var bad=[];"
    "for(var i=0;i<document.images.length;i++){var im=document.images[i];"
    "if(!im.complete||im.naturalWidth===0)bad.push(im.alt);}"
    "var d=document.createElement('div');d.id='__probe';d.textContent=JSON.stringify("
    "{images:document.images.length,broken:bad,errors:window.__errors});"
    "document.body.appendChild(d);});</script>"
)


def _run_folder(folder):
    """A folder shaped like a design run, with a suite-style report subfolder."""
    folder.mkdir()
    # A design run's manifest (no checksums: those are tested in test_run_folder_trust.py).
    (folder / "manifest.json").write_text(json.dumps({"extra": {"kind": "design"}}))
    rgb = (np.arange(40 * 30 * 3) % 255).astype(np.uint8).reshape(30, 40, 3)
    Image.fromarray(rgb).save(folder / "figure3.png")
    frames = [Image.fromarray(np.roll(rgb, k, axis=1)) for k in range(3)]
    frames[0].save(folder / "rollout.gif", save_all=True, append_images=frames[1:])
    (folder / "design.json").write_text(json.dumps({"free_energy": 4861.25, "valid": True}))
    (folder / "evaluations.csv").write_text("iteration,free_energy\n0,5000.5\n1,4861.25\n")
    (folder / "report").mkdir()
    Image.fromarray(rgb[::-1]).save(folder / "report" / "final_f.png")
    (folder / "report" / "summary.md").write_text("| optimizer | F |\n|---|---|\n| <b>x | 1 |\n")
    (folder / "parts").mkdir()
    (folder / "parts" / "iteration=000000.csv").write_text("secret,stored\n1,2\n")
    return folder


def test_report_embeds_every_figure_card_and_table(tmp_path):
    folder = _run_folder(tmp_path / "run")
    path = write_html_report(folder)
    assert path == folder / REPORT_FILE
    text = path.read_text()
    assert text.count("data:image/png;base64,") == 2 and text.count("data:image/gif;base64,") == 1
    assert "4861.25" in text and "5000.5" in text and "report/summary.md" in text
    assert "&lt;b&gt;x" in text  # file contents are escaped, not interpreted
    assert "secret" not in text  # stored results under parts/ are left out
    # The only script is inline (sorting and paging); nothing is loaded from anywhere.
    assert "<script src" not in text.replace(" ", " ")
    assert not re.search(r"""(src|href)=["']?(https?:|//|file:)""", text)
    write_html_report(folder)  # again: the earlier report is not embedded in the new one
    assert path.read_text() == text


def test_report_bad_input(tmp_path):
    with pytest.raises(FileNotFoundError):
        write_html_report(tmp_path / "absent")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="empty is not a run folder: it has no manifest.json"):
        write_html_report(tmp_path / "empty")
    (tmp_path / "empty" / "tool.urdf").write_text("<robot/>")
    with pytest.raises(ValueError, match="not a run folder"):  # half an evaluate folder
        write_html_report(tmp_path / "empty")


@pytest.mark.slow
def test_cli_prints_where_the_report_is(tmp_path, capsys):
    folder = _run_folder(tmp_path / "run")
    assert main(["html", str(folder)]) == 0
    assert f"report: {folder / REPORT_FILE}" in capsys.readouterr().out
    with pytest.raises(SystemExit) as excinfo:
        main(["html", str(tmp_path / "absent")])
    assert excinfo.value.code == 2


@pytest.mark.slow
def test_cli_refuses_an_out_that_is_a_folder_or_in_a_missing_folder_and_leaves_nothing(
    tmp_path, capsys
):
    # A folder gave "[Errno 21] Is a directory: '/tmp/o.tmp' -> '/tmp/o'" and left a 775 KB
    # /tmp/o.tmp; a missing folder named the internal x.html.tmp (an audit of issue 11).
    folder = _run_folder(tmp_path / "run")
    (tmp_path / "o").mkdir()
    cases = {
        tmp_path / "o": "is a folder",
        tmp_path / "nowhere" / "x.html": f"its folder {tmp_path / 'nowhere'} does not exist",
    }
    for out, message in cases.items():
        with pytest.raises(SystemExit) as excinfo:
            main(["html", str(folder), "--out", str(out)])
        assert excinfo.value.code == 2
        err = capsys.readouterr().err
        assert message in err and str(out) in err and ".tmp" not in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o", "run"]
    assert list((tmp_path / "o").iterdir()) == []
    assert not any(p.name.endswith(".tmp") for p in folder.rglob("*"))


def test_the_report_is_written_atomically_through_the_one_writer(tmp_path, monkeypatch):
    # html.py had a writer of its own: a fixed .tmp name, no fsync, nothing removed on failure.
    import benchmarks.reports.html as html_module

    written = []
    real = html_module.atomic_write_text

    def spy(path, text, **kwargs):
        written.append(path)
        return real(path, text, **kwargs)

    monkeypatch.setattr(html_module, "atomic_write_text", spy)
    folder = _run_folder(tmp_path / "run")
    assert write_html_report(folder) == folder / REPORT_FILE
    assert written == [folder / REPORT_FILE]


@pytest.mark.slow
def test_report_rebuilds_a_report_html_the_folder_has(tmp_path, capsys):
    # `tooldesign report DIR` rebuilt the figures but left report.html with the old ones (an
    # audit of issue 11).
    from pathlib import Path

    results = Path(__file__).resolve().parents[1] / "docs" / "results" / "robust-design"
    folder = tmp_path / "robust-design"
    shutil.copytree(results, folder)
    assert main(["report", str(folder)]) == 0
    assert "report.html" not in capsys.readouterr().out  # none to refresh: none is made
    assert not (folder / REPORT_FILE).exists()
    write_html_report(folder)
    (folder / "report" / "notes.md").write_text("written after the page")
    # As a report command writes it: recorded (an unrecorded one is left out of the page).
    record_report_files(folder, [folder / "report" / "notes.md"])
    assert main(["report", str(folder)]) == 0
    assert f"{folder / REPORT_FILE} rebuilt" in capsys.readouterr().out
    assert "written after the page" in (folder / REPORT_FILE).read_text()
    # Sent elsewhere with --out, the figures are not the page's: it stays as it was.
    before = (folder / REPORT_FILE).read_bytes()
    assert main(["report", str(folder), "--out", str(tmp_path / "elsewhere")]) == 0
    assert "rebuilt" not in capsys.readouterr().out
    assert (folder / REPORT_FILE).read_bytes() == before


def _browser_probe(report, tmp_path):
    browser = next((shutil.which(b) for b in BROWSERS if shutil.which(b)), None)
    if browser is None:
        pytest.skip("no headless Chromium installed (apt-get install chromium)")
    page = tmp_path / "probe.html"
    html = report.read_text()
    page.write_text(
        html.replace("<head>", "<head>" + PROBE_HEAD, 1).replace("</body>", PROBE_TAIL + "</body>")
    )
    out = subprocess.run(
        [
            browser,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--virtual-time-budget=10000",
            "--dump-dom",
            page.as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    found = re.findall(r'<div id="__probe">(.*?)</div>', out.stdout)
    assert found, f"the browser printed no probe result: {out.stderr[-500:]}"
    return json.loads(found[0].replace("&quot;", '"'))


@pytest.mark.slow
def test_report_opens_in_headless_chromium_with_nothing_broken(tmp_path):
    report = write_html_report(_run_folder(tmp_path / "run"))
    probe = _browser_probe(report, tmp_path)
    assert probe == {"images": 3, "broken": [], "errors": []}


@pytest.mark.slow
def test_the_browser_check_sees_a_broken_image(tmp_path):
    folder = _run_folder(tmp_path / "run")
    (folder / "figure3.png").write_bytes(b"\x89PNG\r\n\x1a\nnot really")
    probe = _browser_probe(write_html_report(folder), tmp_path)
    assert probe["broken"] == ["figure3.png"]


# --- a design run's page, as a person at a 1280 px window sees it ------------------------------

WIDTH, HEIGHT = 1280, 800
COLUMNS = (
    "suite,optimizer,seed,iteration,candidate,eval_id,c1,c2,c3,free_energy,goal_error,"
    "confidence,final_distance,status,eval_time,opt_time,best_so_far,goal_x,goal_y,goal_z,"
    "goal_precision,box_mass,variant"
)


def _design_folder(folder, *, straight=True, iterations=15, batch=8):
    """A design run folder as `tooldesign design` writes it (pictures are stand-ins)."""
    folder.mkdir()
    rng = np.random.default_rng(0)
    picture = (rng.random((675, 900, 3)) * 255).astype(np.uint8)
    for name in (
        "fig3a_tool_curves",
        "fig3b_free_energy",
        "fig3c_box_paths",
        "fig3d_final_tool",
        "figure3",
        "robustness",
    ):
        Image.fromarray(picture).save(folder / f"{name}.png")
    frames = [Image.fromarray(picture[:404, :480]) for _ in range(2)]
    frames[0].save(folder / "rollout.gif", save_all=True, append_images=frames[1:])
    lines, best = [COLUMNS], np.inf
    for k in range(iterations * batch):
        f = float(8000.0 + 5000.0 * rng.random())
        best = min(best, f)
        c = [float(v) for v in rng.uniform(-1.5, 1.5, 3)]
        distance, seconds = float(rng.random()), float(8 * rng.random())
        lines.append(
            f"design,cmaes,0,{k // batch},{k % batch},{k},{c[0]!r},{c[1]!r},{c[2]!r},{f!r},"
            f"{f + 1200.5!r},1200.5,{distance!r},ok,{seconds!r},0.000458,{best!r},"
            "0.0,1.5,0.1,20.0,0.1,"
        )
    (folder / "evaluations.csv").write_text("\n".join(lines) + "\n")
    config = {
        "batch_size": batch,
        "bounds": [[-1.5, 1.5], [-1.5, 1.5], [-0.5, 0.5]],
        "box_mass": 0.1,
        "estimator": "contact",
        "executor": "process",
        "goal": [0.0, 1.5, 0.1],
        "goal_precision": 20.0,
        "iterations": iterations,
        "max_retries": 0,
        "objective": "free-energy",
        "optimizer": "cmaes",
        "optimizer_settings": {},
        "robustness_masses": [0.3, 0.5, 0.7, 0.9],
        "scene": {"merge_fixed_links": True},
        "scene_samples": 1,
        "scheduler": None,
        "section_shape": "round",
        "seed": 0,
        "workers": None,
    }
    card = {
        "coefficients": [0.2046, -0.2876, 0.0759],
        "free_energy": 8030.25,
        "goal_error": 9230.75,
        "confidence": 1200.5,
        "final_distance": 0.0654,
        "status": "ok",
        "iteration": 14,
        "candidate": 2,
        "eval_id": 114,
        "format_version": 1,
        "polynomial": "y = c1 x^n + ... + cn x (highest power first, constant term 0)",
        "tool": {
            "mass": 0.224,
            "arc_length": 1.1,
            "handle_length": 0.15,
            "section": 0.03,
            "section_shape": "round",
            "min_radius_of_curvature": 1.36,
            "buildable": True,
        },
        "robustness": {
            "robustness": -224.0,
            "accuracy": -3100.2,
            "control_deviation": 20729.8,
            "masses": [0.3, 0.5, 0.7, 0.9],
        },
        "seed": 0,
        "config": config,
        "evaluations": {
            "total": iterations * batch,
            "iterations": iterations,
            "ok": iterations * batch,
            "invalid": 0,
            "failed": 0,
        },
        "packages": {"numpy": "2.4.6"},
        "git_commit": "062b3a0",
        "start_time": "2026-11-27T06:42:08+00:00",
        "end_time": "2026-11-27T06:43:40+00:00",
        "wall_time": 92.0,
        "simulation_time": 141.0,
        "optimizer_time": 0.05,
        "files": {},
    }
    if straight:
        card["straight_tool"] = {
            "coefficients": [0.0, 0.0, 0.0],
            "free_energy": 8610.93,
            "goal_error": 9488.91,
            "confidence": 877.98,
            "final_distance": 0.0615,
            "status": "ok",
            "message": "",
        }
    (folder / "design.json").write_text(json.dumps(card))
    path = [[1.17, 0.67 + 0.001 * t, 0.1] for t in range(100)]
    paths = {
        "iterations": list(range(iterations)),
        "iteration_bests": [path] * iterations,
        "nominal_mass": 0.1,
        "masses": [0.3, 0.5, 0.7, 0.9],
        "nominal": path,
        "perturbed": [path] * 4,
    }
    (folder / "box_paths.json").write_text(json.dumps(paths))
    robustness = {
        "robustness": -224.0,
        "accuracy": -3100.2,
        "control_deviation": 20729.8,
        "masses": [0.3, 0.5, 0.7, 0.9],
        "nominal_mass": 0.1,
        "goal": [0.0, 1.5, 0.1],
        "coefficients": card["coefficients"],
        "error": "",
    }
    (folder / "robustness.json").write_text(json.dumps(robustness))
    # The manifest records every file a design run writes, the evaluation log among them: the
    # report shows only files that match their checksums (docs/reliability.md, trust model).
    recorded = sorted(p.name for p in folder.iterdir())
    checksums = {
        name: hashlib.sha256((folder / name).read_bytes()).hexdigest() for name in recorded
    }
    manifest = {"extra": {"kind": "design", FILE_CHECKSUMS: checksums}}
    (folder / "manifest.json").write_text(json.dumps(manifest))
    return folder


@pytest.mark.slow
def test_a_design_report_leads_with_the_answer(tmp_path):
    text = write_html_report(_design_folder(tmp_path / "run")).read_text()
    summary = text.index('id="summary"')
    # The card comes first: F beside the straight tool's, the terms with units, robustness.
    for wanted in (
        "8,030",
        "8,611",
        "straight tool (C = 0)",
        "dimensionless",
        "final distance",
        "6.7 % lower (better)",
        "Robustness:",
        "mm</strong> from its nominal path",
    ):
        assert wanted in text[summary:], wanted
    order = [
        text.index(s)
        for s in ('id="summary"', "rollout.gif", "<h2>Settings", "<h2>Every evaluation")
    ]
    assert order == sorted(order)
    # Settings with units; the evaluation log whole, its constant columns said once.
    assert "0.1 kg" in text and "(0, 1.5, 0.1) m" in text and "wall time (elapsed)" in text
    assert text.count("<tr><td") >= 120 and "The same in every row: suite = design" in text
    assert 'data-page="25"' in text


@pytest.mark.slow
def test_a_design_report_of_a_run_without_the_straight_tool_says_so(tmp_path):
    text = write_html_report(_design_folder(tmp_path / "run", straight=False)).read_text()
    assert "was not evaluated for this run" in text and "straight tool (C = 0)</th>" not in text


def _browser():
    browser = next((shutil.which(b) for b in BROWSERS if shutil.which(b)), None)
    if browser is None:
        pytest.skip("no headless Chromium installed (apt-get install chromium)")
    return browser


# After load: where the summary ends, how wide the page and every table box are, and what the
# pager shows before and after a click on the F column.
LAYOUT_PROBE = (
    "<script>window.addEventListener('load',function(){"
    "var s=document.getElementById('summary').getBoundingClientRect();"
    "var boxes=[].map.call(document.querySelectorAll('table'),function(t){"
    "var b=t.closest('.tablebox')||t;var r=b.getBoundingClientRect();"
    "return {right:r.right,scroll:b.scrollWidth>b.clientWidth+1,"
    "sortable:t.classList.contains('sortable')};});"
    "var t=document.querySelector('table.sortable');var rows=[].slice.call(t.tBodies[0].rows);"
    "var shown=rows.filter(function(r){return r.style.display!=='none';}).length;"
    "var heads=[].slice.call(t.tHead.rows[0].cells);"
    "var col=heads.findIndex(function(h){return h.textContent.trim()==='F';});"
    "heads[col].click();"
    "var first=[].slice.call(t.tBodies[0].rows).filter(function(r){"
    "return r.style.display!=='none';}).map(function(r){return parseFloat(r.cells[col]"
    ".getAttribute('data-v'));});"
    "var d=document.createElement('div');d.id='__layout';d.textContent=JSON.stringify({"
    "height:window.innerHeight,width:window.innerWidth,summaryBottom:s.bottom,"
    "pageWidth:document.documentElement.scrollWidth,tables:boxes,shown:shown,"
    "rows:rows.length,sorted:first});document.body.appendChild(d);});</script>"
)


@pytest.mark.slow
def test_the_design_report_at_1280_px_in_headless_chromium(tmp_path):
    browser = _browser()
    report = write_html_report(_design_folder(tmp_path / "run"))
    page = tmp_path / "layout.html"
    page.write_text(report.read_text().replace("</body>", LAYOUT_PROBE + "</body>"))
    common = [
        browser,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--hide-scrollbars",
        f"--window-size={WIDTH},{HEIGHT}",
    ]
    out = subprocess.run(
        [*common, "--virtual-time-budget=10000", "--dump-dom", page.as_uri()],
        capture_output=True,
        text=True,
        timeout=120,
    )
    found = re.findall(r'<div id="__layout">(.*?)</div>', out.stdout)
    assert found, f"the browser printed no layout: {out.stderr[-500:]}"
    layout = json.loads(found[0].replace("&quot;", '"'))
    # The window's inner height: 800 px less what headless Chromium keeps for its frame.
    assert layout["width"] == WIDTH and 650 <= layout["height"] <= HEIGHT, layout
    assert layout["summaryBottom"] <= layout["height"], layout  # the answer is above the fold
    assert layout["pageWidth"] <= WIDTH, layout  # nothing widens the page
    assert all(t["right"] <= WIDTH for t in layout["tables"]), layout["tables"]
    # The 23-column log of 120 evaluations fits without scrolling, a page at a time.
    log = [t for t in layout["tables"] if t["sortable"]]
    assert log and not log[0]["scroll"], layout["tables"]
    assert (layout["rows"], layout["shown"]) == (120, 25)
    assert len(layout["sorted"]) == 25 and layout["sorted"] == sorted(layout["sorted"])
    # The screenshot a person would see first.
    shot = tmp_path / "report.png"
    subprocess.run(
        [*common, f"--screenshot={shot}", report.as_uri()], capture_output=True, timeout=120
    )
    with Image.open(shot) as image:
        assert image.size == (WIDTH, HEIGHT)
        assert len(np.unique(np.asarray(image.convert("L")))) > 10  # not a blank page


def test_a_suite_report_leads_with_its_summary_then_its_figures(tmp_path):
    folder = _run_folder(tmp_path / "run")
    (folder / "report" / "pairwise.md").write_text(
        "# Pairwise\n\n| a | b |\n|---|---|\n| x | y |\n"
    )
    for k in range(10):
        (folder / "report" / f"design-{k}.json").write_text(json.dumps({"k": k}))
    text = write_html_report(folder).read_text()
    order = [
        text.index(s)
        for s in (
            "report/summary.md",
            "<h2>Figures",
            "report/pairwise.md",
            "<h2>Tables",
            "<h2>Cards",
        )
    ]
    assert order == sorted(order)
    assert "<th>optimizer</th>" in text  # the Markdown table is a table, not text
    assert "12 JSON files</summary>" in text  # many cards (the manifest too): one fold
    assert "3 figures, 2 reports, 1 table, 12 cards" in text


def test_an_evaluate_report_leads_with_the_design_card(tmp_path):
    folder = tmp_path / "eval"
    folder.mkdir()
    Image.fromarray(np.zeros((30, 40, 3), np.uint8)).save(folder / "tool_shape.png")
    Image.fromarray(np.zeros((30, 40, 3), np.uint8)).save(folder / "box_path.png")
    terms = {
        "coefficients": [0.1, 0.2, 0.05],
        "free_energy": 8359.3,
        "goal_error": 9554.9,
        "confidence": 1195.6,
        "final_distance": 0.066,
        "valid": True,
        "goal": [0, 1.5, 0.1],
    }
    (folder / "terms.json").write_text(json.dumps(terms))
    (folder / "tool.urdf").write_text("<robot name='tool'/>\n")  # what marks an evaluate folder
    rows = "\n".join(f"{0.01 * k},{k},lower" for k in range(200))
    (folder / "trajectory.csv").write_text("time,box_x,phase\n" + rows + "\n")
    text = write_html_report(folder).read_text()
    assert text.index('id="summary"') < text.index("box_path.png") < text.index("trajectory.csv")
    assert "8,359" in text and "0.066" in text and "straight tool" not in text
    assert "<details><summary>trajectory.csv</summary>" in text  # thousands of rows: folded


def test_a_protocol_folder_gets_a_page_that_leads_with_its_report(tmp_path):
    # Issue 34: the benchmark protocol's page leads with its rankings and ECDFs, like a suite's;
    # the cells (a suite run folder each) and the IOHprofiler files are data, not the page.
    from benchmarks.protocol.suite import PROTOCOL_FILE
    from benchmarks.storage import runfolder
    from benchmarks.storage.runfolder import run_folder_kind

    folder = tmp_path / "protocol-run"
    (folder / "report").mkdir(parents=True)
    (folder / PROTOCOL_FILE).write_text(json.dumps({"size": "smoke"}))
    (folder / "report" / "report.md").write_text("# Protocol report\n\nranking: cmaes first\n")
    (folder / "report" / "power.csv").write_text("d,detectable\n3,inf\n")
    picture = np.zeros((30, 40, 3), np.uint8)
    Image.fromarray(picture).save(folder / "report" / "ecdf_d3.png")
    cell = folder / "cells" / "d3" / "i01"
    cell.mkdir(parents=True)
    (cell / "manifest.json").write_text(json.dumps({"extra": {"kind": "suite"}}))
    Image.fromarray(picture).save(cell / "fig.png")
    (folder / "ioh").mkdir()
    (folder / "ioh" / "IOHprofiler_f1.json").write_text("{}")
    assert run_folder_kind(folder) == "protocol"
    assert runfolder._PROTOCOL_FILE == PROTOCOL_FILE  # storage cannot import the protocol
    text = write_html_report(folder).read_text()
    assert text.index("report/report.md") < text.index("report/ecdf_d3.png")
    assert "ranking: cmaes first" in text and "tooldesign bench protocol" in text
    assert "cells/" not in text and "IOHprofiler_f1" not in text
