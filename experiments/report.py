"""Reports a colleague can read: Markdown plus a self-contained HTML page.

A report is a title and a list of :class:`Section`; each section holds
paragraphs, :class:`Table` and :class:`Figure` objects. :func:`write_report`
writes ``report.md`` (figures referenced by relative path) and ``report.html``
(figures embedded as base64 PNG, no external resources, opens offline in any
browser), both atomically. :func:`check_report` is what the tests use: every
figure referenced exists and every table holds numbers.
"""

from __future__ import annotations

import base64
import html
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from physics.io import atomic_write_text

__all__ = ["Table", "Figure", "Section", "write_report", "check_report", "format_value"]


@dataclass(frozen=True)
class Table:
    """A table: ``columns`` names, ``rows`` of values (numbers are formatted by :func:`format_value`)."""

    caption: str
    columns: tuple
    rows: tuple

    @classmethod
    def from_records(cls, caption: str, records, columns=None) -> "Table":
        """From a list of dicts (keys of the first record, or ``columns``, give the column order)."""
        records = list(records)
        cols = tuple(columns or (records[0].keys() if records else ()))
        return cls(caption, cols, tuple(tuple(r.get(c) for c in cols) for r in records))


@dataclass(frozen=True)
class Figure:
    """A PNG file (absolute, relative to the working directory, or to the report directory) with its caption."""

    caption: str
    path: str


@dataclass(frozen=True)
class Section:
    title: str
    paragraphs: tuple = ()
    tables: tuple = ()
    figures: tuple = ()
    subsections: tuple = field(default=())


def format_value(v) -> str:
    """Numbers with 4-5 significant digits, booleans as yes/no, None/NaN as an en dash."""
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
        return f"{v:.4g}" if (a >= 1e5 or a < 1e-3) else f"{v:.5g}"
    if hasattr(v, "item") and not isinstance(v, str):  # numpy scalar
        return format_value(v.item())
    return str(v)


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


def _markdown(title: str, sections, root: Path) -> str:
    lines = [f"# {title}", ""]

    def emit(sec: Section, level: int):
        lines.extend([f"{'#' * level} {sec.title}", ""])
        for p in sec.paragraphs:
            lines.extend([p, ""])
        for t in sec.tables:
            lines.extend([f"**{t.caption}**", ""])
            lines.append("| " + " | ".join(str(c) for c in t.columns) + " |")
            lines.append("| " + " | ".join("---" for _ in t.columns) + " |")
            for r in t.rows:
                lines.append("| " + " | ".join(format_value(v).replace("|", "\\|") for v in r) + " |")
            lines.append("")
        for f in sec.figures:
            lines.extend([f"![{f.caption}]({_rel(f.path, root)})", "", f"*{f.caption}*", ""])
        for s in sec.subsections:
            emit(s, level + 1)

    for s in sections:
        emit(s, 2)
    return "\n".join(lines)


_CSS = """body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;max-width:1100px;margin:2em auto;
padding:0 1em;color:#222;line-height:1.45}table{border-collapse:collapse;margin:.5em 0 1.5em;font-size:.9em}
th,td{border:1px solid #bbb;padding:.25em .6em;text-align:right}th{background:#eee}td:first-child,th:first-child{text-align:left}
caption{font-weight:600;text-align:left;padding:.3em 0}figure{margin:1em 0 2em}img{max-width:100%;border:1px solid #ddd}
figcaption{font-style:italic;color:#444}code{background:#f4f4f4;padding:0 .2em}"""


def _inline(text: str) -> str:
    """Escape, then the little Markdown the paragraphs use: `code` and **bold**."""
    t = html.escape(text)
    t = re.sub(r"`([^`]+)`", r"<code>\1</code>", t)
    return re.sub(r"\*\*([^*]+)\*\*", r"<b>\1</b>", t)


def _html(title: str, sections, root: Path) -> str:
    out = [f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
           f"<style>{_CSS}</style></head><body><h1>{html.escape(title)}</h1>"]

    def emit(sec: Section, level: int):
        out.append(f"<h{level}>{html.escape(sec.title)}</h{level}>")
        for p in sec.paragraphs:
            out.append(f"<p>{_inline(p)}</p>")
        for t in sec.tables:
            out.append(f"<table><caption>{_inline(t.caption)}</caption><tr>"
                       + "".join(f"<th>{html.escape(str(c))}</th>" for c in t.columns) + "</tr>")
            for r in t.rows:
                out.append("<tr>" + "".join(f"<td>{html.escape(format_value(v))}</td>" for v in r) + "</tr>")
            out.append("</table>")
        for f in sec.figures:
            data = base64.b64encode(_figure_file(f.path, root).read_bytes()).decode("ascii")
            out.append(f"<figure><img alt='{html.escape(f.caption)}' src='data:image/png;base64,{data}'>"
                       f"<figcaption>{_inline(f.caption)}</figcaption></figure>")
        for s in sec.subsections:
            emit(s, min(level + 1, 6))

    for s in sections:
        emit(s, 2)
    out.append("</body></html>")
    return "\n".join(out)


def write_report(out_dir, title: str, sections) -> dict:
    """Write ``report.md`` and ``report.html`` into ``out_dir``; returns their paths.

    Raises
    ------
    FileNotFoundError
        A figure file does not exist (nothing is written then).
    """
    root = Path(out_dir)
    root.mkdir(parents=True, exist_ok=True)
    sections = tuple(sections)
    html_text = _html(title, sections, root)  # reads every figure first: fails before writing anything
    md_path, html_path = root / "report.md", root / "report.html"
    atomic_write_text(md_path, _markdown(title, sections, root) + "\n")
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
