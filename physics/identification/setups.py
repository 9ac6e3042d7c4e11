"""Multi-setup output-only tests (roving sensors, reference sensors left in place): the modes of every setup merged
into one set of shapes (:func:`merge_setups`, PoSER-like: a mode of some setups only is kept, NaN at the others'
DOFs), the references checked by the MAC of each mode's reference part across setups."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from physics.errors import ShapeError
from physics.identification.modes import ModalEstimate, modal_phase_collinearity
from physics.io import ModalData
from physics.modal import eigenvalues_from_modal

__all__ = ["MAX_SUBSET_DOFS", "REFERENCE_MAC", "MergedSetups", "finite_mac", "merge_setups"]


#: Least MAC between a mode's reference part in two setups: below it the references are not the same sensors.
REFERENCE_MAC = 0.9


@dataclass(frozen=True)
class MergedSetups:
    """Modes of several setups (roving sensors, fixed reference sensors) merged into one set of shapes.

    Attributes
    ----------
    estimate : ModalEstimate
        Frequencies and damping ratios: means over the setups holding each mode; one sigma: their spread divided by
        sqrt(their number) (with one setup, that setup's own); shapes unit-norm over the DOFs measured in the setups
        holding the mode, NaN at the DOFs of the other setups (partial modes).
    dofs : tuple of str
        The first setup's DOFs, then each later setup's new DOFs in its order.
    references : tuple of str
        DOFs measured in every setup (they scale each setup's shapes onto the mode's first setup's).
    found_in : tuple of tuple of int
        Per mode, the setups (0-based, in the order given) that hold it.
    reference_mac : ndarray, shape (n_modes, n_setups)
        MAC of each setup's reference part of the mode with that of the mode's first setup (1 there; NaN where the
        setup does not hold the mode).
    by_position : bool
        The references were assumed by position: a setup's file holds no DOF labels.
    """

    estimate: ModalEstimate
    dofs: tuple
    references: tuple
    found_in: tuple
    reference_mac: np.ndarray
    by_position: bool = False

    @property
    def partial(self) -> np.ndarray:
        """Per mode, whether some setup does not hold it (its DOFs NaN in the shape)."""
        return np.array([len(f) < self.reference_mac.shape[1] for f in self.found_in], bool)

    @property
    def modal_data(self) -> ModalData:
        return ModalData(self.estimate.eigenvalues, self.estimate.shapes, self.dofs)


def _group_modes(freqs, freq_tol):
    """Modes of the setups grouped by frequency: ``[{setup: mode index}, ...]`` by ascending mean frequency.

    Setup by setup, each mode joins the group of the nearest mean frequency within ``freq_tol`` (relative) that
    holds none of that setup's modes (closest pairs first), else starts a group."""
    groups = []
    for s, f in enumerate(freqs):
        free = set(range(f.size))
        if groups:
            centre = np.array([np.mean([freqs[t][k] for t, k in g.items()]) for g in groups])
            d = np.abs(f[:, None] - centre[None, :]) / centre[None, :]
            taken = set()
            for k, g in zip(*np.unravel_index(np.argsort(d, axis=None), d.shape)):
                if d[k, g] > freq_tol:
                    break
                if k in free and g not in taken:
                    groups[g][s] = int(k)
                    free.discard(k)
                    taken.add(g)
        groups += [{s: k} for k in sorted(free)]
    return sorted(groups, key=lambda g: np.mean([freqs[t][k] for t, k in g.items()]))


def _mac_pair(a, b) -> float:
    return float(np.abs(np.vdot(a, b)) ** 2 / (np.vdot(a, a).real * np.vdot(b, b).real))


def _check_references(idents, refs, groups, macs, by_position, min_mac):
    """Refuse a setup whose reference part disagrees with the first setup's on most of the modes both hold (the
    references are not the same sensors); warn of single modes below ``min_mac``."""
    names = [str(i.records.metadata.get("source", f"setup {k + 1}")) for k, i in enumerate(idents)]
    how = (" (assumed by position: a file holds no DOF labels, so channel k of every setup is taken as one sensor)"
           if by_position else "")
    for s in range(1, len(idents)):
        rows = [j for j, g in enumerate(groups) if s in g and min(g) != s]
        if not rows:
            continue
        m = macs[rows, s]
        f = [np.mean([idents[t].estimate.natural_frequencies_hz[k] for t, k in groups[j].items()]) for j in rows]
        first = names[min(groups[rows[0]])]
        if np.median(m) < min_mac:
            agree = _agreeing_references(idents, refs, groups, rows, s, min_mac)
            raise ShapeError(f"{names[s]}: the reference DOFs {', '.join(refs)}{how} do not hold the shapes they hold "
                             f"in {first}: MAC " + ", ".join(f"{x:.3g} at {y:.4g} Hz" for x, y in zip(m, f))
                             + f" (the same sensors give >= {min_mac:g}); "
                             + (f"only {', '.join(agree[0])} agree (MAC >= {agree[1]:.3g} on every mode); "
                                if agree else "")
                             + ("label the channels (field 'dofs') so that the references share their labels"
                                if by_position else "check that these DOFs are the sensors left in place"))
        low = m < min_mac
        if low.any():
            warnings.warn(f"{names[s]}: the reference part of the mode(s) at "
                          + ", ".join(f"{y:.4g} Hz (MAC {x:.3g})" for x, y in zip(m[low], np.array(f)[low]))
                          + f" disagrees with {first}'s on the reference DOFs {', '.join(refs)}{how}: the merged "
                          "shape is doubtful there", UserWarning, stacklevel=3)


#: Most reference DOFs whose subsets are searched for the ones that agree (2^n subsets).
MAX_SUBSET_DOFS = 12


def _agreeing_references(idents, refs, groups, rows, s, min_mac):
    """The largest set (2 or more) of the reference DOFs whose part of every mode in ``rows`` has MAC >=
    ``min_mac`` between setup ``s`` and the mode's first setup, and its least MAC; None if there is none."""
    n = len(refs)
    if n < 3 or n > MAX_SUBSET_DOFS:
        return None
    a = [[list(i.records.dofs).index(d) for d in refs] for i in idents]
    r0 = np.array([idents[min(groups[j])].estimate.shapes[a[min(groups[j])], groups[j][min(groups[j])]]
                   for j in rows])                                               # (n_modes, n_ref)
    rs = np.array([idents[s].estimate.shapes[a[s], groups[j][s]] for j in rows])
    subsets = (np.arange(1, 2 ** n)[:, None] >> np.arange(n)[None, :]) & 1      # (2^n - 1, n_ref)
    subsets = subsets[subsets.sum(axis=1) >= 2].astype(float)
    cross = np.abs(subsets @ (rs.conj() * r0).T) ** 2
    m = cross / ((subsets @ (np.abs(rs) ** 2).T) * (subsets @ (np.abs(r0) ** 2).T))
    least = m.min(axis=1)
    ok = np.nonzero(least >= min_mac)[0]
    if ok.size == 0:
        return None
    best = ok[np.lexsort((-least[ok], -subsets[ok].sum(axis=1)))[0]]
    if subsets[best].sum() == n:
        return None
    return tuple(d for d, k in zip(refs, subsets[best]) if k), float(least[best])


def merge_setups(idents, freq_tol=0.02, min_reference_mac=REFERENCE_MAC) -> MergedSetups:
    """Merge the output-only identifications of several setups that share reference DOFs (PoSER-like).

    The modes of all setups are grouped by frequency (:func:`_group_modes`, within ``freq_tol`` relative); a mode
    found in only some setups is kept, NaN at the DOFs only the others measure. Each setup's shape is scaled onto
    that of the mode's first setup by the complex least-squares factor on the reference DOFs, whose entries are
    then averaged over the setups. The reference part of each mode in each setup is compared with the first's by
    MAC: a setup whose references disagree (median MAC below ``min_reference_mac`` over the modes it shares) is
    refused, a single disagreeing mode named in a warning. Files without DOF labels (channels ``1:+Z``,
    ``2:+Z``...) share their references by position, which a warning says.

    Parameters
    ----------
    idents : sequence of RecordsIdentification
    freq_tol : float
    min_reference_mac : float

    Returns
    -------
    MergedSetups

    Raises
    ------
    ShapeError
        No DOF is measured in every setup, no mode is found in two setups, or a setup's references disagree.
    """
    dof_sets = [list(i.records.dofs) for i in idents]
    names = [str(i.records.metadata.get("source", "?")) for i in idents]
    refs = [d for d in dof_sets[0] if all(d in ds for ds in dof_sets[1:])]
    if not refs:
        raise ShapeError("setups " + ", ".join(names) + ": no DOF is measured in every setup; reference sensors "
                         "must stay in place")
    unlabelled = [n for i, n in zip(idents, names) if i.records.metadata.get("dof_labels") == "by position"]
    if unlabelled:
        warnings.warn(f"{', '.join(unlabelled)}: no DOF labels; the setups are merged on the reference DOFs "
                      f"{', '.join(refs)} assumed by position (channel k of every setup taken as one sensor) and "
                      "checked by the MAC of each mode's reference part", UserWarning, stacklevel=2)
    dofs = list(dof_sets[0])
    for ds in dof_sets[1:]:
        dofs += [d for d in ds if d not in dofs]
    ests = [i.estimate for i in idents]
    groups = _group_modes([e.natural_frequencies_hz for e in ests], freq_tol)
    if not any(len(g) > 1 for g in groups):
        raise ShapeError("setups " + ", ".join(names) + ": no mode is found in two setups (within "
                         f"{100 * freq_tol:g} % in frequency); nothing ties their shapes together")
    ref_rows = [[ds.index(d) for d in refs] for ds in dof_sets]
    macs = np.full((len(groups), len(idents)), np.nan)
    phi = np.full((len(dofs), len(groups)), np.nan, complex)
    for j, g in enumerate(groups):
        a = min(g)
        ref0 = ests[a].shapes[ref_rows[a], g[a]]
        total, count = np.zeros(len(dofs), complex), np.zeros(len(dofs))
        for s, k in g.items():
            psi = ests[s].shapes[:, k]
            rs = psi[ref_rows[s]]
            macs[j, s] = _mac_pair(rs, ref0)
            idx = [dofs.index(d) for d in dof_sets[s]]
            total[idx] += np.vdot(rs, ref0) / np.vdot(rs, rs) * psi
            count[idx] += 1
        seen = count > 0
        phi[seen, j] = total[seen] / count[seen]
    _check_references(idents, refs, groups, macs, bool(unlabelled), min_reference_mac)
    phi = phi / np.sqrt(np.nansum(np.abs(phi) ** 2, axis=0))
    members = [list(g.items()) for g in groups]
    F = [np.array([ests[s].natural_frequencies_hz[k] for s, k in m]) for m in members]
    Z = [np.array([ests[s].damping_ratios[k] for s, k in m]) for m in members]
    fn, zeta = np.array([f.mean() for f in F]), np.array([z.mean() for z in Z])
    f_std = np.array([f.std(ddof=1) / np.sqrt(f.size) if f.size > 1 else ests[m[0][0]].frequency_std_hz[m[0][1]]
                      for f, m in zip(F, members)])
    z_std = np.array([z.std(ddof=1) / np.sqrt(z.size) if z.size > 1 else ests[m[0][0]].damping_std[m[0][1]]
                      for z, m in zip(Z, members)])
    weak = np.array([any(ests[s].weakly_stable is not None and ests[s].weakly_stable[k] for s, k in m)
                     for m in members])
    mpc = np.array([modal_phase_collinearity(phi[np.isfinite(phi[:, j]), j][:, None])[0] for j in range(fn.size)])
    est = ModalEstimate(fn, zeta, eigenvalues_from_modal(fn, zeta), phi, np.zeros((len(dofs), 0, fn.size), complex),
                        f_std, z_std, mpc, ests[0].method, False, weakly_stable=weak)
    return MergedSetups(est, tuple(dofs), tuple(refs), tuple(tuple(sorted(g)) for g in groups), macs,
                        bool(unlabelled))


def finite_mac(shapes) -> np.ndarray:
    """MAC matrix of shapes with NaN entries (partial modes): each pair over the rows finite in both."""
    phi = np.asarray(shapes, complex)
    ok = np.isfinite(phi)
    z = np.where(ok, phi, 0)
    cross = np.abs(z.conj().T @ z) ** 2
    both = ok.T.astype(float)
    norms_a = (np.abs(z.T) ** 2) @ ok.astype(float)          # (m, m): |a_i|^2 over rows where b_j is finite
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(both @ ok.astype(float) > 0, cross / (norms_a * norms_a.T), np.nan)
