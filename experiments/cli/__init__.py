"""The ``beam-damage`` command line: parse, call, print.

Each sub-command is a row of :data:`COMMANDS` (its module and its one-line help) and lives in that module,
which exposes ``add_parser(subparsers)``: it registers the parser (``subparsers.add_parser(name,
description=...)``, the help line coming from the row) and sets ``func`` to a callable ``run(args) -> dict``
and, optionally, ``flags``: a mapping from library parameter names to its
options (``{"n_elements": "--elements"}``), so that an error about a parameter
(:attr:`physics.errors.BeamDamageError.parameter`) is reported with the flag.
``run`` returns a JSON-serialisable result and, for text output, may print a
human-readable view itself (only when ``args.json`` is false). Errors derived
from :class:`physics.errors.BeamDamageError` (and ``OSError`` on user files)
become one line on stderr and exit code 2; warnings raised while a command runs are dropped when it fails
(the error line is the whole story) and otherwise printed on stderr after it, one line each
(``beam-damage COMMAND: warning: ...``), with, in text mode, those its result lists under ``"warnings"`` (a
command does not print them itself; with ``--json`` they stay in the JSON, and those raised are added to a dict
result's ``"warnings"``). Commands run with one BLAS thread:
their matrices are small (at most a few hundred DOFs, batched), where more threads only add overhead and, on a
shared machine, slow a command down many times; parallel work uses processes (``generate --workers``) or torch threads.
"""

from __future__ import annotations

import argparse
import errno
import importlib
import json
import os
import signal
import sys
import threading
import warnings
from importlib.metadata import PackageNotFoundError, version
from typing import NamedTuple

from threadpoolctl import threadpool_limits

from experiments.cli.args import check_out_dir, check_out_file
from physics.errors import BeamDamageError
from physics.io import to_jsonable

__all__ = ["COMMANDS", "Command", "build_parser", "main", "result_warnings"]


class Command(NamedTuple):
    """A sub-command: the module registering its parser (``add_parser(subparsers)``) and its one-line help."""

    module: str
    help: str


#: Sub-command name -> its module and help line, in the order ``--help`` lists them. The top ``--help`` reads
#: only this table and a command imports only its own module (start-up pays for no other command's imports).
COMMANDS = {
    "validate": Command("experiments.studies.validate", "reproduce the thesis's examples and tables, check by check"),
    "model": Command("experiments.cli.cmd_model", "FE matrices and natural frequencies of a preset beam or beam file"),
    "update": Command("experiments.cli.cmd_update",
                      "identify C and update K from measured complex modes (Lancaster/Pilkey)"),
    "identify": Command("experiments.cli.cmd_identify", "identify natural frequencies, damping and complex modes "
                                                        "from measured FRFs or, output-only, from response records"),
    "estimate": Command("experiments.cli.cmd_estimate",
                        "estimate FRFs (H1/H2/Hv, coherence) from force and response time records"),
    "demo": Command("experiments.studies.demo",
                    "run the main job: thesis, discrepancy, dataset, classifier, beam 5, report"),
    "generate": Command("experiments.cli.cmd_generate",
                        "generate a dataset of specimens tested twice (baseline, current), updated models"),
    "inspect": Command("experiments.cli.cmd_inspect",
                       "summarise a generated dataset and plot labels, shift-vs-position and FRF overlays"),
    "experiment": Command("experiments.cli.cmd_experiment", "run a study and write its report (HTML + Markdown)"),
    "export": Command("experiments.cli.cmd_export", "write chosen samples' FRFs (synthesised) as measurement files"),
    "discrepancy": Command("experiments.cli.cmd_discrepancy",
                           "find where the model misses measured data and name the missing effect"),
    "train": Command("experiments.cli.cmd_train",
                     "train the damage classifier (detect, localise, size damage) on datasets"),
    "evaluate": Command("experiments.cli.cmd_evaluate",
                        "score a trained classifier and the classical methods on datasets"),
    "classify": Command("experiments.cli.cmd_classify",
                        "classify measured beams against their baseline with a trained model"),
    "monitor": Command("experiments.cli.cmd_monitor", "monitor a series of tests: normal variation learnt on a "
                                                      "baseline period, alarms at a chosen false-alarm rate"),
}

EXIT_USAGE = 2
#: Exit codes of a command ended by SIGINT (Ctrl-C) and SIGTERM: 128 + the signal number, as shells report them.
EXIT_SIGINT = 128 + signal.SIGINT
EXIT_SIGTERM = 128 + signal.SIGTERM


class Terminated(BaseException):
    """Raised in the main thread on SIGTERM, so a command unwinds (temporary files removed) as on Ctrl-C."""


def _raise_terminated(signum, frame):
    raise Terminated()


def one_line(text: str) -> str:
    """``text`` as one printable line: control characters (a newline in a file name) escaped, and lone
    surrogates (a file name that is not UTF-8) written as ``\\udcXX``."""
    text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(text))
    return text.encode("utf-8", "backslashreplace").decode("utf-8")


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line and exit code 2."""

    def error(self, message):
        sys.stderr.write(f"beam-damage: error: {message}\n")
        raise SystemExit(EXIT_USAGE)


class _Commands(argparse._SubParsersAction):
    """The sub-parsers: a command's help line is its :data:`COMMANDS` row's (its module does not repeat it)."""

    def add_parser(self, name, **kwargs):
        return super().add_parser(name, help=COMMANDS[name].help, **kwargs)


def build_parser(argv=None) -> argparse.ArgumentParser:
    """The ``beam-damage`` parser for ``argv``: the command ``argv`` names gets its module's parser (only that
    module is imported); every other command is listed by its :data:`COMMANDS` help line."""
    parser = _Parser(
        prog="beam-damage",
        description="Vibration-based model updating and damage detection of beams.",
    )
    try:
        ver = version("beam-damage")
    except PackageNotFoundError:  # running from a source tree
        ver = "unknown"
    parser.add_argument("--version", action="version", version=f"beam-damage {ver}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser, action=_Commands)
    sub.required = True
    first = next((a for a in (argv or []) if not a.startswith("-")), None)
    for name, command in COMMANDS.items():
        if name == first:
            importlib.import_module(command.module).add_parser(sub)
        else:
            sub.add_parser(name)
    return parser


def _on_path(a: str, b: str) -> bool:
    """Whether one of the paths ``a``, ``b`` lies on the other's (the same, or one a folder of the other)."""
    pa, pb = os.path.abspath(a), os.path.abspath(b)
    return pa == pb or pa.startswith(pb + os.sep) or pb.startswith(pa + os.sep)


def _check_out(parser, args) -> None:
    """Refuse a command's ``--out`` that cannot be written before it runs: a file (metavar ``FILE``) or else a
    directory (:func:`experiments.cli.args.check_out_file`, :func:`~experiments.cli.args.check_out_dir`)."""
    if not getattr(args, "out", None):
        return
    sub = next(a for a in parser._actions if a.dest == "command").choices[args.command]
    out = next((a for a in sub._actions if a.dest == "out"), None)
    (check_out_file if out is not None and out.metavar == "FILE" else check_out_dir)(args.out)


def result_warnings(result) -> list[str]:
    """The ``"warnings"`` a command's result holds (a dict, or a list of dicts: one per input), in order."""
    items = result if isinstance(result, list) else [result]
    return [str(w) for r in items if isinstance(r, dict) for w in r.get("warnings") or ()]


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(argv)
    args = parser.parse_args(argv)
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        with warnings.catch_warnings(record=True) as caught, threadpool_limits(1, user_api="blas"):
            warnings.simplefilter("default")
            _check_out(parser, args)
            result = args.func(args)
    except BeamDamageError as exc:
        flag = getattr(args, "flags", {}).get(exc.parameter)
        sys.stderr.write(one_line(f"beam-damage {args.command}: error: {f'{flag}: ' if flag else ''}{exc}") + "\n")
        return EXIT_USAGE
    except BrokenPipeError:  # output piped into `head` and closed: not an error of the user's input
        sys.stderr.close()
        return 0
    except OSError as exc:
        where = f": {exc.filename}" if exc.filename else ""
        out = getattr(args, "out", None)
        if out and exc.filename and _on_path(str(exc.filename), str(out)):     # the output named by its flag
            where += f" (--out {out}: cannot be written there)"
        kept = ("; nothing was half-written: files from before are as they were, and generate resumes from its "
                "complete shards") if exc.errno in (errno.ENOSPC, errno.EDQUOT) else ""
        sys.stderr.write(one_line(f"beam-damage {args.command}: error: {exc.strerror or exc}{where}{kept}") + "\n")
        return EXIT_USAGE
    except KeyboardInterrupt:
        sys.stderr.write(f"beam-damage {args.command}: interrupted (SIGINT)\n")
        return EXIT_SIGINT
    except Terminated:
        sys.stderr.write(f"beam-damage {args.command}: terminated (SIGTERM)\n")
        return EXIT_SIGTERM
    finally:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, previous)
    messages = [str(w.message) for w in caught] + result_warnings(result)      # on stderr with --json too
    for message in dict.fromkeys(" ".join(m.split()) for m in messages):
        sys.stderr.write(one_line(f"beam-damage {args.command}: warning: {message}") + "\n")
    if getattr(args, "json", False) and isinstance(result, dict) and caught:    # and in the JSON's "warnings"
        said = list(result.get("warnings") or [])
        result["warnings"] = said + [m for m in dict.fromkeys(" ".join(str(w.message).split()) for w in caught)
                                     if m not in said]
    exit_code = int(result.pop("exit_code", 0)) if isinstance(result, dict) else 0
    if getattr(args, "json", False):
        try:
            json.dump(to_jsonable(result), sys.stdout, indent=None, allow_nan=False)
            sys.stdout.write("\n")
            sys.stdout.flush()
        except BrokenPipeError:  # e.g. piped into `head`
            sys.stderr.close()
    return exit_code

