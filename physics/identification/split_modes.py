"""Modes an identification may have split in two: adjacent modes whose half-power bands overlap and whose shapes
agree.

Two modes closer than the sum of their half-power half-widths (``|f_i - f_j| < zeta_i f_i + zeta_j f_j``) make one
peak; data can tell them apart only by their shapes (several references or responses moving differently). Where the
shapes agree too (MAC at least :data:`SPLIT_MAC`, always so for one FRF or one channel), nothing in the data
separates them: a fit that reports both has most likely split one mode (on the pyFRF hammer hit's H1, LSCF reports
3007.40 and 3007.50 Hz, damping ratios 0.0015, each with a fit sigma of 170 Hz).
"""

from __future__ import annotations

import numpy as np

from physics.modal import mac

__all__ = ["SPLIT_MAC", "split_pairs", "split_text"]

#: Shapes at least this alike (MAC) do not separate two modes whose half-power bands overlap.
SPLIT_MAC = 0.9


def split_pairs(natural_frequencies_hz, damping_ratios, shapes, mac_min=SPLIT_MAC) -> np.ndarray:
    """Adjacent (in frequency) modes whose half-power bands overlap and whose shapes agree.

    Parameters
    ----------
    natural_frequencies_hz, damping_ratios : array_like, shape (n_modes,)
        A NaN damping ratio never flags its mode.
    shapes : array_like, complex, shape (n_dofs, n_modes)
    mac_min : float

    Returns
    -------
    ndarray of int, shape (n_pairs, 2)
        Mode indices ``(i, j)``, ``f_i < f_j``.
    """
    f = np.asarray(natural_frequencies_hz, float)
    z = np.asarray(damping_ratios, float)
    if f.size < 2:
        return np.zeros((0, 2), int)
    order = np.argsort(f)
    a, b = order[:-1], order[1:]
    with np.errstate(invalid="ignore"):
        overlap = (f[b] - f[a]) < z[a] * f[a] + z[b] * f[b]
    phi = np.asarray(shapes)
    alike = np.array([mac(phi[:, [i]], phi[:, [j]])[0, 0] >= mac_min if ok else False
                      for i, j, ok in zip(a, b, overlap)], bool)    # one MAC per overlapping adjacent pair
    return np.stack([a[alike], b[alike]], axis=1).astype(int)


def split_text(where, natural_frequencies_hz, pairs) -> str:
    """One warning line naming the pairs (1-based mode numbers in frequency order of the report)."""
    f = np.asarray(natural_frequencies_hz, float)
    items = ", ".join(f"modes {i + 1} and {j + 1} ({f[i]:.6g} and {f[j]:.6g} Hz)" for i, j in pairs)
    return (f"{where}: {items} lie within each other's half-power band with alike shapes (MAC >= {SPLIT_MAC:g}): "
            "nothing in the data separates them, most likely one mode the fit split in two; try another "
            "--max-order or a --band around it")
