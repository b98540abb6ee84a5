"""The self-contained HTML report: everything embedded, and nothing broken in a real browser."""

from __future__ import annotations

import json
import re
import shutil
import subprocess

import numpy as np
import pytest
from PIL import Image

from benchmarks.cli import main
from benchmarks.reports.html import REPORT_FILE, write_html_report

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
    assert "<script" not in text and not re.search(r"""(src|href)=["']?(https?:|//|file:)""", text)
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
