"""The first stage of ``classify`` (:func:`learn.pairs.classify.classify_pairs`): the inputs' modes, identified from FRF
files, the (baseline, current) pairs they form and the feature rows the network reads."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from learn.network.features import frf_features, frequency_features, map_frf_to_grid, modal_features, with_missing_modes
from learn.pairs.measured import (FREQUENCIES_ONLY, IDENTIFICATION, IDENTIFICATION_BAND_FACTOR, frf_rows,
                                  identification_band_hz, identify_band, identify_modes, modal_pair,
                                  pair_modes_by_frequency, pairing_bands, refit_missing_modes)
from learn.network.model_dir import TrainedModel
from learn.network.mode_count import mode_count_problem
from learn.pairs.normal_variation import measure
from learn.pairs.verdict import modes_text
from physics.errors import BeamDamageError
from physics.identification import METHODS
from physics.io import MeasuredFRF
from physics.modal import modal_parameters

__all__ = ["DAMPING_RANGE_FACTOR", "PairInputs", "damping_warning", "identification_warning", "mode_features",
           "network_reads", "pair_inputs", "refit_frf_modes"]


@dataclass(frozen=True)
class PairInputs:
    """The first stage: the tests' modes, the (baseline, current) pairs they form and what the network reads.

    Attributes
    ----------
    names : tuple of str           the reference baseline's, then each current input's
    identified : bool              the modes were identified from FRF files
    warnings : tuple of str        shared by every pair
    baseline : ModalData or None   the reference baseline's modes (None: the FRFs could not be identified)
    currents, baselines : tuple of ModalData or None
    pairs : tuple of :class:`learn.pairs.measured.ModalPair` or None, one per current input
    normal_variation : :class:`learn.pairs.normal_variation.NormalVariation` or None (one baseline)
    baseline_pairs : tuple of ModalPair or None   the reference baseline paired with each other baseline
    route : str                    the network's input route
    features : ndarray (r, p) or None   the rows the network reads (:func:`pair_inputs`)
    rows : tuple of int            the inputs those rows belong to
    baseline_features : ndarray (k, p) or None   the modal or frequency network's rows of the baseline pairs that
                                   hold every mode (None: none, or another route)
    """

    names: tuple
    identified: bool
    warnings: tuple = ()
    baseline: object = None
    currents: tuple | None = None
    baselines: tuple | None = None
    pairs: tuple | None = None
    normal_variation: object = None
    baseline_pairs: tuple | None = None
    route: str = ""
    features: object = None
    rows: tuple = ()
    baseline_features: object = None

    def pair(self, i: int):
        """The ``i``-th pair, None without modes."""
        return self.pairs[i] if self.pairs else None


def pair_inputs(model: TrainedModel, baseline, currents: list, names: list[str] | None = None,
                methods: list | None = None) -> PairInputs:
    """The first stage of :func:`classify_pairs`: the inputs' modes (identified from FRF files), their pairs and
    the network's feature rows; a pair with fewer common modes than a modal or frequency network reads is refused
    (:func:`learn.network.mode_count.mode_count_problem`)."""
    baselines = list(baseline) if isinstance(baseline, (list, tuple)) else [baseline]
    nb = len(baselines)
    names = (list(names) if names else
             (["baseline"] if nb == 1 else [f"baseline {k + 1}" for k in range(nb)])
             + [f"measured {k + 1}" for k in range(len(currents))])
    inputs = _measured_pairs(model, baselines, currents, names)
    ref = 0 if inputs.normal_variation is None else inputs.normal_variation.reference
    inputs = _network_inputs(model, inputs, baselines[ref], currents, methods)
    for p, n in zip(inputs.pairs if inputs.route in ("modal", "frequency") else (), inputs.names[1:]):
        found = (f"{n}: {p.mode_index.size} of modes {modes_text(model.beam.modes)} found in both it and "
                 f"{inputs.names[0]} (" + "; ".join(p.missing) + ")")
        problem = mode_count_problem(p.mode_index.size, found)
        if problem:
            raise BeamDamageError(problem)
    return inputs


def _measured_pairs(model: TrainedModel, baselines: list, currents: list, names: list[str]) -> PairInputs:
    """The inputs' modal data and the modes each (baseline, current) pair holds, without the network's features;
    the modal data and pairs None when the FRFs could not be identified (an FRF-input model then reads the FRFs
    alone). With several baselines the pairs compare with the reference baseline of their normal variation."""
    nb, sens = len(baselines), model.sensitivity
    mds, identified, found = _modal_inputs(model, [*baselines, *currents], names, sens)
    if mds is None:                            # ``found``: why the identification failed
        if nb > 1:
            raise BeamDamageError(f"several baseline tests need their modes, and {found}")
        return PairInputs((names[0], *names[nb:]), identified, (f"{found}: no classical answer; the FRF-route "
                                                                "network alone",))
    found = found or [None] * len(names)
    nv = measure(mds[:nb], model.beam, sens.frequencies_hz, names[:nb]) if nb > 1 else None
    if nv is not None and identified:          # a mode of the baselines missed: identified again over its band
        target_hz, band = nv.targets
        again = [refit_frf_modes(d, md, target_hz, band, nv.counts > 0, n)
                 for d, md, n in zip([*baselines, *currents], mds, names)]
        if any(t for _, t in again):
            mds = [md for md, _ in again]
            found = [f if not t else f"{f}; " + ", ".join(f"mode {model.beam.modes[j]} at {hz:.5g} Hz by LSCF over "
                                                          f"{lo:.5g}-{hi:.5g} Hz" for j, hz, lo, hi in t)
                     for f, (_, t) in zip(found, again)]
            nv = measure(mds[:nb], model.beam, sens.frequencies_hz, names[:nb])
    r = 0 if nv is None else nv.reference
    base_md = mds[r]
    target_hz, band = (sens.frequencies_hz, None) if nv is None else nv.targets
    pairs = [modal_pair(base_md, c, model.beam, target_hz, (names[r], n), (found[r], f), band)
             for c, n, f in zip(mds[nb:], names[nb:], found[nb:])]
    own = None if nv is None else tuple(modal_pair(base_md, mds[k], model.beam, target_hz, tolerance=band)
                                        for k in range(nb) if k != r)
    warnings = list(dict.fromkeys(w for p in pairs for w in p.warnings))
    w = damping_warning(model, pairs)
    return PairInputs((names[r], *names[nb:]), identified, tuple(warnings + [w] * bool(w)), base_md,
                      tuple(mds[nb:]), tuple(mds[:nb]), tuple(pairs), nv, own)


#: How far outside the training's damping ratios a baseline may lie before :func:`damping_warning` speaks (factor).
DAMPING_RANGE_FACTOR = 2.0


def damping_warning(model: TrainedModel, pairs: list) -> str | None:
    """One line when the baseline's damping ratios lie beyond :data:`DAMPING_RANGE_FACTOR` times the training pairs'
    range (``damping_ratio_range`` of the model: the central 99 % of the training's measured baseline ratios),
    else None: the modal noise the model was trained with depends on the damping (an output-only identification's
    frequency scatter grows with its square root)."""
    trained = model.config.get("damping_ratio_range")
    pair = next((p for p in pairs if p is not None and p.mode_index.size), None)
    if pair is None or not trained:
        return None

    lo, hi = np.asarray(trained, float)[pair.mode_index].T
    zeta = modal_parameters(pair.eigenvalues[0])[1]
    given = np.isfinite(zeta) & (zeta > 0)                                # frequencies alone carry no damping
    out = given & ((zeta < lo / DAMPING_RANGE_FACTOR) | (zeta > hi * DAMPING_RANGE_FACTOR))
    if not out.any():
        return None
    modes = [model.beam.modes[j] for j in pair.mode_index[out]]
    return (f"the baseline's damping ratios of mode(s) {', '.join(map(str, modes))} ("
            + ", ".join(f"{100 * z:.3g} %" for z in zeta[out]) + ") lie beyond twice the training's ("
            + ", ".join(f"{100 * a:.3g}-{100 * b:.3g} %" for a, b in zip(lo[out], hi[out]))
            + "): the modal noise the model was trained with depends on the damping; generate with "
              "specimen.damping_ratios set to the test's")


def _modal_inputs(model: TrainedModel, inputs: list, names: list[str], sens):
    """Modal data of every input: ``(list of ModalData, identified, found)``, ``found`` one text per input on the
    modes it holds (e.g. "LSCF/LSFD found 2 modes in 2-500 Hz"); when an FRF-route model's input cannot be
    identified, ``(None, True, why)`` (e.g. "baseline: LSCF/LSFD identification failed (LinAlgError: ...)")."""
    kinds = {isinstance(d, MeasuredFRF) for d in inputs}
    if len(kinds) > 1:
        raise BeamDamageError("BASELINE and MEASURED must all be FRF files or all modal data")
    if not kinds.pop():
        return list(inputs), False, None
    test = model.beam.test
    if test is None:
        fmax, fmin = IDENTIFICATION_BAND_FACTOR * float(sens.frequencies_hz[3]), 0.0
    else:
        fmin, fmax = test.band_hz
    try:  # the thesis's test: its 4 modes; another test: as 'identify --band' does, then paired by frequency
        ids = [identify_modes(d, fmax, n) if test is None else identify_band(d, test.band_hz, n)
               for d, n in zip(inputs, names)]
    except BeamDamageError as exc:
        if model.route == "modal":
            raise
        return None, True, " ".join(str(exc).split())     # an FRF-route model classifies the FRFs without modes
    ids = [replace(md, eigenvectors=None, dofs=()) if FREQUENCIES_ONLY in d.metadata else md     # one sensor
           for d, md in zip(inputs, ids)]
    found = []
    for d, md in zip(inputs, ids):
        k = md.eigenvalues.size
        lo, hi = identification_band_hz(d, fmax, fmin)
        found.append(f"LSCF/LSFD found {k} mode{'s' * (k != 1)} in {lo:.4g}-{hi:.4g} Hz")
    return ids, True, found


def _frf_route_features(model: TrainedModel, baseline, currents, warnings: list):
    """Grid features of the model's FRF route for (baseline, current) FRF pairs, or None if the files lack DOFs."""
    rows_b = frf_rows(baseline, model.beam)
    rows_c = [frf_rows(c, model.beam) for c in currents]
    if rows_b[0] is None or any(r[0] is None for r in rows_c):
        return None
    if model.route == "updated":
        warnings.append("the updated-model route is fed with the measured FRFs (no updating of measured FRFs here)")

    def grid(r):
        H, f = r
        w, g = f.omega_rad_s, model.beam.grid_rad_s
        if w[0] > g[0] * 1.001 or w[-1] < g[-1] * 0.999:
            msg = (f"FRF lines cover {w[0]:.4g}-{w[-1]:.4g} rad/s, the model's grid "
                   f"{g[0]:.4g}-{g[-1]:.4g} rad/s: nearest values used outside")
            if msg not in warnings:
                warnings.append(msg)
        return map_frf_to_grid(H, w, g)

    gb = grid(rows_b)
    return frf_features(np.stack([np.stack([gb, grid(r)]) for r in rows_c]))


def network_reads(est, pair) -> bool:
    """Whether the modal or frequency network ``est`` answers ``pair``: it holds every mode of the model, or the
    network answers missing modes (``est.answers_missing_modes``) and the pair holds ``est.min_modes`` or more."""
    return pair.complete or (est.answers_missing_modes and pair.mode_index.size >= est.min_modes)


def mode_features(model: TrainedModel, route: str, pairs: list, rows: list):
    """The ``modal`` or ``frequency`` features of ``pairs[rows]`` on the model's modes (NaN in the columns of a mode
    a pair lacks), None for no rows."""
    if not rows:
        return None
    m = model.beam.n_modes
    parts = [with_missing_modes(pairs[i].eigenvalues[None], pairs[i].eigenvectors[None], pairs[i].mode_index, m)
             for i in rows]
    lam, vecs = np.concatenate([a for a, _ in parts]), np.concatenate([b for _, b in parts])
    return frequency_features(lam, m) if route == "frequency" else modal_features(lam, vecs, m, model.beam.test)


def _network_inputs(model: TrainedModel, inputs: PairInputs, baseline, currents: list, methods=None) -> PairInputs:
    """``inputs`` with the network's route, feature rows and the inputs they belong to (and their warnings).

    The features are the FRF-route features of every pair when the model reads FRFs and the inputs are FRF files
    (``baseline``, ``currents``), else the modal (or, without shapes, frequency) features of the pairs the network
    reads (:func:`network_reads`; NaN in the columns of a mode a pair lacks; None when there are none).
    """
    pairs, warnings = inputs.pairs, list(inputs.warnings)

    def given(route, X, rows):
        own = inputs.baseline_pairs or ()
        full = [i for i, p in enumerate(own) if p.complete and (route == "frequency" or not p.frequency_only)]
        return replace(inputs, route=route, features=X, rows=tuple(rows), warnings=tuple(warnings),
                       baseline_features=mode_features(model, route, own, full) if route in ("modal", "frequency")
                       else None)

    if inputs.identified and model.route in ("measured", "updated"):
        X = _frf_route_features(model, baseline, currents, warnings)
        if X is not None:
            return given(model.route, X, range(len(currents)))
    if pairs is None:
        raise BeamDamageError(f"the files hold neither the FRFs the model's {model.route} route reads "
                              "nor identifiable modes")
    if any(p.frequency_only for p in pairs):
        if "frequency" not in model.networks:
            raise BeamDamageError("natural frequencies without mode shapes need a model with a frequency-route "
                                  "network: re-create it with 'beam-damage train'")
        rows = [i for i, p in enumerate(pairs) if network_reads(model.networks["frequency"], p)]
        return given("frequency", mode_features(model, "frequency", pairs, rows), rows)
    if "modal" not in model.networks:
        raise BeamDamageError("this model has no modal-route network; give FRF files holding receptances at "
                              f"{', '.join(model.beam.dofs)} driven at {model.beam.dofs[model.beam.drive_row]}")
    rows = [i for i, p in enumerate(pairs) if network_reads(model.networks["modal"], p)]
    X = mode_features(model, "modal", pairs, rows)
    w = identification_warning(model, inputs.identified, methods)
    if w:
        warnings.append(w)
    return given("modal", X, rows)


def _output_only(method) -> bool:
    return method in METHODS and METHODS[method].data == "records"


def identification_warning(model: TrainedModel, identified: bool, methods=None) -> str | None:
    """One line when the inputs' modes were identified otherwise than the training data's modal noise describes
    (``measurement.identification`` of its generator config), else None.

    FRF files (``identified``) are identified here by :data:`IDENTIFICATION`; modal data carry the ``methods``
    that produced them (None: unknown, nothing said). Output-only inputs (SSI-cov, FDD) against FRF-route or
    fixed modal noise, and FRF-route inputs against output-only modal noise, are named.
    """
    trained = model.recorded.measurement.get("identification")
    trained_oo = _output_only((trained or {}).get("method"))
    used = sorted({m for m in (methods or ()) if m is not None})
    oo = [m for m in used if _output_only(m)]
    if oo and not trained_oo:
        what = "the FRF route's LSCF/LSFD" if trained else "fixed stds, not an identification"
        return (f"the training data's modal noise describes {what}, not the output-only identification of these "
                f"modes ({', '.join(oo)}): retrain on data from 'beam-damage generate --modal-noise output-only'")
    frf = identified or any(not _output_only(m) for m in used)
    if frf and trained_oo:
        return ("the training data's modal noise describes the output-only identification (SSI-cov), not the "
                "FRF route's of these modes: retrain on data from 'beam-damage generate' without "
                "--modal-noise output-only")
    if identified and trained != IDENTIFICATION:
        return ("the training data's modal noise was not calibrated against the identification run here: retrain "
                "on data from 'beam-damage generate --config training'")
    return None


def refit_frf_modes(frf, md, target_hz, band, wanted=None, where: str = "FRF file"):
    """``(ModalData, found)``: ``md`` (identified from ``frf``) with the modes no pole of it pairs with found again
    over their own band (:func:`learn.pairs.measured.refit_missing_modes`).

    The modes are those of ``target_hz`` (Hz; those ``wanted``, a bool mask; default all) that no pole of ``md``
    pairs with (:func:`pair_modes_by_frequency` within ``band``); each is looked for from ``f_j / (1 + b_j)`` to
    ``f_j (1 + b_j)`` (:func:`pairing_bands`, within the file's lines) as ``identify --band`` looks
    (:func:`identify_band`). ``found``: ``(j, frequency Hz, lo, hi)`` per mode found so.
    """
    target = np.asarray(target_hz, float)
    tol = pairing_bands(target, band)
    which = pair_modes_by_frequency(np.abs(np.asarray(md.eigenvalues)) / (2 * np.pi), target, band)
    missing = [j for j in range(target.size) if j not in which and (wanted is None or wanted[j])]
    if md.eigenvectors is None or not missing:
        return md, []
    lines = np.asarray(frf.frequency_hz, float)
    lines = lines[lines > 0]

    def identify(lo, hi):
        try:
            found = identify_band(frf, (lo, hi), where)
        except (BeamDamageError, ValueError):
            return None
        return found, np.abs(np.asarray(found.eigenvalues)) / (2 * np.pi)

    def accept(found, j):
        return found.eigenvectors is not None and found.eigenvectors.shape[0] == md.eigenvectors.shape[0]

    got = refit_missing_modes(missing, target, np.log1p(tol), np.c_[target / (1 + tol), target * (1 + tol)],
                              (lines[0], lines[-1]), identify, accept)
    if not got:
        return md, []
    lam = np.array([f.eigenvalues[k] for _, f, k, _, _ in got])
    return (replace(md, eigenvalues=np.r_[md.eigenvalues, lam],
                    eigenvectors=np.c_[md.eigenvectors, np.stack([f.eigenvectors[:, k] for _, f, k, _, _ in got], 1)]),
            [(j, float(np.abs(x) / (2 * np.pi)), float(lo), float(hi)) for (j, _, _, lo, hi), x in zip(got, lam)])
