"""Circular complex Gaussian noise: the measurement noise the simulated FRFs and mode shapes carry."""

from __future__ import annotations

import numpy as np

__all__ = ["complex_normal"]


def complex_normal(rng: np.random.Generator, shape, scale=None) -> np.ndarray:
    """``scale (x + i y) / sqrt(2)``, ``x`` and ``y`` standard normal (every real part drawn from ``rng`` before
    every imaginary part): complex noise of variance ``scale^2`` (1 without ``scale``; an array broadcasts), shape
    ``shape``."""
    z = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
    return (z if scale is None else scale * z) / np.sqrt(2)
