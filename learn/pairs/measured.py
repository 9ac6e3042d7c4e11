"""Measured data made ready for a trained model: on its DOFs, modes identified from FRFs, and paired by frequency
with the nominal beam's modes."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np

from learn.network.features import BeamSpec
from learn.explanations.shapes import real_shapes
from physics.ratio_trend import MIN_PAIR_MAC, RATIO_TOLERANCE, choice_texts, trend_picks
from physics.errors import BeamDamageError
from physics.identification import identify_frf
from physics.identification.failures import identification_failure
from physics.io import (MeasuredFRF, map_frf_dofs, map_measured_dofs, parse_dof, prepare_measured,
                        reference_position_m, sensor_labels)
from physics.layout import MIN_VISIBLE, uniform_shapes
from physics.modal import mac

__all__ = ["BASELINE_PAIR_BAND", "FREQUENCIES_ONLY", "IDENTIFICATION", "IDENTIFICATION_BAND_FACTOR", "MIN_PAIR_MAC",
           "RATIO_TOLERANCE", "ModalPair", "differences_from_model", "frf_rows", "identification_band_hz",
           "identify_band", "identify_modes", "measured_test_differences", "modal_pair", "mode_checks",
           "nominal_ratio_range", "on_model_dofs", "pair_modes_by_frequency", "pairing_bands", "prefer_shared_poles",
           "refit_missing_modes", "unexcited_modes"]

#: The identification ``classify`` runs on FRF files: LSCF poles and LSFD residues, the 4 lowest modes. The
#: training data's modal noise (``measurement.modal_noise = "calibrated"``) is calibrated against this path
#: (``experiments.benches.bench_modal_noise``), and the dataset records it (``measurement.identification``).
IDENTIFICATION = {"method": "lscf", "n_modes": 4}
#: The band identified ends at this multiple of the model's nominal mode-4 frequency (mode 5 of a cantilever
#: lies at 1.65 times mode 4; above the band, modes act through the upper residual).
IDENTIFICATION_BAND_FACTOR = 1.4


#: With several baseline tests, a test's pole pairs with a mode only within this relative distance of the
#: baselines' median frequency of that mode (narrowed to half the log gap to its neighbours): the baselines measure
#: the beam itself, so what remains is the normal variation (0.1-1 %) and the damage; a pole farther away is the
#: mode moved or lost, never the mode (on a one-accelerometer cantilever a spurious pole 6 % above mode 5 otherwise
#: took mode 5's place, a false alarm).
BASELINE_PAIR_BAND = 0.05


def on_model_dofs(data, beam: BeamSpec, beam_x_m=None, where: str = "measured data"):
    """Measured data moved onto the model's DOFs by position: ``(data on beam.dofs, DofMap or None)``.

    Positions come from the file's node geometry (FRF files that carry it), else a beam file's
    ``beam_x_m``, else the quarter-point convention (:func:`physics.io.map_measured_dofs`); each measured DOF
    at a node of the model's 4-element grid is used (others, e.g. extra sensors between the quarter points, are
    left out and named in the map's detail), and the model's DOFs (:attr:`BeamSpec.dofs`) must all be measured
    (refused naming the missing ones). Rows are selected and ordered as ``beam.dofs`` and
    relabelled with them; FRF references get the model DOF at their position too. DOFs labelled with a
    negative sense (``"3:-Y"``) are turned to the positive one first, and an FRF file whose references, not its
    responses, cover the model's DOFs (a roving hammer, one accelerometer) is read by reciprocity
    (:func:`physics.io.prepare_measured`, the one rule). Modal data without ``dofs`` labels are returned as they are
    (rows taken as the model's DOFs, with a warning later).
    """
    n = len(beam.dofs)
    if beam.test is None:
        grid_x = np.linspace(0.0, beam.length_m, n + 1)
        grid = tuple(f"{k}:y" for k in range(1, n + 2))
        kw = dict(length_m=beam.length_m, n_elements=n, beam_x_m=beam_x_m)
    else:  # the model's sensors; files without node geometry are read in ascending node number onto them
        grid_x, grid = beam.sensors_x_m, tuple(beam.dofs)
        gap = np.min(np.diff(grid_x)) if n > 1 else beam.length_m
        kw = dict(length_m=beam.length_m, n_elements=n, tol_m=0.05 * gap,
                  beam_x_m=grid_x if beam_x_m is None else np.sort(np.asarray(beam_x_m, float)))
    if isinstance(data, MeasuredFRF):
        def frf_map(d):
            return map_frf_dofs(d, sensor_labels(d, kw["beam_x_m"]), grid_x, grid, off_grid="ignore", **kw)

        prepared = prepare_measured(data, frf_map, wanted=beam.dofs)
        data, dof_map = prepared.data, prepared.dof_map
        to_model = dict(zip(dof_map.dofs, dof_map.model_dofs))
        if prepared.reciprocal:  # a roving-hammer test: the hammer positions are the responses
            dof_map = replace(dof_map, detail=dof_map.detail + "; responses at the hammer positions by "
                              "reciprocity (H_ij = H_ji, a roving-hammer test)")
        resp_map = replace(dof_map, dofs=data.response_dofs,
                           model_dofs=tuple(to_model.get(d, "") for d in data.response_dofs))
        if len(data.response_dofs) == 1 and len(beam.dofs) > 1:     # one sensor: its natural frequencies alone
            return replace(data, metadata={**data.metadata, FREQUENCIES_ONLY: (
                f"{where}: one sensor ({data.response_dofs[0]}) for the model's {len(beam.dofs)}: read on its "
                "natural frequencies alone")}), dof_map
        resp = resp_map.rows(beam.dofs, where)
        return replace(data, frf=data.frf[resp], response_dofs=tuple(beam.dofs),
                       reference_dofs=tuple(to_model.get(d) or d for d in data.reference_dofs)), dof_map
    data = prepare_measured(data).data
    if not data.dofs or data.eigenvectors is None:
        return data, None
    dof_map = map_measured_dofs(data.dofs, grid_x, grid, where=where, off_grid="ignore", **kw)
    rows = dof_map.rows(beam.dofs, where)
    return replace(data, eigenvectors=data.eigenvectors[rows], dofs=tuple(beam.dofs)), dof_map


#: The metadata key of an FRF file :func:`on_model_dofs` reads on its natural frequencies alone (one sensor for a
#: model of several): its identified modes carry no shapes, and the verdict is the frequency network's.
FREQUENCIES_ONLY = "frequencies_only"


@dataclass(frozen=True)
class ModalPair:
    """The modes of one (baseline, current) pair on the model's DOFs that both tests hold.

    Attributes
    ----------
    eigenvalues : ndarray, complex, shape (2, c)          baseline and current, ascending frequency
    eigenvectors : ndarray, complex, shape (2, n_dofs, c)
    mode_index : ndarray, int, shape (c,)                 0-based indices of the model's modes they are
                                                          (``[0, 1, 2, 3]`` when both tests hold the 4 of the
                                                          thesis's test; the 1-based mode numbers are
                                                          ``beam.modes[j]``)
    missing : tuple of str                                which of the model's modes a test lacks, and why (empty
                                                          when complete)
    warnings : tuple of str
    n_modes : int                                         modes the model reads
    frequency_only : bool                                 natural frequencies without shapes in a test (the
                                                          eigenvectors are placeholders)
    poles : tuple of 2 lists                              per test, every mode found: ``{"frequency_hz", "mode"}``
                                                          (the model's 1-based mode it was paired with, None for
                                                          a pole left unpaired; ``"choice"`` on a pole paired
                                                          among several in its mode's band:
                                                          :func:`physics.ratio_trend.choice_texts`);
                                                          empty on the thesis's 4 modes
    """

    eigenvalues: np.ndarray
    eigenvectors: np.ndarray
    mode_index: np.ndarray
    missing: tuple = ()
    warnings: tuple = ()
    n_modes: int = 4
    frequency_only: bool = False
    poles: tuple = ()

    @property
    def complete(self) -> bool:
        """Both tests hold every mode the model reads (what the modal network reads)."""
        return self.mode_index.size == self.n_modes


def pair_modes_by_frequency(frequencies_hz, nominal_hz, tolerance: float | None = None,
                            shape_mac=None, trend: bool = False) -> np.ndarray:
    """The nominal mode each identified mode is: 0-based indices into ``nominal_hz``, -1 for none.

    The identified modes and the nominal beam's are aligned in frequency order: each identified mode pairs with
    one nominal mode or none, each nominal mode with at most one, minimising the sum of the squared log frequency
    ratios plus ``ln(1 + tol_j)^2`` per identified mode left unpaired (a spurious mode). A pairing farther
    than a factor ``1 + tol_j`` is never kept: ``tol_j`` is ``tolerance``, narrowed to the geometric midpoint
    between nominal mode ``j`` and its nearest neighbour (modes 1-4 of a cantilever lie a factor 1.96 or more
    apart, so there it is ``tolerance``; a free-free beam's mode 6 lies a factor 1.40 above mode 5, so a pole
    more than 18 % from it is not mode 6). With ``shape_mac`` (two or more sensors), a mode whose MAC against
    the nominal shape is below :data:`MIN_PAIR_MAC` is not paired with it either.

    With ``trend`` (classify's pairing, :func:`modal_pair`), where a mode's band holds several poles the one
    paired is the nearest where the measured/model frequency ratios of the modes whose band holds one pole put it
    (:func:`physics.ratio_trend.trend_picks`: ``ln(f / f_model)`` a line in ``f_model``), not the
    nearest the nominal frequency: an Euler-Bernoulli model's frequencies run increasingly high with the mode
    (shear), so on a one-accelerometer cantilever a spurious pole at 1227 Hz lies nearer the model's mode 5
    (1257 Hz) than mode 5 itself (1166 Hz), which lies nearer the 1153 Hz its modes 1-4 predict. With one pole or
    none in every band the pairing is the same either way.

    Parameters
    ----------
    frequencies_hz : array, shape (k,)     identified natural frequencies (Hz), any order
    nominal_hz : array, shape (m,)         the nominal beam's natural frequencies (Hz), ascending (or the
                                           baselines' modes:
                                           :attr:`learn.pairs.normal_variation.NormalVariation.targets`)
    tolerance : float or array (m,), optional   per mode; default :data:`RATIO_TOLERANCE`
    shape_mac : array, shape (k, m), optional   MAC of each identified shape against each nominal shape
    trend : bool                                several poles in a band: the nearest the ratio trend, not the
                                                nominal frequency

    Returns
    -------
    ndarray, int, shape (k,)  e.g. ``[0, 1, 3]`` for modes 1, 2 and 4 of a test that misses mode 3.
    """
    f = np.asarray(frequencies_hz, float)
    nominal = np.asarray(nominal_hz, float)
    order = np.argsort(f)
    raw = np.asarray(RATIO_TOLERANCE if tolerance is None else tolerance, float)
    skip = float(np.log1p(np.max(raw, initial=0.0)) ** 2)            # an identified mode left unpaired
    cost = np.where(_admissible(f, nominal, raw, shape_mac)[order], np.log(f[order, None] / nominal[None]) ** 2,
                    np.inf)                                            # (k, m)
    k, m = cost.shape
    total = np.full((k + 1, m + 1), np.inf)                            # order-preserving alignment, O(k m)
    total[0, :] = 0.0
    step = np.zeros((k + 1, m + 1), int)                               # 0 pair, 1 skip nominal, 2 skip identified
    for i in range(1, k + 1):
        total[i, 0], step[i, 0] = total[i - 1, 0] + skip, 2
        for j in range(1, m + 1):
            options = (total[i - 1, j - 1] + cost[i - 1, j - 1], total[i, j - 1], total[i - 1, j] + skip)
            step[i, j] = int(np.argmin(options))
            total[i, j] = options[step[i, j]]
    best, i, j = np.full(k, -1), k, m
    while i > 0:
        if step[i, j] == 1:
            j -= 1
        elif step[i, j] == 2:
            i -= 1
        else:
            i, j = i - 1, j - 1
            best[i] = j
    out = np.empty(f.size, int)
    out[order] = best
    if not trend:
        return out
    picks, _ = trend_picks(f, nominal, _admissible(f, nominal, raw, shape_mac))
    for j in np.flatnonzero((picks >= 0) & np.isin(np.arange(m), out)):    # several poles in the band of mode j
        if out[picks[j]] in (-1, j):
            out[out == j] = -1
            out[picks[j]] = j
    return out


def _admissible(frequencies_hz, nominal_hz, tolerance, shape_mac) -> np.ndarray:
    """Which identified mode may pair with which nominal mode, bool (k, m): within the mode's pairing band
    (:func:`pairing_bands`) and, with ``shape_mac``, a MAC of at least :data:`MIN_PAIR_MAC`."""
    nominal = np.asarray(nominal_hz, float)
    band = np.log1p(pairing_bands(nominal, tolerance))
    ok = np.log(np.asarray(frequencies_hz, float)[:, None] / nominal[None]) ** 2 <= band[None] ** 2
    return ok if shape_mac is None else ok & (np.asarray(shape_mac, float) >= MIN_PAIR_MAC)


def pairing_bands(nominal_hz, tolerance=RATIO_TOLERANCE) -> np.ndarray:
    """Each mode's pairing band (relative, shape (m,)): ``tolerance`` (float or per mode) narrowed to the geometric
    midpoint between the mode and its nearest neighbour in ``nominal_hz`` (ascending)."""
    nominal = np.asarray(nominal_hz, float)
    tol = np.broadcast_to(np.asarray(tolerance, float), nominal.shape)
    if nominal.size > 1:
        gap = np.log(nominal[1:] / nominal[:-1])                      # (m - 1,) log spacing of neighbours
        half = np.minimum(np.r_[np.inf, gap], np.r_[gap, np.inf]) / 2
        tol = np.minimum(tol, np.expm1(half))
    return np.array(tol, float)


def modal_pair(baseline, current, beam: BeamSpec, nominal_hz, names=("baseline", "measured"),
               found=None, tolerance=None) -> ModalPair:
    """The modes two :class:`physics.io.ModalData` of the model's DOFs both hold.

    Two tests of 4 or more modes give their 4 lowest. When either holds fewer, each test's modes are paired with
    the nominal beam's (:func:`pair_modes_by_frequency`, against ``nominal_hz`` within ``tolerance``; with several
    baselines, their modes and bands: :attr:`learn.pairs.normal_variation.NormalVariation.targets`; several poles in
    a band: the nearest the ratio trend of the others, ``trend``; then :func:`prefer_shared_poles`) and the modes both
    hold are kept; ``found`` (one text per test, e.g. ``"LSCF/LSFD found 2 modes in 2-500 Hz"``) says in
    :attr:`ModalPair.missing` where the others went (with ``tolerance``, also the nearest pole left unpaired: the
    mode moved beyond its band, or lost).
    """
    warnings = []
    lams, vecs = [], []
    shapeless = any(d.eigenvectors is None for d in (baseline, current))
    if shapeless:
        warnings.append("natural frequencies without mode shapes: the verdict reads the frequencies alone")
    for name, d in zip(names, (baseline, current)):
        if shapeless:  # placeholders: the frequency route and the frequency-only methods read no shape
            d = replace(d, eigenvectors=np.ones((len(beam.dofs), d.eigenvalues.size), complex), dofs=beam.dofs)
        dofs = tuple(_canonical_dof(x) for x in d.dofs) if d.dofs else None
        if dofs is None:
            if d.eigenvectors.shape[0] != len(beam.dofs):
                raise BeamDamageError(f"{name} modal data has {d.eigenvectors.shape[0]} DOFs but the model was trained "
                                      f"on {len(beam.dofs)} ({', '.join(beam.dofs)})")
            warnings.append(f"{name} modal data has no 'dofs': rows taken as {', '.join(beam.dofs)}")
        elif dofs != tuple(beam.dofs):
            raise BeamDamageError(f"{name} modal data: DOF set {list(d.dofs)} differs from the model's "
                                  f"{list(beam.dofs)}")
        m = beam.n_modes
        o = np.argsort(np.abs(d.eigenvalues))[:m] if beam.test is None else np.argsort(np.abs(d.eigenvalues))
        lams.append(d.eigenvalues[o])
        vecs.append(d.eigenvectors[:, o])
    m = beam.n_modes
    if beam.test is None and all(x.size == m for x in lams):
        return ModalPair(np.stack(lams), np.stack(vecs), np.arange(m), (), tuple(warnings), m, shapeless)
    found = [how or f"it holds {x.size} mode{'s' * (x.size != 1)}" for how, x in zip(found or (None, None), lams)]
    tol = None if tolerance is None else np.asarray(tolerance, float)[:m]
    f_hz = [np.abs(x) / (2 * np.pi) for x in lams]
    macs = [None if shapeless else _nominal_mac(v, beam) for v in vecs]
    which = [pair_modes_by_frequency(f, nominal_hz[:m], tol, shape_mac=s, trend=True) for f, s in zip(f_hz, macs)]
    which = list(prefer_shared_poles(f_hz, which, nominal_hz[:m], tol, macs))
    common = np.intersect1d(*which)
    common = common[common >= 0]
    missing = []
    for name, how, k, x in zip(names, found, which, lams):
        absent = [j for j in range(m) if j not in k]
        if absent:
            missing.append(f"mode{'s' * (len(absent) > 1)} {', '.join(str(beam.modes[j]) for j in absent)} not "
                           f"identified in {name} ({how}"
                           + ("" if tol is None else _beyond_band(np.abs(x[k < 0]) / (2 * np.pi), nominal_hz[:m],
                                                                  pairing_bands(nominal_hz[:m], tol), absent,
                                                                  beam.modes)) + ")")
    take = [[int(np.flatnonzero(k == j)[0]) for j in common] for k in which]
    inside = [_admissible(f, nominal_hz[:m], RATIO_TOLERANCE if tol is None else tol, s) for f, s in zip(f_hz, macs)]
    notes = [choice_texts(f, nominal_hz[:m], ok, k, beam.modes, "the model" if tol is None else "the baselines")
             for f, ok, k in zip(f_hz, inside, which)]
    poles = tuple([{"frequency_hz": float(abs(lam) / (2 * np.pi)), "mode": beam.modes[j] if j >= 0 else None,
                    **({"choice": note[i]} if i in note else {})}
                   for i, (lam, j) in enumerate(zip(x, k))] for x, k, note in zip(lams, which, notes))
    return ModalPair(np.stack([x[t] for x, t in zip(lams, take)]), np.stack([v[:, t] for v, t in zip(vecs, take)]),
                     common, tuple(missing), tuple(warnings), m, shapeless, poles)


def prefer_shared_poles(frequencies_hz, which, nominal_hz, tolerance=None, shape_mac=(None, None)) -> tuple:
    """Two tests' pairings (:func:`pair_modes_by_frequency`) with each mode both hold taken by the poles nearest
    each other: the pole a test shares with the other within the mode's band, not one only it holds.

    For each mode ``j`` both tests pair, the candidates of a test are its pole paired with ``j`` and its poles left
    unpaired within ``j``'s band (:func:`pairing_bands` of ``nominal_hz`` and ``tolerance``; with ``shape_mac``, a
    MAC of at least :data:`MIN_PAIR_MAC` with ``j``). Of the pairings that change one test's pole at most, the one
    whose two poles lie nearest each other in ``|ln f|`` takes ``j`` (the nominal rule's pairing on a tie). Two
    poles both left unpaired never replace the pairing: where both tests hold the same two poles in the band, the
    nominal rule's choice stays. The bands of neighbouring modes do not overlap, so the frequency order stays.

    A spurious pole in one test then takes no mode's place: a one-accelerometer cantilever's baseline holding
    1227 Hz besides its mode 5 at 1166 Hz pairs 1227 Hz, nearer the Euler-Bernoulli model's 1257 Hz, by the nominal
    rule; against a test whose mode 5 lies at 1169 Hz, 1166 Hz takes mode 5 (0.2 % against 4.9 %).

    Parameters
    ----------
    frequencies_hz : 2 arrays, shapes (k0,), (k1,)   each test's poles (Hz)
    which : 2 int arrays, shapes (k0,), (k1,)        their 0-based modes of ``nominal_hz``, -1 for none
    nominal_hz : array, shape (m,)                   ascending (Hz)
    tolerance : float or array (m,), optional        default :data:`RATIO_TOLERANCE`
    shape_mac : 2 arrays (k_t, m) or None

    Returns
    -------
    tuple of 2 int arrays, shapes (k0,), (k1,)
    """
    f = [np.asarray(x, float) for x in frequencies_hz]
    out = [np.array(w, int) for w in which]
    tol = RATIO_TOLERANCE if tolerance is None else tolerance
    inside = [_admissible(x, nominal_hz, tol, s) for x, s in zip(f, shape_mac)]          # (k_t, m)
    for j in np.intersect1d(out[0][out[0] >= 0], out[1][out[1] >= 0]):
        now = [int(np.flatnonzero(w == j)[0]) for w in out]
        cand = [np.r_[i, np.flatnonzero((w < 0) & ok[:, j])] for i, w, ok in zip(now, out, inside)]
        gap = np.abs(np.log(f[0][cand[0], None] / f[1][None, cand[1]]))          # (c0, c1), [0, 0] the pairing
        gap[1:, 1:] = np.inf                                                      # one test's pole changes at most
        a, b = np.unravel_index(np.argmin(gap), gap.shape)
        for w, c, pick in zip(out, cand, (a, b)):
            w[w == j] = -1
            w[c[pick]] = j
    return tuple(out)


def _beyond_band(free_hz, target_hz, tol, absent, modes) -> str:
    """``"; mode 5: the nearest pole left unpaired 1230 Hz, +6.0 % from the baselines' 1160 Hz, beyond its 5 %
    band"`` for the absent modes with an unpaired pole within twice their band (empty otherwise)."""
    out = []
    for j in absent:
        if free_hz.size == 0:
            break
        near = free_hz[int(np.argmin(np.abs(np.log(free_hz / target_hz[j]))))]
        shift = near / target_hz[j] - 1
        if abs(np.log1p(shift)) <= 2 * np.log1p(tol[j]):
            out.append(f"mode {modes[j]}: the nearest pole left unpaired {near:.5g} Hz, {100 * shift:+.1f} % from the "
                       f"baselines' {target_hz[j]:.5g} Hz, beyond its {100 * tol[j]:.2g} % band (moved or lost)")
    return "".join(f"; {t}" for t in out)


def _nominal_mac(shapes, beam: BeamSpec):
    """MAC (k, m) of identified shapes (S, k) on the model's sensors against the nominal uniform beam's, or None
    (one sensor, the thesis's test)."""
    test = beam.test
    if test is None or test.n_sensors < 2:
        return None
    ref = test.sensor_shapes                                          # (S, m)
    u = np.asarray(shapes)
    num = np.abs(u.conj().T @ ref) ** 2
    den = np.sum(np.abs(u) ** 2, axis=0)[:, None] * np.sum(ref ** 2, axis=0)[None]
    return num / np.maximum(den, 1e-300)


def _canonical_dof(label: str) -> str:
    node, direction = parse_dof(label)
    names = {1: "x", 2: "y", 3: "z", 4: "rx", 5: "ry", 6: "rz"}
    return f"{node}:{names.get(abs(direction), str(direction))}"


def frf_rows(frf, beam: BeamSpec):
    """Receptances at the model's DOFs driven at its first DOF, shape (4, F); None if the file lacks some."""
    f = frf.to_kind("receptance") if frf.frequency_hz[0] > 0 else frf.select_band(fmin_hz=1e-9).to_kind("receptance")
    resp = [_canonical_dof(d) for d in f.response_dofs]
    ref = [_canonical_dof(d) for d in f.reference_dofs]
    drive = beam.dofs[beam.drive_row]
    if drive not in ref or any(d not in resp for d in beam.dofs):
        return None, f
    j = ref.index(drive)
    return np.stack([f.frf[resp.index(d), j] for d in beam.dofs]), f


def identification_band_hz(frf, fmax_hz: float | None = None, fmin_hz: float = 0.0) -> tuple[float, float]:
    """Band (Hz) :func:`identify_modes` fits: the file's lines from the first above ``fmin_hz`` (and 0 Hz) up to
    ``fmax_hz``."""
    f = frf.frequency_hz
    return float(f[f > fmin_hz][0]), float(f[-1] if fmax_hz is None else min(f[-1], fmax_hz))


def identify_modes(frf, fmax_hz: float | None = None, where: str = "FRF file", n_modes: int = 4,
                   fmin_hz: float = 0.0, max_order: int = 40):
    """Modal data of one FRF file by :data:`IDENTIFICATION` (the path the training data's modal noise describes).

    Parameters
    ----------
    frf : :class:`physics.io.MeasuredFRF` on the model's DOFs
    fmax_hz : float, optional
        Upper end of the band fitted (Hz), between the beam's modes 4 and 5, so that the 4 modes identified are
        the 4 lowest.

    Returns
    -------
    :class:`physics.io.ModalData` with the modes identified in the band (at most 4; fewer when the band stops
    below mode 4 or a mode sinks into the noise floor: :func:`pair_modes_by_frequency` tells which they are).
    """
    band = None
    if (fmax_hz is not None and frf.frequency_hz[-1] > fmax_hz) or fmin_hz > frf.frequency_hz[0]:
        band = identification_band_hz(frf, fmax_hz, fmin_hz)
    return _lscf(frf, where, n_modes=n_modes, band_hz=band, max_order=max_order)


def identify_band(frf, band_hz, where: str = "FRF file"):
    """Modal data of one FRF file of a beam-file test, identified as ``beam-damage identify FILE --band LO HI``
    identifies it (:func:`physics.identification.identify_frf`: LSCF over the band, every stable pole inside it,
    its default model order, a clear peak no pole explains fitted again around it). ``classify`` and the modal-noise
    calibration of ``generate`` run this; the poles are then paired with the model's modes
    (:func:`pair_modes_by_frequency`), so a spurious pole takes no mode's place.

    Returns
    -------
    :class:`physics.io.ModalData` of every mode found in ``band_hz`` (Hz).
    """
    return _lscf(frf, where, band_hz=tuple(map(float, band_hz)))


def _lscf(frf, where: str, **options):
    """:data:`IDENTIFICATION`'s method on ``frf`` (:func:`physics.identification.identify_frf` ``options``); a
    numerical failure (:data:`physics.identification.failures.PER_RECORD_ERRORS`) raised as one
    :class:`BeamDamageError` naming ``where`` and the exception's class."""
    with identification_failure(f"{where}: LSCF/LSFD identification"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return identify_frf(frf, method=IDENTIFICATION["method"], **options).modal_data


def refit_missing_modes(missing, target_hz, log_tol, bands_hz, lines_hz, identify, accept=None) -> list:
    """The narrow-band re-identification of the modes a test's identification over its whole band missed (of
    ``classify`` with several baselines, :func:`learn.pairs.inputs.refit_frf_modes`, and of ``monitor``,
    :func:`learn.monitor.tracking.refit_missing`).

    For each mode ``j`` of ``missing``, the test is identified again over ``bands_hz[j]`` (Hz, within
    ``lines_hz``, its ``(lo, hi)`` or None) by ``identify(lo, hi)`` -> ``(found, frequencies Hz)`` or None, and
    the pole of ``found`` nearest ``target_hz[j]`` within ``log_tol[j]`` in ``|ln f|`` (and where
    ``accept(found, j)``, a bool or one per pole, holds) is kept.

    Returns
    -------
    list of ``(j, found, k, lo, hi)``: the mode, the narrow-band identification, its pole kept and the band.
    """
    out = []
    for j in missing:
        lo, hi = bands_hz[j]
        if lines_hz is not None:
            lo, hi = max(lo, lines_hz[0]), min(hi, lines_hz[1])
        got = identify(lo, hi) if hi > lo else None
        if got is None or got[1].size == 0:
            continue
        d = np.abs(np.log(got[1] / target_hz[j]))
        ok = (d <= log_tol[j]) & (True if accept is None else accept(got[0], j))
        if np.any(ok):
            out.append((j, got[0], int(np.argmin(np.where(ok, d, np.inf))), lo, hi))
    return out


def unexcited_modes(test, drive_x_m: float) -> tuple:
    """The test's modes (1-based) with a node at ``drive_x_m`` (m): their uniform-beam shape there below
    :data:`physics.layout.MIN_VISIBLE` of their largest along the beam (:func:`physics.layout.uniform_shapes`; the
    rule by which the layout leaves out a mode its drive point cannot see: a mode near a clamp, 3 % there, still
    shows a clear peak)."""
    grid = np.linspace(0.0, test.length_m, 241)
    peak = np.abs(uniform_shapes(test, grid)).max(axis=0)
    rel = np.abs(uniform_shapes(test, [drive_x_m]))[0] / peak
    return tuple(int(m) for m, r in zip(test.modes, rel) if r < MIN_VISIBLE)


def differences_from_model(frfs: dict, beam: BeamSpec, line_spacing_hz: float | None = None) -> list[str]:
    """How the measured test differs from the model's, one line each (empty when it does not).

    Parameters
    ----------
    frfs : dict of str -> :class:`physics.io.MeasuredFRF`
        The files as read (name -> FRFs), before they are placed on the model's DOFs.
    beam : BeamSpec
        The model's test (``beam.test``; the thesis's test is compared on its band and line spacing alone).
    line_spacing_hz : float, optional
        The training data's line spacing (Hz).

    Compared: the reference DOF's position (from the files' node geometry) against the model's drive point, and
    the modes that position cannot excite (:func:`unexcited_modes`); the files' FRF kinds; the band the files
    cover against the model's modes (a mode outside the lines, or within 5 % of their ends); their line spacing
    against the training data's (coarser by more than a factor 2: the identification errs more than the training
    data's modal noise says; finer lines err less).
    """
    test = beam.test
    out = []
    if not frfs:
        return out
    kinds = {name: f.kind for name, f in frfs.items()}
    if len(set(kinds.values())) > 1:
        out.append("FRF kinds differ between the files (" + ", ".join(f"{n}: {k}" for n, k in kinds.items())
                   + "): each is converted to receptance before identification")
    if test is not None:
        where = {n: reference_position_m(f) for n, f in frfs.items()}
        placed = {n: x for n, x in where.items() if x is not None}
        tol = 0.02 * test.length_m
        for n, x in placed.items():
            if abs(x - test.drive_x_m) <= tol:
                continue
            lost = unexcited_modes(test, x)
            out.append(f"{n}: the reference DOF {frfs[n].reference_dofs[0]} lies at {x:.4g} m (the file's node "
                       f"geometry), the model was trained for a drive point at {test.drive_x_m:.4g} m"
                       + (f"; a force at {x:.4g} m cannot excite mode{'s' * (len(lost) > 1)} "
                          f"{', '.join(map(str, lost))} (a node there: below {MIN_VISIBLE:.0%} of the mode's "
                          "largest amplitude), which the model reads" if lost else "")
                       + ": generate the training data for this drive point (drive_x_m in the beam file)")
        unplaced = [n for n in frfs if n not in placed]
        if unplaced and len(unplaced) == len(frfs):
            out.append(f"the files carry no node geometry of their reference DOF: the force is taken at the model's "
                       f"drive point {test.drive_x_m:.4g} m")
    lo, hi = beam.test.band_hz if test is not None else (None, None)
    for n, f in frfs.items():
        fr = f.frequency_hz[f.frequency_hz > 0]
        outside = [] if test is None else \
            [m for m, fm in zip(test.modes, test.frequencies_hz) if not fr[0] * 1.05 <= fm <= fr[-1] / 1.05]
        if outside:
            out.append(f"{n}: its lines cover {fr[0]:.4g}-{fr[-1]:.4g} Hz, the model's band is {lo:.4g}-{hi:.4g} Hz: "
                       f"mode{'s' * (len(outside) > 1)} {', '.join(map(str, outside))} of the model lie outside the "
                       "file's lines or within 5 % of their ends")
        df = float(np.median(np.diff(fr))) if fr.size > 1 else None
        if line_spacing_hz and df and df > 2.0 * line_spacing_hz:
            out.append(f"{n}: line spacing {df:.4g} Hz, coarser than the training data's {line_spacing_hz:.4g} Hz: "
                       "the modal noise the model was trained with describes the identification on finer lines")
    return out


def measured_test_differences(files, raw, mapped, beam: BeamSpec, line_spacing_hz: float | None = None) -> list[str]:
    """One line per way the files' test differs from the model's (:func:`differences_from_model` of the FRF files
    ``raw``), and per file whose measured DOFs the model does not read (``mapped``: each file's
    :func:`on_model_dofs`; a DOF at an FRF file's force alone is no sensor left out)."""
    frfs = {str(f): d for f, d in zip(files, raw) if isinstance(d, MeasuredFRF)}
    out = differences_from_model(frfs, beam, line_spacing_hz)
    for f, d, (_, dof_map) in zip(files, raw, mapped):
        if dof_map is not None and "not used" in dof_map.detail:
            forces = ({parse_dof(x)[0] for x in d.reference_dofs} - {parse_dof(x)[0] for x in d.response_dofs}
                      if isinstance(d, MeasuredFRF) else set())
            unused = [x for x, m in zip(dof_map.dofs, dof_map.model_dofs) if not m and parse_dof(x)[0] not in forces]
            if not unused:
                continue
            out.append(f"{f}: measured DOF{'s' * (len(unused) > 1)} {', '.join(unused)} lie at no sensor of the "
                       f"model ({', '.join(beam.dofs)}): not used")
    return out


def nominal_ratio_range(sens) -> np.ndarray:
    """Accepted range of the frequency ratios ``f_k / f_1`` (k = 2..m), shape (m - 1, 2): the nominal beam's ratios
    times ``1 -+ RATIO_TOLERANCE``."""
    r = sens.frequencies_hz[1:] / sens.frequencies_hz[0]
    return np.stack([r * (1 - RATIO_TOLERANCE), r * (1 + RATIO_TOLERANCE)], axis=1)


def mode_checks(lam, vecs, ratio_range) -> list[list[str]]:
    """Per pair, reasons it lies outside what the modal network was trained on: a frequency ratio ``f_k / f_1``
    outside the accepted range (a missing or spurious mode), or baseline and current modes that do not pair
    (MAC < 0.8)."""
    f = np.abs(lam) / (2 * np.pi)                                 # (n, 2, m)
    ratio = f[..., 1:] / f[..., :1]                               # (n, 2, m - 1)
    m = f.shape[-1]
    u = real_shapes(vecs)                                         # (n, 2, 4, m)
    pairing = np.diagonal(mac(u[:, 0], u[:, 1]), axis1=-2, axis2=-1)  # (n, m)
    reasons = []
    for i in range(f.shape[0]):
        r = [f"{name} f{k + 2}/f1 = {ratio[i, s, k]:.4g} lies outside the nominal beam's "
             f"{ratio_range[k, 0]:.4g}-{ratio_range[k, 1]:.4g} (a missing or spurious mode)"
             for s, name in enumerate(("baseline", "measured")) for k in range(m - 1)
             if not ratio_range[k, 0] <= ratio[i, s, k] <= ratio_range[k, 1]]
        r += [f"mode {k + 1} of the baseline and the measured test do not pair (MAC {pairing[i, k]:.2f} < 0.8)"
              for k in range(m) if pairing[i, k] < 0.8]
        reasons.append(r)
    return reasons


