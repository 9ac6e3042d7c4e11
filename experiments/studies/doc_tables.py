"""Benchmark tables in the ``docs/`` pages, written by the ``bench_*`` scripts that measure them.

A page marks each table it shows with a named block::

    <!-- bench:learn-benchmark -->
    | method | ROC AUC | ... |
    <!-- /bench:learn-benchmark -->

and the script that produces it, run with ``--docs``, replaces the text between the two markers
(:func:`write_table`), so the numbers in the docs are the ones the code printed. The block's last line says
which command wrote it, on which day (UTC), at which commit of the project and with which numpy and scipy::

    Written by `python -m experiments.benches.bench_learn --docs` on 2026-11-29 (UTC), commit 53b2bf0, numpy 2.4.6,
    scipy 1.17.1.

(on one line; :func:`stamp`; ``unknown`` for the commit outside a git checkout; a stamp without versions is read
too). Re-writing a block replaces its stamp.
"""

from __future__ import annotations

import re
import shlex
import sys
from datetime import datetime, timezone
from importlib.metadata import version
from pathlib import Path

from physics.errors import BeamDamageError
from physics.io import atomic_write_text

__all__ = ["DOCS", "LIBRARIES", "STAMP", "block_names", "block_text", "git_commit", "invoking_command", "stamp",
           "write_table"]

#: The ``docs/`` directory of this checkout.
DOCS = Path(__file__).resolve().parents[2] / "docs"

_BLOCK = re.compile(r"<!-- bench:([\w.-]+) -->")

#: A block's stamp line: the command that wrote the block, the day (UTC), the project's commit and the numerical
#: libraries' versions (:data:`LIBRARIES`; floating-point results of the same commit can differ between versions).
STAMP = re.compile(r"^Written by `[^`\n]+` on \d{4}-\d{2}-\d{2} \(UTC\), commit (?:[0-9a-f]{7,40}|unknown)"
                   r"(?:, numpy [\w.+-]+, scipy [\w.+-]+)?\.$", re.MULTILINE)
#: The numerical libraries a stamp names, with their versions.
LIBRARIES = ("numpy", "scipy")

#: Modules whose ``python -m`` run is the installed ``beam-damage`` command.
_CLI_MODULES = ("experiments.cli", "experiments.cli.__main__")

_HEX = re.compile(r"[0-9a-f]{40}")


def block_names(text: str) -> list[str]:
    """Names of the ``<!-- bench:NAME -->`` blocks opened in ``text``, in order."""
    return _BLOCK.findall(text)


def block_text(text: str, name: str) -> str:
    """The content of block ``name`` in the page ``text``, stripped, without its stamp line.

    Raises
    ------
    BeamDamageError
        ``text`` does not hold the block's two markers.
    """
    start, end = f"<!-- bench:{name} -->", f"<!-- /bench:{name} -->"
    if start not in text or end not in text.split(start, 1)[1]:
        raise BeamDamageError(f"no '{start}' ... '{end}' block in the page")
    return _without_stamp(text.split(start, 1)[1].split(end, 1)[0])


def _without_stamp(markdown: str) -> str:
    return STAMP.sub("", markdown).strip()


def git_commit(root=DOCS.parent) -> str:
    """The short hash (7 hex digits) of the commit checked out in ``root``, read from its ``.git`` (a directory, or
    a worktree's ``gitdir:`` file; loose or packed refs); ``"unknown"`` when it cannot be read."""
    try:
        git = Path(root) / ".git"
        if git.is_file():
            git = (Path(root) / git.read_text(encoding="utf-8").split("gitdir:", 1)[1].strip()).resolve()
        head = (git / "HEAD").read_text(encoding="utf-8").strip()
        if _HEX.fullmatch(head):
            return head[:7]
        ref = head.removeprefix("ref:").strip()
        common = git
        if (git / "commondir").is_file():
            common = (git / (git / "commondir").read_text(encoding="utf-8").strip()).resolve()
        for d in (git, common):
            if (d / ref).is_file():
                sha = (d / ref).read_text(encoding="utf-8").strip()
                return sha[:7] if _HEX.fullmatch(sha) else "unknown"
        for line in (common / "packed-refs").read_text(encoding="utf-8").splitlines():
            sha, _, name = line.partition(" ")
            if name == ref and _HEX.fullmatch(sha):
                return sha[:7]
    except (OSError, IndexError, UnicodeDecodeError):
        pass
    return "unknown"


def invoking_command() -> str:
    """The command line of this process as a reader would type it: ``beam-damage ARGS`` for the CLI, ``python -m
    MODULE ARGS`` for a module run with ``-m``, else ``python SCRIPT ARGS``; paths inside the checkout relative."""
    main = sys.modules.get("__main__")
    spec = getattr(main, "__spec__", None)
    if spec is not None and spec.name:
        module = spec.name.removesuffix(".__main__")
        prog = ["beam-damage"] if module in _CLI_MODULES else ["python", "-m", module]
    elif Path(sys.argv[0]).name == "beam-damage":
        prog = ["beam-damage"]
    else:
        prog = ["python", sys.argv[0]]
    root = f"{DOCS.parent}/"
    return " ".join(shlex.quote(a.replace(root, "")) for a in [*prog, *sys.argv[1:]])


def stamp(command: str | None = None) -> str:
    """The stamp line of a block written now by ``command`` (default :func:`invoking_command`)."""
    command = (command or invoking_command()).replace("`", "'").replace("\n", " ")
    day = datetime.now(timezone.utc).date().isoformat()
    versions = ", ".join(f"{name} {version(name)}" for name in LIBRARIES)
    return f"Written by `{command}` on {day} (UTC), commit {git_commit()}, {versions}."


def write_table(page_path, name: str, markdown: str, command: str | None = None) -> None:
    """Replace the text of block ``name`` in ``page_path`` with ``markdown``, atomically.

    Parameters
    ----------
    page_path : str or Path
        The docs page; a bare file name is looked up in :data:`DOCS`.
    name : str
        Block name: the page holds ``<!-- bench:NAME -->`` and ``<!-- /bench:NAME -->``, once each.
    markdown : str
        The new block content (a Markdown table and any lines that belong to it); a stamp line in it is dropped.
    command : str, optional
        The command named in the block's stamp line (:func:`stamp`); default this process's command line.

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
    atomic_write_text(page, f"{head}{start}\n{_without_stamp(markdown)}\n\n{stamp(command)}\n{end}{tail}")
