"""What every bench shares: its command line, its Markdown tables and the docs block its ``--docs`` rewrites.

A bench is ``experiments/benches/bench_<name>.py`` with ``main(argv=None) -> int``::

    p = parser(__file__, __doc__, docs="identification.md", out="out/name", seed=0)
    p.add_argument("--seeds", type=int, default=5)          # its own arguments
    args = p.parse_args(argv)
    ...
    md = table(["case", "error (%)"], [[r["case"], f"{r['error']:.2f}"] for r in rows])
    publish(args, "name", md)           # with --docs: the <!-- bench:name --> block of docs/identification.md
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import subprocess
import sys
from pathlib import Path

from experiments.cli import main as cli_main
from experiments.studies.doc_tables import write_table
from physics.io import atomic_write_text

__all__ = ["cli_json", "emit_json", "parser", "publish", "table", "write_table"]


def parser(file: str, doc: str, *, docs: str | None = None, json: bool | str = False, out: str | None = None,
           seed: int | None = None, workers: int | None = None, **kwargs) -> argparse.ArgumentParser:
    """The argument parser of the bench in ``file`` (its ``__file__``): ``prog`` the ``python -m`` command that runs
    it, the description the first paragraph of ``doc``, and the arguments common to benches that it asks for.

    Parameters
    ----------
    docs : str, optional
        ``--docs``: write the tables into this page of ``docs/`` (:func:`publish`); ``args.docs`` is the page
        given ``--docs``, else None.
    json : bool or str, optional
        True: ``--json`` prints the rows as JSON; a string: ``--json FILE`` writes them there.
    out : str, optional
        ``--out DIR`` (a string, so that ``vars(args)`` stays JSON) with this default.
    seed, workers : int, optional
        ``--seed N``, ``--workers N`` with these defaults.
    **kwargs
        Passed to :class:`argparse.ArgumentParser` (e.g. ``description``, ``formatter_class``).
    """
    kwargs.setdefault("description", doc.split("\n\n")[0])
    p = argparse.ArgumentParser(prog=f"python -m experiments.benches.{Path(file).stem}", **kwargs)
    if out is not None:
        p.add_argument("--out", default=out, help=f"output directory (default {out})")
    if seed is not None:
        p.add_argument("--seed", type=int, default=seed, help=f"first random seed (default {seed})")
    if workers is not None:
        p.add_argument("--workers", type=int, default=workers, help=f"processes (default {workers})")
    if json is True:
        p.add_argument("--json", action="store_true", help="print the rows as JSON")
    elif json:
        p.add_argument("--json", metavar=json, help="write the rows as JSON into this file")
    if docs is not None:
        p.add_argument("--docs", action="store_const", const=docs, help=f"write the table into docs/{docs}")
    return p


def publish(args: argparse.Namespace, name: str, markdown: str) -> None:
    """With ``--docs`` (``args.docs``: the page the bench's :func:`parser` names), replace block ``name`` of that
    page with ``markdown`` (:func:`~experiments.studies.doc_tables.write_table`); without it, nothing."""
    if args.docs:
        write_table(args.docs, name, markdown)


def emit_json(args: argparse.Namespace, obj, **dumps) -> None:
    """With ``--json`` (as the bench's :func:`parser` declares it): ``obj`` as indented JSON, printed (``json=True``)
    or written atomically into the file given (``json="FILE"``); without it, nothing. ``dumps`` go to
    :func:`json.dumps` (e.g. ``default=float``)."""
    if args.json is True:
        print(json.dumps(obj, indent=1, **dumps))
    elif args.json:
        atomic_write_text(args.json, json.dumps(obj, indent=1, **dumps) + "\n")


def table(header, rows, align=None) -> str:
    """A Markdown table: the ``header`` cells, the alignment row (``align``: one of ``---``, ``---:`` per column;
    default ``---`` each), then one line per row of ``rows`` (cells formatted by ``str``); no final newline."""
    lines = [header, align or ["---"] * len(header), *rows]
    return "\n".join("| " + " | ".join(str(c) for c in line) + " |" for line in lines)


def cli_json(argv: list[str], source_tree: str | None = None) -> dict | list:
    """``beam-damage ARGV --json`` in this process (the CLI's own entry point), or in ``source_tree``'s; its JSON.

    A non-zero exit (a usage error's too) raises ``RuntimeError`` with the command's stderr."""
    if source_tree is None:
        buf, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(err):
            try:
                code = cli_main(argv + ["--json"])
            except SystemExit as exc:
                code = exc.code
        if code != 0:
            raise RuntimeError(f"beam-damage {' '.join(argv)} exited {code}: {err.getvalue().strip()}")
        return json.loads(buf.getvalue())
    env = {**os.environ, "PYTHONPATH": str(source_tree)}
    p = subprocess.run([sys.executable, "-m", "experiments.cli", *argv, "--json"], capture_output=True, text=True,
                       env=env, cwd=source_tree)
    if p.returncode != 0:
        raise RuntimeError(f"beam-damage {' '.join(argv)} ({source_tree}) exited {p.returncode}: {p.stderr.strip()}")
    return json.loads(p.stdout)
