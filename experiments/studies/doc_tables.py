"""Benchmark tables in the ``docs/`` pages, written by the ``bench_*`` scripts that measure them.

A page marks each table it shows with a named block::

    <!-- bench:learn-benchmark -->
    | method | ROC AUC | ... |
    <!-- /bench:learn-benchmark -->

and the script that produces it, run with ``--docs``, replaces the text between the two markers
(:func:`write_table`), so the numbers in the docs are the ones the code printed.
"""

from __future__ import annotations

import re
from pathlib import Path

from physics.errors import BeamDamageError
from physics.io import atomic_write_text

__all__ = ["DOCS", "block_names", "write_table"]

#: The ``docs/`` directory of this checkout.
DOCS = Path(__file__).resolve().parents[2] / "docs"

_BLOCK = re.compile(r"<!-- bench:([\w.-]+) -->")


def block_names(text: str) -> list[str]:
    """Names of the ``<!-- bench:NAME -->`` blocks opened in ``text``, in order."""
    return _BLOCK.findall(text)


def write_table(page_path, name: str, markdown: str) -> None:
    """Replace the text of block ``name`` in ``page_path`` with ``markdown``, atomically.

    Parameters
    ----------
    page_path : str or Path
        The docs page; a bare file name is looked up in :data:`DOCS`.
    name : str
        Block name: the page holds ``<!-- bench:NAME -->`` and ``<!-- /bench:NAME -->``, once each.
    markdown : str
        The new block content (a Markdown table and any lines that belong to it).

    Raises
    ------
    BeamDamageError
        The page does not exist or does not hold both markers of the block exactly once.
    """
    page = Path(page_path)
    if not page.is_absolute() and page.parent == Path("."):
        page = DOCS / page
    try:
        text = page.read_text(encoding="utf-8")
    except OSError as e:
        raise BeamDamageError(f"{page}: cannot read the docs page ({e.strerror})") from None
    start, end = f"<!-- bench:{name} -->", f"<!-- /bench:{name} -->"
    if text.count(start) != 1 or text.count(end) != 1 or text.index(start) > text.index(end):
        raise BeamDamageError(f"{page}: expected one '{start}' ... '{end}' block, found "
                              f"{text.count(start)} opening and {text.count(end)} closing markers")
    head, rest = text.split(start)
    _, tail = rest.split(end)
    atomic_write_text(page, f"{head}{start}\n{markdown.strip()}\n{end}{tail}")
