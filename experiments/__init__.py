"""The ``beam-damage`` command line (``cli.py``, one ``cmd_*`` module per command), studies and benchmarks.

Commands only parse arguments, call the libraries (``physics``, ``datagen``,
``learn``) and print; nothing outside this package imports it.
"""

__all__ = ["cli"]


def __getattr__(name):
    """``experiments.cli`` loads on first use, so ``python -m experiments.<tool>`` does not pay for the CLI."""
    if name == "cli":
        import importlib

        return importlib.import_module("experiments.cli")
    raise AttributeError(f"module 'experiments' has no attribute {name!r}")
