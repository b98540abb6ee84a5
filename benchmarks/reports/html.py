"""A self-contained HTML report of a run folder: one file, opened without network or server.

``tooldesign html DIR`` (and every design run and ``tooldesign evaluate``, at the end) writes
``DIR/report.html``. The page leads with the answer and keeps the details below it:

- a design run folder: a summary card (the tool's picture; F, goal error, confidence and final
  distance beside the straight tool's, C = 0; the robustness test in one sentence), then the
  rollout video, the convergence and the box paths, then the settings grouped with their units,
  then the full evaluation log as a sortable, paginated table;
- an ``evaluate`` folder: the same card for the one evaluated design, then its figures;
- a suite's run folder: its Markdown reports (rankings, verdicts) rendered as tables, then its
  figures, then its tables and cards folded away.

Every figure and video (PNG, GIF, SVG) is embedded as a base64 data URI, and the little script
that sorts and pages the tables is inline: the page loads nothing, so it can be mailed or
attached to an issue, and without script it shows every row. It is laid out for a 1280 px
window; wide tables scroll inside their box instead of widening the page. The stored results
under ``parts/`` are left out.
"""

from __future__ import annotations

import base64
import contextvars
import csv
import html
import io
import json
import math
import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from benchmarks.storage import atomic_write_text, read_run_file
from benchmarks.storage.atomic import check_file_target
from benchmarks.storage.runfolder import (
    EVALUATE_KIND,
    PROTOCOL_KIND,
    ReportFiles,
    check_own_page,
    report_files,
)

__all__ = ["REPORT_FILE", "write_html_report"]

REPORT_FILE = "report.html"
_IMAGES = {".png": "image/png", ".gif": "image/gif", ".svg": "image/svg+xml"}
_SKIP_DIRS = {"parts", "__pycache__", ".git"}
_MAX_CSV_ROWS = 5000  # every row of a design run (K x B); a suite's big logs are Parquet
_PAGE_ROWS = 25
_MAX_FILES = 400  # a suite folder has tens of figures; more means a wrong folder was given

_STYLE = """
*, *::before, *::after { box-sizing: border-box; }
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 0 auto;
  padding: 1em 1.5em 3em; max-width: 78em; color: #222; line-height: 1.4; }
h1 { font-size: 1.5em; margin: 0.2em 0 0.1em; }
h2 { font-size: 1.2em; margin-top: 1.8em; border-bottom: 1px solid #ccc; }
h3 { font-size: 1.02em; margin: 1.2em 0 0.3em; }
.sub { color: #555; margin: 0 0 0.8em; }
.card { display: grid; grid-template-columns: minmax(0, 1.15fr) minmax(0, 1fr); gap: 1.2em;
  border: 1px solid #cfd8e3; border-radius: 8px; background: #f7fafd; padding: 0.9em 1.1em; }
.card img { width: 100%; max-height: 330px; object-fit: contain; background: #fff;
  border: 1px solid #ddd; }
.card table { font-size: 0.95em; width: 100%; }
.card td.num, .card th.num { font-variant-numeric: tabular-nums; }
.card .better { color: #16622d; font-weight: 600; }
.card .worse { color: #a12a1a; font-weight: 600; }
.verdict { margin: 0.6em 0 0.2em; }
.grid3 { display: grid; grid-template-columns: repeat(3, minmax(0, 1fr)); gap: 0.8em; }
.grid2 { display: grid; grid-template-columns: repeat(2, minmax(0, 1fr)); gap: 0.8em; }
figure { margin: 0; min-width: 0; }
figure img { width: 100%; height: auto; border: 1px solid #ddd; background: #fff; }
.loose figure { display: inline-block; vertical-align: top; width: calc(50% - 0.6em);
  margin: 0.3em; }
figcaption { font-size: 0.85em; color: #444; }
figcaption code { font-size: 0.95em; color: #777; }
.tablebox { max-width: 100%; overflow-x: auto; }
table { border-collapse: collapse; font-size: 0.85em; margin: 0.3em 0; }
td, th { border: 1px solid #d4d4d4; padding: 0.15em 0.4em; text-align: right; }
th { background: #f1f3f5; } td.key, th.key { text-align: left; font-weight: 600; }
td.text { text-align: left; }
table.sortable th { cursor: pointer; user-select: none; vertical-align: bottom; }
table.sortable td { white-space: nowrap; }
table.sortable th[aria-sort=ascending]::after { content: " \\25B2"; }
table.sortable th[aria-sort=descending]::after { content: " \\25BC"; }
.pager { font-size: 0.85em; margin: 0.2em 0 0.8em; }
.pager button { margin-right: 0.4em; }
.settings { display: grid; grid-template-columns: repeat(3, minmax(0, 1fr)); gap: 0 1.2em; }
.settings table { width: 100%; }
.note { font-size: 0.85em; color: #555; }
.unchecked { font-size: 0.8em; color: #8a4b00; background: #fff3e0; border: 1px solid #e0a060;
  border-radius: 3px; padding: 0 0.3em; font-family: system-ui, sans-serif; }
.unchecked-note { background: #fff3e0; border-left: 4px solid #e0a060; padding: 0.4em 0.8em; }
details { margin: 0.4em 0; } summary { cursor: pointer; font-weight: 600; }
pre { background: #f7f7f7; padding: 0.8em; overflow-x: auto; font-size: 0.85em;
  white-space: pre-wrap; word-break: break-word; }
@media (max-width: 900px) { .card, .grid3, .grid2, .settings { grid-template-columns: 1fr; } }
"""

# Sorts a table by a clicked header (numbers as numbers) and shows it a page at a time.
_SCRIPT = """
(function () {
  function cellValue(row, i) {
    var t = row.cells[i].getAttribute('data-v') || row.cells[i].textContent.trim();
    var n = parseFloat(t);
    return (t !== '' && isFinite(n) && /^[-+0-9.eE]+$/.test(t)) ? n : t.toLowerCase();
  }
  function setUp(table) {
    var body = table.tBodies[0], size = parseInt(table.getAttribute('data-page') || '0', 10);
    var rows = Array.prototype.slice.call(body.rows), page = 0, pager = null;
    function show() {
      var pages = size ? Math.max(1, Math.ceil(rows.length / size)) : 1;
      page = Math.min(page, pages - 1);
      rows.forEach(function (r, k) {
        r.style.display = (!size || Math.floor(k / size) === page) ? '' : 'none';
      });
      if (pager) {
        pager.querySelector('span').textContent = 'rows ' + (size ? page * size + 1 : 1) +
          '-' + (size ? Math.min(rows.length, (page + 1) * size) : rows.length) + ' of ' +
          rows.length;
        pager.querySelector('.prev').disabled = page === 0;
        pager.querySelector('.next').disabled = page >= pages - 1;
        pager.querySelector('.all').textContent = size ? 'show all' : 'show pages';
      }
    }
    if (size && rows.length > size) {
      var full = size;
      pager = document.createElement('div');
      pager.className = 'pager';
      pager.innerHTML = '<button class="prev">previous</button><button class="next">next' +
        '</button><button class="all"></button><span></span>';
      pager.querySelector('.prev').onclick = function () { page -= 1; show(); };
      pager.querySelector('.next').onclick = function () { page += 1; show(); };
      pager.querySelector('.all').onclick = function () {
        size = size ? 0 : full; page = 0; show();
      };
      table.parentNode.parentNode.insertBefore(pager, table.parentNode.nextSibling);
    } else { size = 0; }
    Array.prototype.forEach.call(table.tHead.rows[0].cells, function (th, i) {
      th.title = (th.title ? th.title + ': ' : '') + 'click to sort';
      th.onclick = function () {
        var up = th.getAttribute('aria-sort') !== 'ascending';
        Array.prototype.forEach.call(table.tHead.rows[0].cells, function (h) {
          h.removeAttribute('aria-sort');
        });
        th.setAttribute('aria-sort', up ? 'ascending' : 'descending');
        rows.sort(function (a, b) {
          var x = cellValue(a, i), y = cellValue(b, i);
          if (typeof x !== typeof y) { x = String(x); y = String(y); }
          return (x < y ? -1 : x > y ? 1 : 0) * (up ? 1 : -1);
        });
        rows.forEach(function (r) { body.appendChild(r); });
        page = 0; show();
      };
    });
    show();
  }
  Array.prototype.forEach.call(document.querySelectorAll('table.sortable'), setUp);
})();
"""

#: How the columns of the evaluation logs are shown: a label with its unit.
_COLUMNS: dict[str, str] = {
    "iteration": "iteration",
    "candidate": "candidate",
    "eval_id": "id",
    "free_energy": "F",
    "goal_error": "goal error",
    "confidence": "confidence",
    "final_distance": "final distance (m)",
    "status": "status",
    "eval_time": "eval. time (s)",
    "opt_time": "opt. time (s)",
    "best_so_far": "best F so far",
    "success": "success (1 yes, 0 no)",
    "goal_x": "goal x (m)",
    "goal_y": "goal y (m)",
    "goal_z": "goal z (m)",
    "goal_precision": "goal precision p^X",
    "box_mass": "box mass (kg)",
}


def _files(folder: Path) -> ReportFiles:
    """The folder's files the page may show, without stored results and earlier reports.

    Regular files inside the folder only, after the folder is checked against its manifest
    (:func:`benchmarks.storage.runfolder.report_files`, which warns about what it leaves out):
    a report file that differs from its record, or (in a folder that records its files) a file
    recorded nowhere, is left out; the files of an older folder that nothing records are
    shown, marked unchecked.
    """
    return report_files(
        folder,
        skip_dirs=_SKIP_DIRS,
        skip_names={REPORT_FILE},
        suffixes=(*_IMAGES, ".json", ".csv", ".md", ".txt"),
    )


_UNCHECKED: contextvars.ContextVar[frozenset[Path]] = contextvars.ContextVar(
    "unchecked", default=frozenset()
)
"""The files of the page being written that its folder's manifest does not record."""

_NOTE: contextvars.ContextVar[str] = contextvars.ContextVar("note", default="")
"""The page's warning about its unchecked files (:func:`_unchecked_note`), or ``""``."""

_UNCHECKED_MARK = (
    ' <span class="unchecked" title="its manifest records no checksum">unchecked</span>'
)


def _name(path: Path, folder: Path) -> str:
    """A file's name as the page shows it, marked when nothing checked it."""
    mark = _UNCHECKED_MARK if path in _UNCHECKED.get() else ""
    return _esc(path.relative_to(folder)) + mark


def _unchecked_note(unchecked: Sequence[str]) -> str:
    """The page's warning about the files shown unchecked (each is marked), or ``""``."""
    if not unchecked:
        return ""
    return (
        f'<p class="unchecked-note"><strong>{len(unchecked)} files below are unchecked</strong> '
        '(marked <span class="unchecked">unchecked</span>): the folder\'s manifest records no '
        "checksum for them, so nothing tells whether they are as the run wrote them. It was "
        "written before tooldesign recorded its report files, or by tooldesign evaluate, which "
        "writes no manifest; <code>tooldesign report</code> records the report's.</p>"
    )


_PROTOCOL_NOTE = (
    '<p class="note">Made from the report of a <code>tooldesign bench protocol</code> folder '
    "(its rankings, power and ECDFs first; the cells' own run folders and the IOHprofiler files "
    "are not embedded). The protocol records no checksums of its report's files; its "
    "references are checked against the SHA-256 in <code>protocol.json</code>.</p>"
)

_EVALUATE_NOTE = (
    '<p class="note">Made from the files of a <code>tooldesign evaluate</code> folder, which '
    "records no checksums: nothing on this page is checked against a manifest.</p>"
)


def _esc(value: Any) -> str:
    return html.escape(str(value))


def _num(value: Any, digits: int = 4) -> str:
    """A number for people: ``digits`` significant digits, thousands without an exponent."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return "n/a" if value is None else _esc(value)
    if not math.isfinite(value):
        return _esc(value)
    if value != 0 and 1e-3 <= abs(value) < 1e6:
        decimals = max(0, digits - 1 - int(math.floor(math.log10(abs(value)))))
        return f"{value:,.{decimals}f}"
    return f"{value:.{digits}g}"


def _image(path: Path, folder: Path, caption: str = "") -> str:
    mime = _IMAGES[path.suffix.lower()]
    data = base64.b64encode(read_run_file(folder, path)).decode("ascii")
    name = _name(path, folder)
    alt = _esc(path.relative_to(folder))
    text = f"{caption} <code>{name}</code>" if caption else f"<code>{name}</code>"
    return (
        f'<figure><img src="data:{mime};base64,{data}" alt="{alt}">'
        f"<figcaption>{text}</figcaption></figure>"
    )


def _value(value: Any) -> str:
    if isinstance(value, float):
        return _esc(f"{value:.6g}")
    if isinstance(value, (dict, list)):
        text = json.dumps(value)
        return _esc(text if len(text) <= 200 else text[:200] + " ...")
    return _esc(value)


def _json_table(path: Path, folder: Path) -> str:
    try:
        data = json.loads(read_run_file(folder, path).decode("utf-8"))
    except (OSError, ValueError) as error:
        return f"<p>{_esc(path.name)}: not readable ({_esc(error)})</p>"
    name = _name(path, folder)
    if not isinstance(data, dict):
        body = f"<pre>{_esc(json.dumps(data, indent=2)[:5000])}</pre>"
    else:
        rows = "".join(
            f'<tr><td class="key">{_esc(k)}</td><td class="text">{_value(v)}</td></tr>'
            for k, v in data.items()
        )
        body = f'<div class="tablebox"><table>{rows}</table></div>'
    return f"<details><summary>{name}</summary>{body}</details>"


def _read_csv(folder: Path, path: Path) -> tuple[list[str], list[list[str]], bool]:
    """Header, up to ``_MAX_CSV_ROWS`` rows, and whether the file has more."""
    text = read_run_file(folder, path).decode("utf-8", errors="replace")
    with io.StringIO(text, newline="") as stream:
        reader = csv.reader(stream)
        header = next(reader, [])
        rows: list[list[str]] = []
        for row in reader:
            if len(rows) == _MAX_CSV_ROWS:
                return header, rows, True
            rows.append(row)
    return header, rows, False


def _digits(column: str) -> int:
    """Significant digits a column of the logs is shown with (the full value sorts)."""
    if re.fullmatch(r"c\d+|final_distance", column):
        return 4
    if column.endswith("_time"):
        return 3
    return 6


def _cell(text: str, digits: int = 6) -> str:
    """A table cell; a number is shown with ``digits`` significant digits, sorted by its value."""
    try:
        number = float(text)
    except ValueError:
        return f'<td class="text">{_esc(text)}</td>'
    if text.strip().lower() in ("nan", "inf", "-inf", "") or not math.isfinite(number):
        return f"<td>{_esc(text)}</td>"
    shown = f"{number:.{digits}g}" if ("." in text or "e" in text.lower()) else text
    return f'<td data-v="{_esc(text)}">{_esc(shown)}</td>'


def _csv_table(path: Path, folder: Path, *, label: str = "") -> str:
    """A CSV file as a sortable, paginated table; columns equal in every row become one line."""
    name = _name(path, folder)
    try:
        header, rows, more = _read_csv(folder, path)
    except (OSError, csv.Error) as error:
        return f"<p>{name}: not readable ({_esc(error)})</p>"
    if not header:
        return f"<p>{name}: empty</p>"
    width = len(header)
    rows = [(row + [""] * width)[:width] for row in rows]
    constant = [i for i in range(width) if len(rows) > 1 and all(r[i] == rows[0][i] for r in rows)]
    shown = [i for i in range(width) if i not in constant] or list(range(width))
    heads = "".join(
        f'<th title="{_esc(header[i])}">{_esc(_COLUMNS.get(header[i], header[i]))}</th>'
        for i in shown
    )
    digits = [_digits(header[i]) for i in range(width)]
    body = "".join("<tr>" + "".join(_cell(r[i], digits[i]) for i in shown) + "</tr>" for r in rows)
    same = ", ".join(
        f"{_esc(_COLUMNS.get(header[i], header[i]))} = {_esc(rows[0][i] or '(empty)')}"
        for i in constant
        if i not in shown or len(shown) < width
    )
    cut = f" (the first {_MAX_CSV_ROWS}; the file has more)" if more else ""
    notes = [f"{len(rows)} rows{cut}; click a column to sort"]
    if same:
        notes.append(f"The same in every row: {same}")
    title = label or name
    return (
        f'<h3>{title}</h3><p class="note">{". ".join(notes)}. File: <code>{name}</code></p>'
        f'<div class="tablebox"><table class="sortable" data-page="{_PAGE_ROWS}">'
        f"<thead><tr>{heads}</tr></thead><tbody>{body}</tbody></table></div>"
    )


def _inline_md(text: str) -> str:
    text = _esc(text)
    text = re.sub(r"`([^`]+)`", r"<code>\1</code>", text)
    return re.sub(r"\*\*([^*]+)\*\*", r"<strong>\1</strong>", text)


def _markdown(text: str) -> str:
    """The Markdown the reports write (headings, paragraphs, lists, pipe tables) as HTML."""
    out: list[str] = []
    lines = text.splitlines()
    k = 0
    while k < len(lines):
        line = lines[k].rstrip()
        if line.startswith("|"):
            block = []
            while k < len(lines) and lines[k].lstrip().startswith("|"):
                block.append([c.strip() for c in lines[k].strip().strip("|").split("|")])
                k += 1
            rows = [r for r in block if not all(re.fullmatch(r":?-{2,}:?", c) for c in r if c)]
            if rows:
                head = "".join(f"<th>{_inline_md(c)}</th>" for c in rows[0])
                body = "".join(
                    "<tr>"
                    + "".join(
                        f'<td class="{"key" if i == 0 else "num"}">{_inline_md(c)}</td>'
                        for i, c in enumerate(r)
                    )
                    + "</tr>"
                    for r in rows[1:]
                )
                out.append(
                    f'<div class="tablebox"><table><thead><tr>{head}</tr></thead>'
                    f"<tbody>{body}</tbody></table></div>"
                )
            continue
        heading = re.match(r"(#{1,6})\s+(.*)", line)
        if heading:
            level = min(len(heading.group(1)) + 2, 6)
            out.append(f"<h{level}>{_inline_md(heading.group(2))}</h{level}>")
        elif re.match(r"\s*[-*]\s+", line):
            items = []
            while k < len(lines) and re.match(r"\s*[-*]\s+", lines[k]):
                item = re.sub(r"^\s*[-*]\s+", "", lines[k])
                items.append(f"<li>{_inline_md(item)}</li>")
                k += 1
            out.append(f"<ul>{''.join(items)}</ul>")
            continue
        elif line.strip():
            para = [line.strip()]
            while (
                k + 1 < len(lines)
                and lines[k + 1].strip()
                and not re.match(r"\s*(#|\||[-*]\s)", lines[k + 1])
            ):
                k += 1
                para.append(lines[k].strip())
            out.append(f"<p>{_inline_md(' '.join(para))}</p>")
        k += 1
    return "\n".join(out)


def _page(title: str, subtitle: str, body: Sequence[str]) -> str:
    head = (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        '<meta name="generator" content="tooldesign html">'  # check_own_page looks for it
        f"<title>{_esc(title)}</title><style>{_STYLE}</style></head><body>"
    )
    return "\n".join(
        [
            head,
            f"<h1>{_esc(title)}</h1>",
            f'<p class="sub">{subtitle}</p>',
            _NOTE.get(),
            *body,
            f"<script>{_SCRIPT}</script>",
            "</body></html>\n",
        ]
    )


def _read_json(folder: Path, path: Path) -> dict[str, Any] | None:
    """The JSON object of a run file, or None where it is absent, refused or not an object."""
    try:
        data = json.loads(read_run_file(folder, path).decode("utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _finite(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _number(value: Any) -> float | None:
    """``value`` as a float if it is a finite number (not a bool), else None."""
    return float(value) if _finite(value) else None


# --- the summary card -------------------------------------------------------------------------

#: The rows of the card: key, label, unit, whether lower is better.
_TERMS = (
    ("free_energy", "free energy F", "dimensionless", "F = goal error - confidence", True, 4),
    ("goal_error", "goal error", "dimensionless", "1/2 p^X |X_t - X^g|^2 over steps", True, 4),
    ("confidence", "control confidence", "dimensionless", "1/2 log|Pi_U| over steps", False, 4),
    ("final_distance", "final distance to goal", "m", "|X_T - X^g|", True, 3),
)


def _answer(design: Mapping[str, Any], straight: Mapping[str, Any]) -> str:
    """One sentence: F and the final distance against the straight tool's."""
    mine, theirs = _number(design.get("free_energy")), _number(straight.get("free_energy"))
    if mine is None or theirs is None or theirs == 0:
        return ""
    change = 100.0 * (mine - theirs) / abs(theirs)
    word = "lower (better)" if change < 0 else "higher (worse)"
    text = (
        f"<strong>F = {_num(mine)}</strong>, {abs(change):.1f} % {word} than the straight "
        f"tool's {_num(theirs)}"
    )
    near, far = _number(design.get("final_distance")), _number(straight.get("final_distance"))
    if near is not None and far is not None:
        text += f"; the box ends {_num(near, 3)} m from the goal (straight tool: {_num(far, 3)} m)"
    return text + "."


def _comparison(
    design: Mapping[str, Any], straight: Mapping[str, Any] | None, *, compare: bool = True
) -> str:
    """The card's table: each term of the design beside the straight tool's (if ``compare``)."""
    has_straight = straight is not None and straight.get("status") == "ok"
    head = '<tr><th class="key">quantity</th><th class="key">unit</th>'
    head += '<th class="num">this tool</th>'
    head += '<th class="num">straight tool (C = 0)</th></tr>' if has_straight else "</tr>"
    rows = []
    for key, label, unit, meaning, lower, digits in _TERMS:
        mine = _number(design.get(key))
        cells = f'<td class="num">{_num(mine, digits)}</td>'
        if has_straight:
            assert straight is not None
            theirs = _number(straight.get(key))
            verdict = ""
            if mine is not None and theirs is not None and mine != theirs:
                good = (mine < theirs) == lower
                verdict = "better" if good else "worse"
            cells = f'<td class="num {verdict}">{_num(mine, digits)}</td>'
            cells += f'<td class="num">{_num(theirs, digits)}</td>'
        better = "lower" if lower else "higher"
        rows.append(
            f'<tr><td class="key" title="{_esc(meaning)}; {better} is better">{_esc(label)}'
            f'</td><td class="text">{_esc(unit)}</td>{cells}</tr>'
        )
    table = f"<table><thead>{head}</thead><tbody>{''.join(rows)}</tbody></table>"
    if has_straight:
        assert straight is not None
        table = f'<p class="verdict">{_answer(design, straight)}</p>' + table
        table += (
            '<p class="note">F = goal error - confidence; lower F, goal error and distance and '
            "higher confidence are better. Green: better than the straight tool on the same "
            "task; red: worse.</p>"
        )
    elif straight is None and compare:
        table += (
            '<p class="note">The straight tool (C = 0) was not evaluated for this run '
            "(runs made before it was stored in design.json).</p>"
        )
    elif straight is not None:
        why = straight.get("message") or f"status {straight.get('status')}"
        table += f'<p class="note">The straight tool (C = 0) has no score here: {_esc(why)}.</p>'
    return table


def _robustness_sentence(card: Mapping[str, Any], paths: Mapping[str, Any] | None) -> str:
    """The robustness test of a design in one sentence, with its units."""
    rob = card.get("robustness") or {}
    value = _number(rob.get("robustness"))
    masses = [m for m in rob.get("masses") or [] if _finite(m)]
    nominal = (paths or {}).get("nominal_mass", card.get("config", {}).get("box_mass"))
    if value is None or not masses:
        error = (card.get("robustness_error") or "").strip()
        return "Robustness: not tested" + (f" ({_esc(error)})." if error else ".")
    mass_text = ", ".join(f"{m:g}" for m in masses)
    steps = len((paths or {}).get("nominal") or [])
    sentence = f"<strong>Robustness:</strong> with the box at {mass_text} kg"
    if _finite(nominal):
        sentence += f" instead of {nominal:g} kg"
    if steps:
        mean = abs(float(value)) / (len(masses) * steps)
        sentence += (
            f", the box's path stays on average <strong>{_num(1000.0 * mean, 3)} mm</strong> "
            f"from its nominal path (robustness {_num(float(value))} m: minus the distance "
            f"summed over {len(masses)} masses and {steps} control steps; 0 is perfect)"
        )
    else:
        sentence += (
            f", robustness = {_num(float(value))} m (minus the deviation from the nominal path "
            "summed over masses and control steps; 0 is perfect)"
        )
    goal = card.get("config", {}).get("goal")
    ends = [p[-1] for p in (paths or {}).get("perturbed") or [] if p]
    if ends and isinstance(goal, list) and len(goal) == 3:
        dists = [math.dist(e[:2], goal[:2]) for e in ends if len(e) >= 2]
        if dists:
            sentence += (
                f"; it ends {_num(min(dists), 2)}-{_num(max(dists), 2)} m from the goal (top view)"
            )
        sentence += _mass_success_text(card, paths or {}, goal)
    return sentence + "."


def _mass_success_text(card: Mapping[str, Any], paths: Mapping[str, Any], goal: list[Any]) -> str:
    """At how many altered masses the box ends at the goal by the task's test, or ""."""
    from benchmarks.reports.success import scene_of_config, success_criterion

    config = card.get("config") or {}
    name = config.get("task_name") or "push"
    try:
        criterion = success_criterion(str(name))
        scene = scene_of_config({**config, "task_name": name})
    except ValueError:  # a task of a plugin that is not installed here
        return ""
    masses, ends = paths.get("masses") or [], [p[-1] for p in paths.get("perturbed") or [] if p]
    if len(masses) != len(ends) or not all(len(e) == 3 and all(map(_finite, e)) for e in ends):
        return ""
    hits = [
        float(m)
        for m, e in zip(masses, ends, strict=True)
        # The paths store the box centre, not its tilt: the distance and the height are tested.
        if criterion.succeeded(math.dist(e, goal), float(e[2]), scene, final_tilt=None)
    ]
    which = f" ({', '.join(f'{m:g}' for m in hits)} kg)" if hits else ""
    return (
        f"; it succeeds (within {criterion.tolerance:g} m of the goal, at its resting height) "
        f"at {len(hits)} of {len(ends)} altered masses{which}"
    )


def _success_line(
    status: Any,
    distance: Any,
    task: Any,
    straight: Mapping[str, Any] | None = None,
    *,
    standing: Mapping[str, Any] | None = None,
    config: Mapping[str, Any] | None = None,
) -> str:
    """Whether the design succeeded on its task, from its stored status and final distance.

    ``config``: the run's stored config, whose ``scene`` overrides make the scene the env
    scored in (:func:`~benchmarks.reports.success.scene_of_config`): a taller box rests higher.

    ``standing``: an evaluation's ``terms.json``, which holds the env's own ``success`` (which
    also asks the box to stand, ``TaskDefinition.max_tilt`` and ``height_tolerance``) and
    ``final_tilt`` (rad) and ``final_height`` (m): a box within the radius that does not stand
    is then no success, as the env and ``tooldesign evaluate`` say; or a design run's
    ``design.json`` with the best row's ``final_height`` and ``final_tilt`` (no ``success``),
    judged by the task's test (:func:`~benchmarks.reports.success.design_succeeded`). A
    ``straight`` entry with them is judged so too; without them, by the distance alone.
    """
    from benchmarks.reports.success import design_succeeded, scene_of_config, success_criterion

    name = task if isinstance(task, str) and task else "push"
    try:
        criterion = success_criterion(name)
        scene = scene_of_config({**(config or {}), "task_name": name})
    except ValueError:  # a task of a plugin that is not installed here
        return f"<strong>Success:</strong> n/a (the task {_esc(name)} is not registered here)."
    tolerance = criterion.tolerance
    outcome = design_succeeded(status, _number(distance), tolerance)
    rule = f"within {tolerance:g} m of the goal, the {_esc(name)} task's tolerance"
    stands: bool | None = None  # whether the box stands, where the folder says
    if standing is not None and "success" in standing:  # the env's own flag (terms.json)
        stands = False if standing.get("success") is False else None
    elif standing is not None:  # a design record's stored height and tilt: the task's test
        stands = design_succeeded(
            status,
            _number(distance),
            criterion,
            _number(standing.get("final_height")),
            _number(standing.get("final_tilt")),
            scene=scene,
        )
    if outcome is None:
        text = f"<strong>Success:</strong> n/a (no final distance stored; success is {rule})"
    elif status != "ok":
        text = f"<strong>Success: no</strong> (the design is not usable; success is {rule})"
    elif outcome and standing is not None and stands is False:
        tilt, height = _number(standing.get("final_tilt")), _number(standing.get("final_height"))
        parts = [] if tilt is None else [f"its up axis {math.degrees(tilt):.1f} degrees off"]
        parts += [] if height is None else [f"its centre {height:.3f} m high"]
        how = ", ".join(parts)
        text = (
            f"<strong>Success: no</strong> (the box ends {_num(_number(distance), 3)} m from "
            f"the goal but does not stand{': ' + how if how else ''}; success is {rule}, "
            "standing)"
        )
    else:
        word = "yes" if outcome else "no"
        text = (
            f"<strong>Success: {word}</strong> (the box ends {_num(_number(distance), 3)} m "
            f"from the goal; success is {rule})"
        )
    if straight is not None:
        theirs = design_succeeded(
            straight.get("status"),
            _number(straight.get("final_distance")),
            criterion,
            _number(straight.get("final_height")),
            _number(straight.get("final_tilt")),
            scene=scene,
        )
        text += "; the straight tool: " + {True: "yes", False: "no", None: "n/a"}[theirs]
    return text + "."


def _evaluations_success_line(
    folder: Path, log: Path | None, card: Mapping[str, Any], config: Mapping[str, Any]
) -> str:
    """How many of a design run's evaluations succeed, and the lowest-F one that does.

    From the evaluation log (its ``success`` column, or for a log stored before it, each row's
    stored final pose judged by the task's test in the run's scene), so a folder made before
    the column existed shows it too. Without a log: the card's counts, where it has them.
    """
    import pandas as pd

    from benchmarks.reports.success import (
        EvaluationSuccesses,
        evaluations_success,
        evaluations_success_text,
        scene_of_config,
        success_criterion,
    )

    name = config.get("task_name") or "push"
    head = "<strong>Every evaluation:</strong> "
    if log is not None:
        try:
            criterion = success_criterion(str(name))
            scene = scene_of_config({**config, "task_name": name})
        except ValueError:  # a task of a plugin that is not installed here
            return f"{head}n/a (the task {_esc(name)} is not registered here)."
        try:
            frame = pd.read_csv(io.BytesIO(read_run_file(folder, log)))
            summary = evaluations_success(frame, criterion, scene=scene)
        except (OSError, ValueError, KeyError, TypeError) as error:
            return f"{head}n/a (the evaluation log is not readable: {_esc(error)})."
        return f"{head}{_esc(evaluations_success_text(summary))}."
    counts = card.get("evaluations") or {}
    stored = [counts.get(key) for key in ("succeeded", "success_unknown", "total")]
    if not all(isinstance(v, int) and not isinstance(v, bool) for v in stored):
        return ""  # a card written before the counts, and no log: nothing to say
    k, unknown, total = (int(v) for v in stored)  # type: ignore[arg-type]  # checked above
    best = card.get("best_succeeding")
    row = None
    if isinstance(best, Mapping) and isinstance(best.get("coefficients"), list):
        row = pd.Series(
            {
                **{f"c{i + 1}": c for i, c in enumerate(best["coefficients"])},
                **{k2: best.get(k2) for k2 in ("iteration", "candidate", "free_energy")},
                "final_distance": best.get("final_distance"),
            }
        )
    summary = EvaluationSuccesses(k, total - unknown, unknown, row)
    return f"{head}{_esc(evaluations_success_text(summary))}."


def _card_html(
    folder: Path,
    picture: Path | None,
    design: Mapping[str, Any],
    straight: Mapping[str, Any] | None,
    lines: Sequence[str],
    *,
    compare: bool = True,
) -> str:
    left = _comparison(design, straight, compare=compare) + "".join(
        f'<p class="verdict">{x}</p>' for x in lines
    )
    right = _image(picture, folder, "The tool seen from above (tool frame, m).") if picture else ""
    return f'<section id="summary" class="card"><div>{left}</div><div>{right}</div></section>'


# --- a design run -----------------------------------------------------------------------------

_FIGURES = {
    "video": "The best tool's rollout: the goal is the green sphere, the box path the blue line.",
    "fig3b": "Convergence: F of every valid evaluation, the best of each iteration, best so far.",
    "fig3c": "Box paths of each iteration's best tool, top view, with start, end and goal.",
    "robustness_png": "The final tool's box paths with the box at the altered masses.",
    "fig3a": "The best tool of each iteration (tool frame, m).",
    "fig3": "Figure 3 of the paper: the four panels in one figure.",
}


def _task_label(config: Mapping[str, Any]) -> str:
    """The run's task, escaped: its name and its title (``push``, the paper's, when unnamed)."""
    from tooldesign_env.tasks import DEFAULT_TASK, get_task

    name = config.get("task_name") or DEFAULT_TASK
    try:
        title = get_task(str(name)).title
    except ValueError:  # a task of a plugin that is not installed here
        return f"{_esc(name)} (not registered here)"
    return f"{_esc(name)} ({_esc(title)})"


def _settings_html(card: Mapping[str, Any]) -> str:
    """The run's settings in three groups, each with its units."""
    config = card.get("config") or {}
    tool = card.get("tool") or {}
    evaluations = card.get("evaluations") or {}

    def seconds(key: str) -> str:
        return f"{_num(card.get(key), 3)} s" if _finite(card.get(key)) else "n/a"

    goal = config.get("goal")
    groups: dict[str, list[tuple[str, str]]] = {
        "Designer": [
            ("optimizer", _esc(config.get("optimizer"))),
            ("optimizer settings", _value(config.get("optimizer_settings") or "defaults")),
            ("seed", _esc(config.get("seed"))),
            ("iterations K", _esc(config.get("iterations"))),
            ("designs per iteration B", _esc(config.get("batch_size"))),
            (
                "coefficient bounds",
                _esc(
                    ", ".join(
                        f"c{i + 1} in [{lo:g}, {hi:g}]"
                        for i, (lo, hi) in enumerate(config.get("bounds") or [])
                    )
                ),
            ),
            (
                "best found at",
                f"iteration {card.get('iteration')}, candidate "
                f"{card.get('candidate')} (id {card.get('eval_id')})",
            ),
        ],
        "Task": [
            ("task", _task_label(config)),
            (
                "goal X^g",
                _esc(f"({', '.join(f'{v:g}' for v in goal)}) m")
                if isinstance(goal, list)
                else "n/a",
            ),
            ("goal precision p^X", _esc(config.get("goal_precision"))),
            ("box mass", f"{_esc(config.get('box_mass'))} kg"),
            ("estimator of dX/dU", _esc(config.get("estimator"))),
            ("objective", _esc(config.get("objective"))),
            ("scene samples", _esc(config.get("scene_samples"))),
            ("scene overrides", _value(config.get("scene") or "none")),
            (
                "robustness masses",
                _esc(", ".join(f"{m:g}" for m in config.get("robustness_masses") or [])) + " kg",
            ),
        ],
        "Tool and run": [
            ("section", f"{_esc(tool.get('section_shape'))}, {_num(tool.get('section'), 3)} m"),
            (
                "arc length / handle",
                f"{_num(tool.get('arc_length'), 3)} m / {_num(tool.get('handle_length'), 3)} m",
            ),
            ("tool mass", f"{_num(tool.get('mass'), 3)} kg"),
            ("min. radius of curvature", f"{_num(tool.get('min_radius_of_curvature'), 3)} m"),
            ("buildable", _esc(tool.get("buildable"))),
            (
                "evaluations",
                _esc(
                    f"{evaluations.get('total')} ({evaluations.get('ok')} ok, "
                    f"{evaluations.get('invalid')} invalid, {evaluations.get('failed')} failed)"
                ),
            ),
            ("wall time (elapsed)", seconds("wall_time")),
            ("simulation time (CPU, summed over workers)", seconds("simulation_time")),
            ("optimizer time", seconds("optimizer_time")),
            (
                "executor / workers",
                _esc(f"{config.get('executor')} / {config.get('workers') or 'all usable CPUs'}"),
            ),
        ],
    }
    tables = "".join(
        f"<div><h3>{_esc(name)}</h3><table>"
        + "".join(
            f'<tr><td class="key">{_esc(k)}</td><td class="text">{v}</td></tr>' for k, v in rows
        )
        + "</table></div>"
        for name, rows in groups.items()
    )
    packages = card.get("packages") or {}
    provenance = (
        f"<details><summary>Provenance: commit {_esc(str(card.get('git_commit'))[:12])}, "
        f"{_esc(card.get('start_time'))} to {_esc(card.get('end_time'))}</summary>"
        f'<p class="note">{_esc(", ".join(f"{k} {v}" for k, v in packages.items()))}</p>'
        f'<p class="note">The simulation time adds up every worker\'s time, so it exceeds the '
        f"wall time when designs are evaluated in parallel.</p></details>"
    )
    return f'<div class="settings">{tables}</div>{provenance}'


def _design_page(folder: Path, files: list[Path], card: dict[str, Any]) -> str:
    from benchmarks.storage import DESIGN_RUN_FILES

    def present(key: str) -> Path | None:
        path = folder / DESIGN_RUN_FILES[key]
        return path if path in files else None

    paths = _read_json(folder, folder / DESIGN_RUN_FILES["box_paths"])
    robustness = _read_json(folder, folder / DESIGN_RUN_FILES["robustness"]) or {}
    if robustness.get("error"):
        card = {**card, "robustness_error": robustness["error"]}
    coeffs = ", ".join(f"{c:.4g}" for c in card.get("coefficients") or [])
    config = card.get("config") or {}
    first = (
        f"<strong>The tool:</strong> C = ({_esc(coeffs)}) "
        f'<span class="note">({_esc(card.get("polynomial", ""))})</span>, '
        f"status {_esc(card.get('status'))}."
    )
    success = _success_line(
        card.get("status"),
        card.get("final_distance"),
        config.get("task_name"),
        card.get("straight_tool"),
        # A card written since 2026-11-27 keeps the best row's height and tilt; an older one
        # is judged by the distance alone, as before.
        standing=card if "final_height" in card else None,
        config=config,
    )
    every = _evaluations_success_line(folder, present("evaluations"), card, config)
    lines = [first, success, *([every] if every else []), _robustness_sentence(card, paths)]
    body = [_card_html(folder, present("fig3d"), card, card.get("straight_tool"), lines)]
    shown: set[Path] = set()
    for head, keys in (
        ('<h2>The run</h2><div class="grid3">', ("video", "fig3b", "fig3c")),
        ('<div class="grid2">', ("robustness_png", "fig3a")),
    ):
        figures = [(key, path) for key in keys if (path := present(key)) is not None]
        if figures:
            body.append(head)
            body.extend(_image(path, folder, _FIGURES[key]) for key, path in figures)
            body.append("</div>")
            shown.update(path for _, path in figures)
    body.append("<h2>Settings</h2>")
    body.append(_settings_html(card))
    log = present("evaluations")
    if log is not None:
        body.append("<h2>Every evaluation</h2>")
        body.append(_csv_table(log, folder, label="The evaluation log"))
        shown.add(log)
    shown.update(p for p in (present("fig3d"),) if p)
    rest = [p for p in files if p not in shown]
    body.extend(_rest(folder, rest, open_figures=False))
    title = f"Tool design: {config.get('optimizer', '?')}, seed {config.get('seed', '?')}"
    subtitle = (
        f"{_esc(folder.resolve().name)}: {_esc(config.get('iterations'))} iterations of "
        f"{_esc(config.get('batch_size'))} designs, task {_task_label(config)}, goal X^g = "
        f"({_esc(', '.join(f'{v:g}' for v in config.get('goal') or []))}) m, box "
        f"{_esc(config.get('box_mass'))} kg. "
        "Everything below is made from the files of the run folder and embedded in this page."
    )
    return _page(title, subtitle, body)


# --- an evaluate folder ------------------------------------------------------------------------


def _evaluate_page(folder: Path, files: list[Path], terms: dict[str, Any]) -> str:
    picture = folder / "tool_shape.png"
    coeffs = ", ".join(f"{c:.4g}" for c in terms.get("coefficients") or [])
    valid = terms.get("valid")
    lines = [
        f"<strong>The tool:</strong> C = ({_esc(coeffs)}), "
        f"{'valid' if valid else 'not valid: ' + _esc(terms.get('invalid_reason', ''))}."
    ]
    stored = terms.get("settings")
    settings: dict[str, Any] = stored if isinstance(stored, dict) else {}
    lines.append(
        _success_line(
            "ok" if valid else "invalid",
            terms.get("final_distance"),
            terms.get("task") or settings.get("task"),
            standing=terms,
        )
    )
    if "robustness" in terms:
        paths = _read_json(folder, folder / "box_paths.json")
        card = {"robustness": terms["robustness"], "config": {"goal": terms.get("goal")}}
        lines.append(_robustness_sentence(card, paths))
    body = [
        _card_html(folder, picture if picture in files else None, terms, None, lines, compare=False)
    ]
    figures = [
        folder / n for n in ("rollout.gif", "box_path.png", "free_energy.png", "robustness.png")
    ]
    figures = [p for p in figures if p in files]
    if figures:
        body.append('<h2>Figures</h2><div class="grid2">')
        body.extend(_image(p, folder) for p in figures)
        body.append("</div>")
    rest = [p for p in files if p not in figures and p != picture]
    # The per-step trajectory (thousands of rows) is there to be looked up: folded.
    body.extend(_rest(folder, rest, open_figures=True, fold_tables=True))
    return _page(
        f"Evaluated design: C = ({coeffs})",
        f"{_esc(folder.resolve().name)}: made from the files of the folder, everything embedded.",
        body,
    )


# --- anything else (a suite's run folder) ------------------------------------------------------

#: The reports a page leads with (the first _LEAD), then the order of the other texts; "report"
#: is the protocol's report.md (its rankings, power and verdicts).
_FIRST_TEXTS = ("summary", "verdict", "ranking", "report", "table1", "ecdf", "pairwise")
_LEAD = 4


def _text_rank(path: Path) -> tuple[int, str]:
    stem = path.stem.lower()
    for rank, word in enumerate(_FIRST_TEXTS):
        if word in stem:
            return rank, str(path)
    return len(_FIRST_TEXTS), str(path)


def _figure_rank(path: Path) -> tuple[int, str]:
    stem = path.stem.lower()
    for rank, word in enumerate(("ecdf", "ranking", "convergence", "final")):
        if word in stem:
            return rank, str(path)
    return 4, str(path)


def _rest(
    folder: Path, files: Sequence[Path], *, open_figures: bool, fold_tables: bool = False
) -> list[str]:
    """Reports, figures, tables and cards not shown above, the answers first.

    The lead reports (a summary, verdicts, rankings), then the figures (ECDFs and convergence
    first), then the other reports; the tables and cards, which the reports summarize, are
    folded away.
    """
    images = sorted((p for p in files if p.suffix.lower() in _IMAGES), key=_figure_rank)
    texts = sorted((p for p in files if p.suffix == ".md"), key=_text_rank)
    lead = [p for p in texts if _text_rank(p)[0] < _LEAD]  # summary, verdict, ranking, report
    logs = [p for p in files if p.suffix == ".txt"]
    tables = [p for p in files if p.suffix == ".csv"]
    cards = [p for p in files if p.suffix == ".json"]
    body: list[str] = []

    def report(path: Path) -> str:
        text = read_run_file(folder, path).decode("utf-8", errors="replace")
        return f"<h2>{_name(path, folder)}</h2>{_markdown(text)}"

    body.extend(report(p) for p in lead)
    if images:
        if open_figures:
            body.append('<h2>Figures</h2><div class="loose">')
            body.extend(_image(p, folder) for p in images)
            body.append("</div>")
        else:
            body.append('<details><summary>More figures</summary><div class="loose">')
            body.extend(_image(p, folder) for p in images)
            body.append("</div></details>")
    body.extend(report(p) for p in texts if p not in lead)
    if tables:
        body.append("<h2>Tables</h2>")
        body.extend(
            f"<details><summary>{_name(p, folder)}</summary>{_csv_table(p, folder)}</details>"
            if texts or fold_tables
            else _csv_table(p, folder)
            for p in tables
        )
    if cards:
        body.append("<h2>Cards</h2>")
        if len(cards) > 8:  # a suite's design files: one fold for all
            body.append(f"<details><summary>{len(cards)} JSON files</summary>")
            body.extend(_json_table(p, folder) for p in cards)
            body.append("</details>")
        else:
            body.extend(_json_table(p, folder) for p in cards)
    for path in logs:
        text = read_run_file(folder, path).decode("utf-8", errors="replace")
        body.append(
            f"<details><summary>{_name(path, folder)}</summary><pre>{_esc(text)}</pre></details>"
        )
    return body


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
    listed = _files(folder)  # a run folder that was tampered with is not shown
    known = [folder / relative for relative in listed.files]
    if len(known) > _MAX_FILES:
        raise ValueError(f"{folder} has more than {_MAX_FILES} files: give a run folder")
    if not known:
        raise ValueError(f"{folder} has no figure, table or card to report")
    # An evaluate or protocol folder has no manifest: all of it is unchecked, which its note
    # says once.
    whole = {EVALUATE_KIND: _EVALUATE_NOTE, PROTOCOL_KIND: _PROTOCOL_NOTE}.get(listed.kind)
    unchecked = () if whole is not None else listed.unchecked
    marks = _UNCHECKED.set(frozenset(folder / relative for relative in unchecked))
    note = _NOTE.set(whole if whole is not None else _unchecked_note(unchecked))
    try:
        page = _page_of(folder, known)
    finally:
        _UNCHECKED.reset(marks)
        _NOTE.reset(note)
    return atomic_write_text(target, page)


def _page_of(folder: Path, known: list[Path]) -> str:
    """The page of ``folder`` showing the files ``known``."""
    card = _read_json(folder, folder / "design.json")
    terms = _read_json(folder, folder / "terms.json")
    if card is not None and isinstance(card.get("config"), dict) and "coefficients" in card:
        page = _design_page(folder, known, card)
    elif terms is not None and "coefficients" in terms:
        page = _evaluate_page(folder, known, terms)
    else:
        title = f"tooldesign report: {folder.resolve().name}"
        kinds = {"figure": _IMAGES, "report": (".md",), "table": (".csv",), "card": (".json",)}
        numbers = [
            (sum(p.suffix.lower() in suffixes for p in known), name)
            for name, suffixes in kinds.items()
        ]
        counts = (
            ", ".join(f"{n} {name}{'' if n == 1 else 's'}" for n, name in numbers)
            + ": the reports (rankings and verdicts) first, made from the files of the folder, "
            "everything embedded."
        )
        page = _page(title, counts, _rest(folder, known, open_figures=True))
    return page
