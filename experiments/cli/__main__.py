"""``python -m experiments.cli``: the ``beam-damage`` command line."""

from experiments.cli import main

raise SystemExit(main())
