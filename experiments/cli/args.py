"""Argument helpers shared by several commands (argparse types and up-front checks; no computation)."""

from __future__ import annotations

import argparse
from pathlib import Path

from physics import properties
from physics.beam import Beam, load_beam
from physics.errors import BeamDamageError

__all__ = ["add_beam_argument", "beam_argument", "check_out_dir", "check_out_file", "counted"]


def beam_argument(spec: str) -> Beam:
    """argparse ``type`` of ``--beam PRESET|FILE``: a bad name or file is a one-line usage error (exit 2)."""
    try:
        return load_beam(spec)
    except BeamDamageError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_beam_argument(p, default="beam5"):
    """The shared ``--beam PRESET|FILE`` option (a preset name or a TOML beam file, see physics.beam)."""
    p.add_argument("--beam", default=default, type=beam_argument, metavar="PRESET|FILE",
                   help=f"beam preset ({', '.join(sorted(properties.PRESETS))}) or TOML beam file "
                        f"(docs/beam-file.md; default {default})")


def check_out_dir(path) -> None:
    """Refuse an output directory that cannot be created, before any long computation."""
    p = Path(path)
    for q in (p, *p.parents):
        if q.exists():
            if not q.is_dir():
                raise BeamDamageError(f"--out {path}: {q} exists and is not a directory")
            return


def check_out_file(path) -> None:
    """Refuse an output file that cannot be written (a directory of that name, a parent that is a file), before any
    long computation."""
    p = Path(path)
    if p.is_dir():
        raise BeamDamageError(f"--out {path}: is a directory; expected a file name")
    q = next((q for q in p.parents if q.exists()), None)
    if q is not None and not q.is_dir():
        raise BeamDamageError(f"--out {path}: {q} exists and is not a directory")


def counted(n: int, noun: str) -> str:
    """``n`` and ``noun``, plural unless ``n`` is 1 (``1 mode``, ``3 channels``, ``1 event``)."""
    return f"{n} {noun}" + ("" if n == 1 else "s")
