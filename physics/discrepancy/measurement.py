"""Measured data of the discrepancy workflow and the noise that whitens its residuals."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from physics.errors import ShapeError
from physics.frf import magnitude_db

__all__ = ["Measurement", "Noise", "frf_scatter_db", "has_complex_shapes"]


@dataclass(frozen=True)
class Noise:
    """Measurement noise (standard deviations) that whitens the residuals.

    Attributes
    ----------
    frequency : float or ndarray, shape (n_modes,)
        Relative std of the natural frequencies (0.003 = 0.3 %).
    damping : float
        Relative std of simulated damping ratios (:func:`simulate_measurement`;
        the analysis takes measured ratios as modal damping, step 3).
    shape : float
        Std of mode-shape entries relative to the largest entry of the mode.
    frf_db : float
        Std of FRF magnitudes (dB).
    """

    frequency: object = 0.003
    damping: float = 0.1
    shape: float = 0.02
    frf_db: float = 1.0


@dataclass(frozen=True)
class Measurement:
    """Measured modal data (and optionally FRFs) on a beam.

    Attributes
    ----------
    frequencies_hz : ndarray, shape (n_modes,)
    damping_ratios : ndarray, shape (n_modes,) or None
    shapes : ndarray, complex, shape (n_points, n_modes) or None
        Mode shapes at ``shape_x_m``; one point (one sensor) compares no shape and is held as None.
    shape_x_m : tuple of float
        Positions (m) of the shape rows.
    frf : ndarray, complex, shape (n_resp, n_ref, n_lines) or None
    frf_frequency_hz : ndarray, shape (n_lines,) or None
    frf_response_x_m, frf_reference_x_m : tuple of float
        Positions of the FRF rows and columns (m).
    frf_kind : {"receptance", "mobility", "accelerance"}
    """

    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray | None = None
    shapes: np.ndarray | None = None
    shape_x_m: tuple = ()
    frf: np.ndarray | None = None
    frf_frequency_hz: np.ndarray | None = None
    frf_response_x_m: tuple = ()
    frf_reference_x_m: tuple = ()
    frf_kind: str = "receptance"

    def __post_init__(self):
        f = np.asarray(self.frequencies_hz, dtype=float)
        if f.ndim != 1 or f.size < 2 or not np.all(np.isfinite(f)) or np.any(f <= 0):
            raise ShapeError("measured frequencies_hz must be a 1-D array of at least 2 positive finite values")
        object.__setattr__(self, "frequencies_hz", f)
        if self.damping_ratios is not None:
            z = np.asarray(self.damping_ratios, dtype=float)
            if z.shape != f.shape or not np.all(np.isfinite(z)) or np.any(z <= 0) or np.any(z >= 1):
                raise ShapeError("measured damping_ratios must be in (0, 1), one per frequency")
            object.__setattr__(self, "damping_ratios", z)
        if self.shapes is not None:
            s = np.asarray(self.shapes, dtype=complex)
            if s.ndim != 2 or s.shape[1] != f.size or s.shape[0] != len(self.shape_x_m):
                raise ShapeError(f"measured shapes must be (n_points, n_modes = {f.size}) with one position per "
                                 "row")
            if s.shape[0] < 2:   # one entry per mode compares no shape (its MAC is 1): no shape residual
                s, xs = None, ()
                object.__setattr__(self, "shape_x_m", xs)
            object.__setattr__(self, "shapes", s)
        if self.frf is not None:
            h = np.asarray(self.frf, dtype=complex)
            if h.shape != (len(self.frf_response_x_m), len(self.frf_reference_x_m), len(self.frf_frequency_hz)):
                raise ShapeError("measured FRF must be (n_resp, n_ref, n_lines) matching its positions and lines")
            object.__setattr__(self, "frf", h)
            object.__setattr__(self, "frf_frequency_hz", np.asarray(self.frf_frequency_hz, dtype=float))

    @property
    def n_modes(self) -> int:
        return self.frequencies_hz.size

    @cached_property
    def frf_db(self) -> np.ndarray:
        """``20 log10 |frf|`` (dB), shape like ``frf`` (computed once)."""
        return magnitude_db(self.frf)

    @cached_property
    def frf_band(self) -> np.ndarray:
        """``(n_lines,)`` index of the measured mode whose band holds each FRF line (computed once).

        Mode ``j``'s band runs from the geometric mean of its frequency and the one below
        (0 for the first) to the geometric mean with the one above (infinity for the last).
        """
        fm = self.frequencies_hz
        edges = np.concatenate([[0.0], np.sqrt(fm[:-1] * fm[1:]), [np.inf]])
        return np.searchsorted(edges, self.frf_frequency_hz, side="right") - 1

    @cached_property
    def frf_band_onehot(self) -> np.ndarray:
        """``(n_lines, n_modes)``: 1 where a line lies in a mode's band (:attr:`frf_band`), else 0."""
        return (self.frf_band[:, None] == np.arange(self.n_modes)[None, :]).astype(float)


def has_complex_shapes(meas: Measurement) -> bool:
    """Measured shapes with imaginary parts (non-proportional damping is visible in them)."""
    return meas.shapes is not None and bool(np.any(np.abs(meas.shapes.imag) > 0))


def frf_scatter_db(meas: Measurement) -> float:
    """Random noise (std, dB) of the measured FRF magnitudes from their line-to-line scatter.

    For independent noise of std ``s`` on each line the second difference along
    frequency has std ``sqrt(6) s``; the smooth FRF adds little between dense
    lines, and the median absolute deviation ignores the peaks. Floored at 0.01 dB.
    """
    x = meas.frf_db.reshape(-1, meas.frf_frequency_hz.size)
    d2 = x[:, 2:] - 2 * x[:, 1:-1] + x[:, :-2]
    mad = np.median(np.abs(d2 - np.median(d2, axis=1, keepdims=True)))
    return max(float(1.4826 * mad / math.sqrt(6)), 0.01)
