"""A self-contained HTML report of a run folder: one file, opened without network or server.

``tooldesign html DIR`` (and every design run and ``tooldesign evaluate``, at the end) writes
``DIR/report.html``: the design card and the other JSON files of the folder as tables, the small
CSV tables, the Markdown reports as text, and every figure and video (PNG, GIF, SVG) embedded as
a base64 data URI. It has no script and loads nothing: it can be mailed or attached to an issue.
It works for a design run folder, an ``evaluate`` folder and a suite's run folder alike (the
suite's figures and tables are found in its subfolders; the stored results under ``parts/`` are
left out).
"""

from __future__ import annotations

import base64
import html
import io
import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from benchmarks.storage import atomic_write_text, read_run_file
from benchmarks.storage.atomic import check_file_target
from benchmarks.storage.runfolder import check_own_page, report_files

__all__ = ["REPORT_FILE", "write_html_report"]

REPORT_FILE = "report.html"
_IMAGES = {".png": "image/png", ".gif": "image/gif", ".svg": "image/svg+xml"}
_SKIP_DIRS = {"parts", "__pycache__", ".git"}
_MAX_CSV_ROWS = 60
_MAX_FILES = 400  # a suite folder has tens of figures; more means a wrong folder was given
_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 72em; color: #222; }
h1 { font-size: 1.6em; } h2 { font-size: 1.2em; margin-top: 2em; border-bottom: 1px solid #ccc; }
figure { display: inline-block; margin: 0.5em; vertical-align: top; max-width: 100%; }
figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.85em; color: #555; }
table { border-collapse: collapse; font-size: 0.85em; margin: 0.5em 0; }
td, th { border: 1px solid #ccc; padding: 0.2em 0.5em; text-align: right; }
th { background: #f4f4f4; } td.key { text-align: left; font-weight: 600; }
pre { background: #f7f7f7; padding: 0.8em; overflow-x: auto; font-size: 0.85em; }
"""


def _files(folder: Path) -> Iterator[Path]:
    """The folder's files, sorted, depth first, without stored results and earlier reports.

    Regular files inside the folder only, after the folder is checked against its manifest
    (:func:`benchmarks.storage.runfolder.report_files`, which warns about what it leaves out).
    """
    listed = report_files(folder, skip_dirs=_SKIP_DIRS, skip_names={REPORT_FILE})
    for relative in listed.files:
        yield folder / relative


def _image(path: Path, folder: Path) -> str:
    mime = _IMAGES[path.suffix.lower()]
    data = base64.b64encode(read_run_file(folder, path)).decode("ascii")
    name = html.escape(str(path.relative_to(folder)))
    return (
        f'<figure><img src="data:{mime};base64,{data}" alt="{name}">'
        f"<figcaption>{name}</figcaption></figure>"
    )


def _value(value: Any) -> str:
    if isinstance(value, float):
        return html.escape(f"{value:.6g}")
    if isinstance(value, (dict, list)):
        text = json.dumps(value)
        return html.escape(text if len(text) <= 200 else text[:200] + " ...")
    return html.escape(str(value))


def _json_table(path: Path, folder: Path) -> str:
    try:
        data = json.loads(read_run_file(folder, path).decode("utf-8"))
    except (OSError, ValueError) as error:
        return f"<p>{html.escape(path.name)}: not readable ({html.escape(str(error))})</p>"
    if not isinstance(data, dict):
        return f"<pre>{html.escape(json.dumps(data, indent=2)[:5000])}</pre>"
    rows = "".join(
        f'<tr><td class="key">{html.escape(str(k))}</td><td>{_value(v)}</td></tr>'
        for k, v in data.items()
    )
    name = html.escape(str(path.relative_to(folder)))
    return f"<h3>{name}</h3><table>{rows}</table>"


def _csv_table(path: Path, folder: Path) -> str:
    import pandas as pd

    name = html.escape(str(path.relative_to(folder)))
    try:
        frame = pd.read_csv(io.BytesIO(read_run_file(folder, path)), nrows=_MAX_CSV_ROWS + 1)
    except (OSError, ValueError) as error:
        return f"<p>{name}: not readable ({html.escape(str(error))})</p>"
    more = len(frame) > _MAX_CSV_ROWS
    table = frame.head(_MAX_CSV_ROWS).to_html(index=False, escape=True, float_format="%.6g")
    note = f"<p>first {_MAX_CSV_ROWS} rows; the file has more</p>" if more else ""
    return f"<h3>{name}</h3>{table}{note}"


def write_html_report(
    folder: str | os.PathLike[str], *, out: str | os.PathLike[str] | None = None
) -> Path:
    """Write the self-contained report of ``folder``.

    Args:
        folder: a run folder (design, evaluate or suite).
        out: the HTML file to write; default ``folder/report.html``.

    Returns:
        The path written.

    Raises:
        FileNotFoundError: ``folder`` is not a folder, or the folder of ``out`` does not exist.
        IsADirectoryError: ``out`` is a folder.
        NotADirectoryError: a file stands where the folder of ``out`` would be.
        ValueError: the folder is not a run folder of a known kind, holds no figure, table or
            card to report, or too many files, or a file differs from the checksum its
            ``manifest.json`` records for it (:meth:`benchmarks.storage.ResultStore.verify`),
            or the page to write exists and was not written by this function, or is a link
            (:func:`benchmarks.storage.runfolder.check_own_page`).
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise FileNotFoundError(f"{folder} is not a folder")
    # Before the folder is read: a wrong --out is named, not found after the work is done.
    target = Path(out) if out is not None else folder / REPORT_FILE
    check_file_target(target, parent_must_exist=out is not None)
    check_own_page(folder, target)  # a user's own report.html, or a link, is not overwritten
    files = list(_files(folder))  # a run folder that was tampered with is not shown
    if len(files) > _MAX_FILES:
        raise ValueError(f"{folder} has more than {_MAX_FILES} files: give a run folder")
    images = [p for p in files if p.suffix.lower() in _IMAGES]
    cards = [p for p in files if p.suffix == ".json"]
    tables = [p for p in files if p.suffix == ".csv"]
    texts = [p for p in files if p.suffix in (".md", ".txt")]
    if not (images or cards or tables or texts):
        raise ValueError(f"{folder} has no figure, table or card to report")
    title = html.escape(f"tooldesign report: {folder.resolve().name}")
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="generator" content="tooldesign html">',  # check_own_page looks for it
        f"<title>{title}</title><style>{_STYLE}</style></head><body>",
        f"<h1>{title}</h1>",
        f"<p>{len(images)} figures, {len(cards)} cards, {len(tables)} tables; made from the "
        "files of the folder, with everything embedded.</p>",
    ]
    if cards:
        parts.append("<h2>Cards</h2>")
        parts.extend(_json_table(p, folder) for p in cards)
    if images:
        parts.append("<h2>Figures and video</h2>")
        parts.extend(_image(p, folder) for p in images)
    if tables:
        parts.append("<h2>Tables</h2>")
        parts.extend(_csv_table(p, folder) for p in tables)
    for path in texts:
        name = html.escape(str(path.relative_to(folder)))
        text = read_run_file(folder, path).decode("utf-8", errors="replace")
        parts.append(f"<h2>{name}</h2><pre>{html.escape(text)}</pre>")
    parts.append("</body></html>\n")
    return atomic_write_text(target, "\n".join(parts))
