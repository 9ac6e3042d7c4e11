"""The ``beam-damage`` command line and the project's tools around it, one sub-package each.

``cli``: the command line (the dispatcher, one ``cmd_*`` module per command); ``studies``: the thesis
reproduction, the demo, the studies and their reports; ``benches``: the benchmarks behind the docs' tables;
``second_sim``: an independent simulator sharing no code with ``physics``, ``datagen`` and ``learn``. Commands
only parse arguments, call the libraries and print; nothing outside this package imports it.
"""

__all__ = []
