"""A tracked pole far from its reference mode confirmed by the narrow-band re-identification around the mode.

The assignment of :func:`learn.monitor.tracking.track_modes` gives a reference mode the pole of the identification
over the series' band nearest it within its band. Where the band is wider than ``TOLERANCE_SIGMAS`` robust standard
deviations of the mode's baseline scatter (its floor :data:`~learn.monitor.tracking.MIN_TOLERANCE`, the 2.5 % core
window, or a baseline reading further off), a spurious pole can take the mode's place: a mode the identification
split into two poles either side of it, one of them in the band. Such a pole is checked by identifying the record
again over the mode's search band (the re-identification of :func:`learn.monitor.tracking.refit_missing`, the same
band and cache entry, :func:`learn.monitor.tracking.search_bands_hz`): a pole of that identification nearer the
tracked pole than the reference frequency confirms it (a moved mode stays moved); where none does, the pole of that
identification nearest the reference within the tracking band is added to the test and takes the mode's place in
the one-to-one assignment (the tracked pole stays in the test, unassigned).
"""

from __future__ import annotations

import numpy as np

from learn.monitor.identification import IdentificationSettings, with_narrow_band_poles
from learn.monitor.tracking import (TOLERANCE_SIGMAS, ReferenceModes, narrow_identifier, search_bands_hz,
                                    shape_accepts, track_modes)
from learn.pairs.measured import refit_missing_modes

__all__ = ["far_from_reference", "confirm_far_poles"]


def far_from_reference(F, ref: ReferenceModes) -> np.ndarray:
    """Shape (n, m) bool: the tracked frequencies ``F`` (Hz, (n, m), NaN where missing) beyond
    ``TOLERANCE_SIGMAS`` robust standard deviations of their reference mode's baseline scatter in ``ln f`` (the
    width the band has where that scatter sets it)."""
    with np.errstate(invalid="ignore"):
        d = np.abs(np.log(np.asarray(F, float) / ref.frequencies_hz[None]))
    return np.nan_to_num(d, nan=0.0) > TOLERANCE_SIGMAS * ref.log_std[None]


def confirm_far_poles(tests: list, files: list, ref: ReferenceModes, settings: IdentificationSettings,
                      cache_dir=None, pending: list | None = None) -> list:
    """``tests`` with each tracked pole far from its reference mode (:func:`far_from_reference`) checked by the
    narrow-band re-identification over the mode's search band (:func:`learn.monitor.tracking.search_bands_hz`,
    within the record's lines; cached as :func:`learn.monitor.identification.cached_identification`, ``pending`` as
    there).

    A pole of that identification nearer the tracked pole than the reference frequency (in ``ln f``; with shapes
    of 2 or more sensors, MAC >= :data:`MAC_MIN` with the reference shape) confirms it; where none does, the one
    nearest the reference within the mode's tolerance (and MAC), when nearer it than the tracked pole, is added to
    the test
    (:func:`~learn.monitor.identification.with_narrow_band_poles`), so that the assignment gives it the mode.
    A tracked pole that a narrow-band identification found already, a test of modal data, and a re-identification
    that fails or finds nothing leave the test as it is.
    """
    F, _, _, cols = track_modes(tests, ref)
    far = far_from_reference(F, ref)
    ln_ref = np.log(ref.frequencies_hz)
    out = list(tests)
    for i in np.flatnonzero(far.any(axis=1)):
        t = tests[i]
        if t is None or t.kind == "modal":
            continue
        narrow = t.narrow_band_hz or [None] * t.frequencies_hz.size
        check = [j for j in np.flatnonzero(far[i]) if narrow[cols[i, j]] is None]   # a narrow band's pole: as found

        def accept(found, j, i=i):
            lg, lt = np.log(found.frequencies_hz), np.log(F[i, j])
            ok = np.broadcast_to(shape_accepts(ref, found, j), lg.shape)
            if np.any(ok & (np.abs(lg - lt) < np.abs(lg - ln_ref[j]))):
                return np.zeros(lg.size, bool)              # the narrow band sees the tracked pole: kept
            return ok & (np.abs(lg - ln_ref[j]) < abs(lt - ln_ref[j]))

        for _, found, k, _, _ in refit_missing_modes(check, ref.frequencies_hz, ref.tolerance, search_bands_hz(ref),
                                                     t.band_hz, narrow_identifier(files[i], settings, cache_dir,
                                                                                  pending), accept):
            out[i] = with_narrow_band_poles(out[i], found, [k])
    return out
