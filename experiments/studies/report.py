"""Reports a colleague can read: Markdown plus a self-contained HTML page.

A report is a title, an optional summary (what was found, rendered first in a box and followed by the
contents) and a list of :class:`Section`; each section holds paragraphs, :class:`Table` and
:class:`Figure` objects. :func:`write_report` writes ``report.md`` (figures referenced by relative path)
and ``report.html`` (figures embedded as base64 PNG, no external resources, opens offline in any browser),
both atomically. In the HTML every table sits in its own horizontally scrolling box, so the page fits a
1280-pixel window; a ``collapsed`` table is a closed ``<details>`` block. :data:`CAPTIONS` holds the
caption of every figure the tools write, by file name (:func:`figure`). :func:`check_report` is what the
tests use: every figure referenced exists and every table holds numbers.
"""

from __future__ import annotations

import base64
import html
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from physics.io import atomic_write_text

__all__ = ["Table", "Figure", "Section", "CAPTIONS", "figure", "figure_caption", "write_report", "check_report",
           "format_value", "header_text"]

#: Caption of each figure the tools write, by file name without suffix.
CAPTIONS = {
    "roc": "ROC curves of the network and the classical methods on the held-out test pairs: detectable damage "
           "against intact pairs, false-positive rate on a logarithmic axis.",
    "confusion": "Confusion matrix of the network on the thesis's 4-element grid: true element (rows; intact "
                 "pairs apart) against the element the network predicts (columns), held-out test pairs.",
    "location_error": "Median location error of every method against the true damage position x/L on the "
                      "held-out damaged pairs; the dotted line marks the tip zone (x/L >= 0.85).",
    "reliability": "Reliability of the network's probability of damage: observed share of damaged pairs against "
                   "the predicted probability (15 bins); the dotted diagonal is perfect calibration.",
    "overlay": "Measured FRFs (light, solid) and the FRFs synthesised from the LSFD fit (dashed): magnitude above, "
               "phase unwrapped along frequency below.",
    "stabilisation": "LSCF stabilisation diagram: poles of each model order over the mode indicator; dashed "
                     "vertical lines mark the selected modes.",
    "frequency_error": "Frequency error per mode of the beam model against the measurement: the beam as given, "
                       "with EI and mass recalibrated only, and with the named effects.",
    "frf_overlay": "Measured FRF magnitude (black) against the beam model before (red, dashed) and after (blue) "
                   "the discrepancy workflow, one panel per response and reference position.",
}


def figure_caption(path) -> str:
    """The caption of a figure file from :data:`CAPTIONS` (its file name, words of it if unknown)."""
    stem = Path(path).stem
    return CAPTIONS.get(stem, stem.replace("_", " ").capitalize() + ".")


@dataclass(frozen=True)
class Table:
    """A table: ``columns`` names, ``rows`` of values (formatted by :func:`format_value`).

    ``collapsed`` tables are a closed ``<details>`` block in the HTML (the caption stays visible).
    """

    caption: str
    columns: tuple
    rows: tuple
    collapsed: bool = False

    @classmethod
    def from_records(cls, caption: str, records, columns=None, collapsed: bool = False) -> "Table":
        """From a list of dicts: keys of the first record, or ``columns``, give the column order.

        ``columns`` may be a dict ``{key: header}`` to name the columns.
        """
        records = list(records)
        keys = tuple(columns or (records[0].keys() if records else ()))
        heads = tuple(columns[k] for k in keys) if isinstance(columns, dict) else keys
        return cls(caption, heads, tuple(tuple(r.get(k) for k in keys) for r in records), collapsed)


@dataclass(frozen=True)
class Figure:
    """A PNG file (absolute, relative to the working directory, or to the report directory) with its caption."""

    caption: str
    path: str


def figure(path, caption: str | None = None) -> Figure:
    """A :class:`Figure` captioned from :data:`CAPTIONS` unless ``caption`` is given."""
    return Figure(caption or figure_caption(path), str(path))


@dataclass(frozen=True)
class Section:
    title: str
    paragraphs: tuple = ()
    tables: tuple = ()
    figures: tuple = ()
    subsections: tuple = field(default=())


_MAX_ITEMS = 4


def format_value(v) -> str:
    """Numbers with 4-5 significant digits, booleans as yes/no, None/NaN as an en dash.

    Sequences show their first few items and their length, mappings their first few ``key: value``
    pairs: a nested value never fills a cell.
    """
    if v is None:
        return "–"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            return "–"
        if v == 0:
            return "0"
        a = abs(v)
        if a >= 1e5 or a < 1e-3:
            mant, _, exp = f"{v:.4g}".partition("e")
            return f"{mant}e{int(exp)}" if exp else mant
        return f"{v:.5g}"
    if isinstance(v, str):
        return v
    if hasattr(v, "item") and getattr(v, "ndim", 0) == 0:  # numpy scalar
        return format_value(v.item())
    if isinstance(v, dict):
        items = [f"{k}: {format_value(x) if not isinstance(x, (dict, list, tuple)) else '…'}"
                 for k, x in list(v.items())[:_MAX_ITEMS]]
        more = f"; … ({len(v)} entries)" if len(v) > _MAX_ITEMS else ""
        return "; ".join(items) + more
    if hasattr(v, "__len__") and hasattr(v, "__iter__"):   # list, tuple, ndarray
        seq = list(v.tolist() if hasattr(v, "tolist") else v)
        items = [format_value(x) if not isinstance(x, (dict, list, tuple)) else "…" for x in seq[:_MAX_ITEMS]]
        more = f", … ({len(seq)} values)" if len(seq) > _MAX_ITEMS else ""
        return "[" + ", ".join(items) + more + "]"
    return str(v)


_UNITS = (("rad_s", "rad/s"), ("kg_m", "kg/m"), ("Nm3", "N m^3"), ("Nm2", "N m^2"), ("pct", "%"), ("hz", "Hz"),
          ("mm", "mm"), ("db", "dB"), ("pa", "Pa"), ("m", "m"), ("s", "s"), ("N", "N"))
_WORDS = {"roc": "ROC", "auc": "AUC", "ece": "ECE", "bic": "BIC", "mac": "MAC", "frf": "FRF", "n": "number of"}


def header_text(name) -> str:
    """A column name for readers: ``median_location_error_mm`` -> ``median location error (mm)``.

    Only identifiers (letters, digits, underscores) change; any other name is kept as written.
    """
    name = str(name)
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name):
        return name
    unit = ""
    for suffix, text in _UNITS:
        if name.endswith("_" + suffix) and len(name) > len(suffix) + 1:
            name, unit = name[: -len(suffix) - 1], f" ({text})"
            break
    return " ".join(_WORDS.get(w, w) for w in name.split("_")) + unit


def _is_number(v) -> bool:
    if hasattr(v, "item") and getattr(v, "ndim", 1) == 0:   # numpy scalar
        v = v.item()
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _figure_file(path: str, root: Path) -> Path:
    """A figure's file: absolute, or relative to the working directory, else to the report directory."""
    p = Path(path)
    return p if p.is_absolute() or p.exists() else root / p


def _rel(path: str, root: Path) -> str:
    p = _figure_file(path, root)
    try:
        return p.resolve().relative_to(root.resolve()).as_posix()
    except ValueError:
        return p.as_posix()


def _markdown(title: str, summary, sections, root: Path) -> str:
    lines = [f"# {title}", ""]

    def emit(sec: Section, level: int):
        lines.extend([f"{'#' * level} {sec.title}", ""])
        for p in sec.paragraphs:
            lines.extend([p, ""])
        for t in sec.tables:
            lines.extend([f"**{t.caption}**", ""])
            lines.append("| " + " | ".join(header_text(c) for c in t.columns) + " |")
            lines.append("| " + " | ".join("---" for _ in t.columns) + " |")
            for r in t.rows:
                lines.append("| " + " | ".join(format_value(v).replace("|", "\\|") for v in r) + " |")
            lines.append("")
        for f in sec.figures:
            lines.extend([f"![{f.caption}]({_rel(f.path, root)})", "", f"*{f.caption}*", ""])
        for s in sec.subsections:
            emit(s, level + 1)

    for s in ([summary] if summary else []) + list(sections):
        emit(s, 2)
    return "\n".join(lines)


_CSS = """body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;max-width:1100px;
margin:1.5em auto;padding:0 1em;color:#222;line-height:1.45}h1{font-size:1.7em;margin:.2em 0 .4em}h2{margin-top:1.8em}
.summary{background:#f4f7fb;border-left:5px solid #2b6cb0;padding:.2em 1.2em .6em;margin:0 0 1em}
.summary h2{margin-top:.6em}.summary p{margin:.45em 0}nav ol{columns:2;margin:.3em 0 1em}
.tbl{margin:.5em 0 1.5em}.scroll{overflow-x:auto;max-width:100%}.cap{font-weight:600;margin:.3em 0}
details.tbl>summary{cursor:pointer;font-weight:600;margin:.3em 0}table{border-collapse:collapse;font-size:.88em}
th,td{border:1px solid #bbb;padding:.25em .55em;vertical-align:top}th{background:#eee;text-align:left;
vertical-align:bottom;max-width:11em;font-weight:600}td{text-align:left;max-width:34em}
td.n{text-align:right;white-space:nowrap;font-variant-numeric:tabular-nums}
figure{margin:1em 0 2em}img{max-width:100%;height:auto;border:1px solid #ddd}
figcaption{color:#444;max-width:52em}code{background:#f4f4f4;padding:0 .2em;overflow-wrap:anywhere}"""


def _inline(text: str) -> str:
    """Escape, then the little Markdown the paragraphs use: `code` and **bold**."""
    t = html.escape(text)
    t = re.sub(r"`([^`]+)`", r"<code>\1</code>", t)
    return re.sub(r"\*\*([^*]+)\*\*", r"<b>\1</b>", t)


def _html_table(t: Table) -> str:
    head = "<tr>" + "".join(f"<th>{html.escape(header_text(c))}</th>" for c in t.columns) + "</tr>"
    body = "".join("<tr>" + "".join(f"<td class='n'>{html.escape(format_value(v))}</td>" if _is_number(v)
                                    else f"<td>{html.escape(format_value(v))}</td>" for v in r) + "</tr>"
                   for r in t.rows)
    table = f"<div class='scroll'><table><thead>{head}</thead><tbody>{body}</tbody></table></div>"
    if t.collapsed:
        return (f"<details class='tbl'><summary>{_inline(t.caption)} ({len(t.rows)} rows; click to show)</summary>"
                f"{table}</details>")
    return f"<div class='tbl'><p class='cap'>{_inline(t.caption)}</p>{table}</div>"


def _html(title: str, summary, sections, root: Path) -> str:
    out = [f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
           f"<meta name='viewport' content='width=device-width, initial-scale=1'><title>{html.escape(title)}</title>"
           f"<style>{_CSS}</style></head><body><h1>{html.escape(title)}</h1>"]

    def emit(sec: Section, level: int, anchor: str = ""):
        out.append(f"<h{level}{anchor}>{_inline(sec.title)}</h{level}>")
        for p in sec.paragraphs:
            out.append(f"<p>{_inline(p)}</p>")
        for t in sec.tables:
            out.append(_html_table(t))
        for f in sec.figures:
            data = base64.b64encode(_figure_file(f.path, root).read_bytes()).decode("ascii")
            out.append(f"<figure><img alt='{html.escape(f.caption)}' src='data:image/png;base64,{data}'>"
                       f"<figcaption>{_inline(f.caption)}</figcaption></figure>")
        for s in sec.subsections:
            emit(s, min(level + 1, 6))

    if summary is not None:
        out.append("<section class='summary'>")
        emit(summary, 2)
        out.append("</section>")
    if summary is not None and len(sections) > 1:
        out.append("<nav><b>Contents</b><ol>" + "".join(f"<li><a href='#s{i}'>{_inline(s.title)}</a></li>"
                                                        for i, s in enumerate(sections, 1)) + "</ol></nav>")
    for i, s in enumerate(sections, 1):
        out.append("<section>")
        emit(s, 2, f" id='s{i}'")
        out.append("</section>")
    out.append("</body></html>")
    return "\n".join(out)


def write_report(out_dir, title: str, sections, summary: Section | None = None) -> dict:
    """Write ``report.md`` and ``report.html`` into ``out_dir``; returns their paths.

    ``summary``, when given, comes first (in the HTML: in a box, followed by the list of sections).

    Raises
    ------
    FileNotFoundError
        A figure file does not exist (nothing is written then).
    """
    root = Path(out_dir)
    root.mkdir(parents=True, exist_ok=True)
    sections = tuple(sections)
    html_text = _html(title, summary, sections, root)  # reads every figure first: fails before writing anything
    md_path, html_path = root / "report.md", root / "report.html"
    atomic_write_text(md_path, _markdown(title, summary, sections, root) + "\n")
    atomic_write_text(html_path, html_text + "\n")
    return {"markdown": str(md_path), "html": str(html_path)}


_NUMBER = re.compile(r"[-+]?\d+(\.\d+)?([eE][-+]?\d+)?")


def check_report(md_path) -> dict:
    """Check a written report: figures referenced exist, every table has a numeric cell.

    Returns
    -------
    dict
        ``figures`` (count), ``tables`` (count), ``problems`` (list of str; empty when the report is sound).
    """
    md = Path(md_path)
    text = md.read_text(encoding="utf-8")
    problems = []
    figs = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text)
    for f in figs:
        p = Path(f) if Path(f).is_absolute() else md.parent / f
        if not p.is_file() or p.stat().st_size == 0:
            problems.append(f"figure {f} referenced but missing")
    tables, current = [], None
    for line in text.splitlines():
        if line.startswith("|"):
            if current is None:
                current = []
                tables.append(current)
            current.append(line)
        else:
            current = None
    for i, t in enumerate(tables, 1):
        body = t[2:]
        if not body:
            problems.append(f"table {i} ({t[0][:40]}...) has no rows")
        elif not any(_NUMBER.fullmatch(c.strip()) for row in body for c in row.strip("|").split("|")):
            problems.append(f"table {i} ({t[0][:40]}...) holds no number")
    html_path = md.with_suffix(".html")
    if html_path.exists():
        h = html_path.read_text(encoding="utf-8")
        if re.search(r"<img[^>]+src='(?!data:)", h):
            problems.append("report.html references an external image")
        if h.count("<img") != len(figs):
            problems.append(f"report.html embeds {h.count('<img')} images, report.md references {len(figs)}")
    return {"figures": len(figs), "tables": len(tables), "problems": problems}
