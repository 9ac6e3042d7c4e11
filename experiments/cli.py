"""The ``beam-damage`` command line: parse, call, print.

Each sub-command lives in its own module exposing ``add_parser(subparsers)``,
which registers the parser and sets ``func`` to a callable ``run(args) -> dict``
and, optionally, ``flags``: a mapping from library parameter names to its
options (``{"n_elements": "--elements"}``), so that an error about a parameter
(:attr:`physics.errors.BeamDamageError.parameter`) is reported with the flag.
``run`` returns a JSON-serialisable result and, for text output, may print a
human-readable view itself (only when ``args.json`` is false). Errors derived
from :class:`physics.errors.BeamDamageError` (and ``OSError`` on user files)
become one line on stderr and exit code 2; warnings raised while a command runs are dropped when it fails
(the error line is the whole story) and otherwise printed after it, one line each
(``beam-damage COMMAND: warning: ...``). Commands run with one BLAS thread: their matrices are small
(at most a few hundred DOFs, batched), where more threads only add overhead and, on a shared machine,
slow a command down many times; parallel work uses processes (``generate --workers``) or torch threads.
"""

from __future__ import annotations

import argparse
import importlib
import json
import signal
import sys
import threading
import warnings

import numpy as np
from threadpoolctl import threadpool_limits

from physics.errors import BeamDamageError
from physics.io import format_complex

__all__ = ["build_parser", "main", "to_jsonable"]


#: Sub-command name -> module registering it (``add_parser``), in the order ``--help`` lists them.
COMMANDS = {
    "validate": "experiments.validate",
    "model": "experiments.cmd_model",
    "update": "experiments.cmd_update",
    "identify": "experiments.cmd_identify",
    "estimate": "experiments.cmd_estimate",
    "demo": "experiments.demo",
    "generate": "experiments.cmd_generate",
    "inspect": "experiments.cmd_inspect",
    "experiment": "experiments.cmd_experiment",
    "export": "experiments.cmd_export",
    "discrepancy": "experiments.cmd_discrepancy",
    "train": "experiments.cmd_train",
    "evaluate": "experiments.cmd_evaluate",
    "classify": "experiments.cmd_classify",
}

EXIT_USAGE = 2
EXIT_SIGINT = 130   # 128 + SIGINT
EXIT_SIGTERM = 143  # 128 + SIGTERM


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line and exit code 2."""

    def error(self, message):
        sys.stderr.write(f"beam-damage: error: {message}\n")
        raise SystemExit(EXIT_USAGE)


def to_jsonable(obj):
    """Convert numpy arrays/scalars and complex numbers into JSON-ready values.

    Complex numbers become strings such as ``"-0.21962+135.31j"`` (the form of
    the thesis fixtures), arrays become nested lists.
    """
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (complex, np.complexfloating)):
        return format_complex(complex(obj))
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        return v if np.isfinite(v) else None
    return obj


def build_parser(argv=None) -> argparse.ArgumentParser:
    """The ``beam-damage`` parser; when ``argv`` names a command, only that command's module is imported (a
    command's start-up does not pay for every other command's imports), else all of them (``--help``)."""
    parser = _Parser(
        prog="beam-damage",
        description="Vibration-based model updating and damage detection of beams.",
    )
    from importlib.metadata import PackageNotFoundError, version

    try:
        ver = version("beam-damage")
    except PackageNotFoundError:  # running from a source tree
        ver = "unknown"
    parser.add_argument("--version", action="version", version=f"beam-damage {ver}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    first = next((a for a in (argv or []) if not a.startswith("-")), None)
    for name, module in COMMANDS.items():
        if first in COMMANDS and name != first:
            continue
        importlib.import_module(module).add_parser(sub)
    return parser


class Terminated(BaseException):
    """SIGTERM received: unwinds like KeyboardInterrupt, so writers' cleanup runs."""


def _raise_terminated(signum, frame):
    raise Terminated


def _on_signals():
    """SIGTERM raises :class:`Terminated` while a command runs (main thread only); returns the previous handler."""
    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGTERM, _raise_terminated)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(argv)
    args = parser.parse_args(argv)
    previous = _on_signals()
    try:
        return _run(args)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _run(args) -> int:
    try:
        with warnings.catch_warnings(record=True) as caught, threadpool_limits(1, user_api="blas"):
            warnings.simplefilter("default")
            result = args.func(args)
    except KeyboardInterrupt:  # SIGINT: one line, exit 128 + 2; what was written stays resumable
        sys.stderr.write(f"beam-damage {args.command}: interrupted (SIGINT)\n")
        return EXIT_SIGINT
    except Terminated:
        sys.stderr.write(f"beam-damage {args.command}: terminated (SIGTERM)\n")
        return EXIT_SIGTERM
    except BeamDamageError as exc:
        flag = getattr(args, "flags", {}).get(exc.parameter)
        sys.stderr.write(f"beam-damage {args.command}: error: {f'{flag}: ' if flag else ''}{exc}\n")
        return EXIT_USAGE
    except BrokenPipeError:  # output piped into `head` and closed: not an error of the user's input
        sys.stderr.close()
        return 0
    except OSError as exc:
        sys.stderr.write(f"beam-damage {args.command}: error: {exc.strerror or exc}: {exc.filename or ''}\n")
        return EXIT_USAGE
    for message in dict.fromkeys(" ".join(str(w.message).split()) for w in caught):
        sys.stderr.write(f"beam-damage {args.command}: warning: {message}\n")
    exit_code = int(result.pop("exit_code", 0)) if isinstance(result, dict) else 0
    if getattr(args, "json", False):
        try:
            json.dump(to_jsonable(result), sys.stdout, indent=None, allow_nan=False)
            sys.stdout.write("\n")
            sys.stdout.flush()
        except BrokenPipeError:  # e.g. piped into `head`
            sys.stderr.close()
    return exit_code


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
