"""The identification methods, in one table: :data:`METHODS`: from FRFs (:func:`~physics.identification.identify_frf`)
and output-only, from response records (:func:`~physics.identification.identify_records`).

``beam-damage identify`` takes its ``--method`` choices and help from this table, and reports each method's
:attr:`MethodSpec.uncertainty` beside the one-sigma values it gives.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np

from physics.errors import ShapeError
from physics.frf import convert_frf, pole_residue
from physics.identification.fdd import identify_fdd
from physics.identification.fft_peak import identify_fft_peaks
from physics.identification.free_decay import identify_era
from physics.identification.lscf import identify_lscf
from physics.identification.sdof import circle_fit, peak_picking
from physics.identification.ssi import identify_ssi
from physics.io import MeasuredFRF

__all__ = ["MAX_LSCF_VALUES", "METHODS", "MethodSpec"]


#: Largest lines x responses an LSCF identification takes (its cost grows with both).
MAX_LSCF_VALUES = 100_000


@dataclass(frozen=True)
class MethodSpec:
    """One identification method of :func:`~physics.identification.identify_frf`.

    Attributes
    ----------
    fit : callable
        ``fit(frf, drive, n_modes, **options)`` on a band-limited :class:`~physics.io.MeasuredFRF` (no 0 Hz
        line), ``drive`` the ``(response_row, reference_column)`` of the driving point or None; returns
        ``(estimate, synthesised, diagram, out_of_band_hz)``: the :class:`ModalEstimate`, the identified model
        on the FRF's lines in its kind and units, the :class:`StabilisationDiagram` (or None) and the natural
        frequencies (Hz) of poles outside the band that the fit used.
    help : str
        One line: what the method does.
    uncertainty : tuple of (str, str)
        ``(fields, meaning)``: what each of the method's one-sigma fields of :class:`ModalEstimate` means.
    yields_uncertainty : bool
        Whether ``frequency_std_hz`` and ``damping_std`` are finite (NaN otherwise).
    options : tuple of str
        Keyword arguments of ``identify_frf`` besides ``band_hz`` and ``n_modes`` that the method takes
        (passed on to ``fit``).
    data : str
        ``"frf"``, or ``"records"`` for an output-only method: then ``fit(signals, sampling_frequency_hz,
        band_hz, n_modes, where, **options)`` on response records ``(n_channels, n_samples)`` returns
        ``(estimate, diagram)`` with unscaled, unit-norm shapes.
    stationary : bool
        An output-only method that assumes a stationary response (its spectra or correlations averaged over the
        whole record): ``identify`` warns when it is named for a free response.
    """

    fit: Callable
    help: str
    uncertainty: tuple[tuple[str, str], ...]
    yields_uncertainty: bool
    options: tuple[str, ...] = ()
    data: str = "frf"
    stationary: bool = False


def _fit_lscf(frf: MeasuredFRF, drive, n_modes, max_order):
    """LSCF poles and LSFD residues (:func:`identify_lscf`) fitted to the FRFs in their own kind."""
    f = frf.frequency_hz
    if f.size * len(frf.response_dofs) > MAX_LSCF_VALUES:
        raise ShapeError(f"{frf.metadata.get('source', 'FRF')}: {f.size} lines x {len(frf.response_dofs)} responses "
                         f"exceed the {MAX_LSCF_VALUES} values LSCF fits in reasonable time; select a band "
                         "(band_hz) with fewer lines")
    res = identify_lscf(f, np.asarray(frf.frf), n_modes=n_modes, drive=drive, max_order=max_order, kind=frf.kind)
    return res.estimate, res.fit.synthesised, res.diagram, res.out_of_band_hz


def _fit_receptance(estimator, frf: MeasuredFRF, drive, n_modes):
    """``estimator(frequency_hz, receptance, n_modes=, drive=)`` on the receptances; its model in the FRF's kind."""
    f, w = frf.frequency_hz, frf.omega_rad_s
    est = estimator(f, np.asarray(frf.to_kind("receptance").frf), n_modes=n_modes, drive=drive)
    synth = convert_frf(pole_residue(est.eigenvalues, est.residues, w), w, "receptance", frf.kind)
    return est, synth, None, np.zeros(0)


def _fit_ssi(signals, fs, band_hz, n_modes, where, max_order, mode_in_band=False, refine_decays=None, free=None):
    res = identify_ssi(signals, fs, band_hz, n_modes, max_order=max_order, where=where, mode_in_band=mode_in_band,
                       refine_decays=refine_decays, free=free)
    return res.estimate, res.diagram


def _fit_era(signals, fs, band_hz, n_modes, where, max_order):
    res = identify_era(signals, fs, band_hz, n_modes, max_order=max_order, where=where)
    return res.estimate, res.diagram


def _fit_fdd(signals, fs, band_hz, n_modes, where, enhanced):
    return identify_fdd(signals, fs, band_hz, n_modes, enhanced=enhanced, where=where).estimate, None


def _fit_fft_peak(signals, fs, band_hz, n_modes, where, quantity=None):
    return identify_fft_peaks(signals, fs, band_hz, n_modes, where=where, quantity=quantity)[0], None


#: Identification methods by name.
METHODS: dict[str, MethodSpec] = {
    "lscf": MethodSpec(
        _fit_lscf,
        "poly-reference LSCF poles with automatic stabilisation-diagram selection, each refined by output error in "
        "its own narrow band of the FRFs where the two disagree, then LSFD residues with lower/upper residuals",
        (("frequency_std_hz, damping_std", "spread of the pole over the LSCF model orders of its cluster "
                                           "(sensitivity to model order, not a confidence interval)"),
         ("frequency_fit_std_hz, damping_fit_std", "one sigma from the LSFD fit itself: variable-projection "
                                                   "covariance of the poles given every FRF and its residual")),
        yields_uncertainty=True, options=("max_order",)),
    "circle": MethodSpec(
        partial(_fit_receptance, circle_fit),
        "Nyquist circle fit of every mode in every FRF (eq. 3.13)",
        (("frequency_std_hz, damping_std", "weighted scatter of the circle fits over the FRFs"),),
        yields_uncertainty=True),
    "peak": MethodSpec(
        partial(_fit_receptance, peak_picking),
        "peak picking with half-power damping (eqs. 3.33/3.34)",
        (("frequency_std_hz, damping_std", "none (NaN)"),),
        yields_uncertainty=False),
    "ssi": MethodSpec(
        _fit_ssi,
        "output-only: covariance-driven stochastic subspace identification (SSI-cov) of response records, with "
        "automatic stabilisation-diagram selection",
        (("frequency_std_hz, damping_std", "standard error from the spread of the mode over segments of the "
                                           "record (divided by sqrt of their number)"),),
        yields_uncertainty=True, options=("max_order",), data="records", stationary=True),
    "era": MethodSpec(
        _fit_era,
        "output-only, free responses (impacts or plucks without the force): the decays after the hits by the "
        "Eigensystem Realisation Algorithm with automatic stabilisation-diagram selection, the poles refined by a "
        "nonlinear least-squares fit of damped sinusoids to the samples, then each in its own narrow band of the "
        "decays' Fourier transforms; the natural frequency |lambda| / 2 pi of each pole",
        (("frequency_std_hz, damping_std", "one sigma from the narrow-band fit of the decays (covariance of the "
                                           "poles with the amplitudes and background unknown; noise white over "
                                           "the band)"),),
        yields_uncertainty=True, options=("max_order",), data="records"),
    "fdd": MethodSpec(
        partial(_fit_fdd, enhanced=False),
        "output-only: frequency-domain decomposition (peaks of the first singular value of the output "
        "cross-spectra; no damping)",
        (("frequency_std_hz, damping_std", "none (NaN)"),), yields_uncertainty=False, data="records",
        stationary=True),
    "efdd": MethodSpec(
        partial(_fit_fdd, enhanced=True),
        "output-only: enhanced FDD (damping from the log decrement of each peak's SDOF bell in the time domain)",
        (("frequency_std_hz, damping_std", "none (NaN)"),), yields_uncertainty=False, data="records",
        stationary=True),
    "fftpeak": MethodSpec(
        _fit_fft_peak,
        "output-only baseline: peaks of the zero-padded FFT of the whole record (no window on a free decay, Hann "
        "on a stationary one), parabolic interpolation of the log magnitude; half-power damping where the peak is "
        "wider than the window's; the natural frequency is the spectrum's peak converted by the recorded quantity "
        "(an acceleration's peaks at f_n / sqrt(1 - 2 zeta^2)), which the force's spectrum and coherent neighbours "
        "move (era and ssi return the pole's |lambda| / 2 pi)",
        (("frequency_std_hz, damping_std", "none (NaN)"),), yields_uncertainty=False, data="records"),
}
