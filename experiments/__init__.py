"""The ``beam-damage`` command line (``cli.py``, one ``cmd_*`` module per command), studies and benchmarks.

Commands only parse arguments, call the libraries (``physics``, ``datagen``,
``learn``) and print; nothing outside this package imports it.
"""

__all__ = ["cli"]

from experiments import cli  # noqa: E402
