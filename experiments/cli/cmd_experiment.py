"""``beam-damage experiment NAME``: run one study and write its report.

A study is a module ``experiments.studies.study_*`` with ``run(out_dir) -> (summary, sections)``;
this command runs it into ``--out`` (default ``out/experiments/NAME``) and writes
``report.md`` and a self-contained ``report.html`` there.
"""

from __future__ import annotations

import importlib
from pathlib import Path

from experiments.studies.report import write_report
from physics.errors import BeamDamageError

__all__ = ["add_parser", "run"]


#: Study name -> (module, title).
STUDIES = {
    "thesis": ("experiments.studies.study_thesis", "Thesis reproduction: beam 5, Chapters Four to Six"),
    "discrepancy-study": ("experiments.studies.study_discrepancy",
                          "Discrepancy workflow: beam 5 and the hidden-effect suite"),
    "damage-study": ("experiments.studies.study_damage",
                     "Damage study: network and classical methods by noise, size and position"),
    "benchmark": ("experiments.benches.study_benchmark", "Benchmarks: data generation, training, identification"),
}


def run_study(name: str, out_dir) -> dict:
    """Run study ``name`` into ``out_dir``; returns its summary and the report paths."""
    if name not in STUDIES:
        raise BeamDamageError(f"unknown study {name!r}; expected one of {sorted(STUDIES)}")
    module, title = STUDIES[name]
    try:
        study = importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if not module.startswith(f"{exc.name}."):
            raise
        raise BeamDamageError(f"study {name!r} runs {module}, a tool of the source tree that the installed package "
                              "does not ship; run it from a checkout (python -m experiments.cli experiment "
                              f"{name})") from None
    summary, sections = study.run(out_dir)
    paths = write_report(out_dir, title, sections)
    return {"study": name, "summary": summary, "report": paths}


def run(args) -> dict:
    out = Path(args.out or f"out/experiments/{args.name}")
    result = run_study(args.name, out)
    if not args.json:
        print(f"Study {args.name!r} written to {result['report']['html']} (and report.md)")
    return result


def add_parser(sub):
    p = sub.add_parser("experiment",
                       description="Run one of the studies and write report.md and a self-contained report.html "
                                   f"with its tables and figures. Studies: {', '.join(STUDIES)}.")
    p.add_argument("name", choices=sorted(STUDIES), help="the study to run")
    p.add_argument("--out", default=None, help="output directory (default out/experiments/NAME)")
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.set_defaults(func=run)
