"""Simulated datasets of slit-damaged beams: configuration, batched pipeline, store, FRFs on read, loaders."""

from datagen.config import load_config, merge, named_configs
from datagen.parallel import generate
from datagen.report import inspect_dataset
from datagen.store import Dataset, load_torch

__all__ = ["Dataset", "generate", "inspect_dataset", "load_config", "load_torch", "merge", "named_configs"]
