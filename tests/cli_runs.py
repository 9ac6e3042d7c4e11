"""The command line run in a test: ``main(argv)``'s exit code and what it printed."""

from experiments.cli import main

__all__ = ["run_cli"]


def run_cli(capsys, argv):
    """``main(argv)``: its exit code, standard output and standard error (read from ``capsys``)."""
    code = main(argv)
    cap = capsys.readouterr()
    return code, cap.out, cap.err
