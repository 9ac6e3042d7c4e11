"""Simulated datasets of damaged beams: configuration, damage kinds (:mod:`datagen.damage`), batched pipeline,
store, FRFs on read, loaders.

The names below load their modules on first use (``import datagen.config`` stays light: no pandas, no
workers' machinery, for the command line's parsers).
"""

import importlib

_HOMES = {"Dataset": "datagen.dataset", "load_torch": "datagen.dataset", "generate": "datagen.generation",
          "inspect_dataset": "datagen.inspection", "load_config": "datagen.config", "merge": "datagen.config",
          "named_configs": "datagen.config"}

__all__ = sorted(_HOMES)


def __getattr__(name):
    if name in _HOMES:
        return getattr(importlib.import_module(_HOMES[name]), name)
    raise AttributeError(f"module 'datagen' has no attribute {name!r}")
