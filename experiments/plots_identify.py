"""Figures of the ``identify`` command (stabilisation diagram, measured vs synthesised FRFs).

Figures are rendered to PNG bytes; the caller writes them atomically.
"""

from __future__ import annotations

import io

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from physics.identification import STABILITY_CODES, mode_indicator  # noqa: E402

_MARKERS = {0: ("o", "0.7", "new"), 1: ("x", "tab:orange", "f"), 2: ("^", "tab:blue", "f+d"),
            3: ("v", "tab:purple", "f+v"), 4: ("s", "tab:green", "stable")}


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()


def stabilisation_png(diagram, frequency_hz, frf, selected_hz=()) -> bytes:
    """Stabilisation diagram over the log mode indicator; selected poles as vertical lines."""
    fig, ax = plt.subplots(figsize=(9, 5.5))
    for code, (mk, col, lab) in _MARKERS.items():
        sel = diagram.status == code
        if np.any(sel):
            ax.scatter(diagram.natural_frequencies_hz[sel], diagram.order[sel], marker=mk, s=14,
                       facecolors="none" if mk == "o" else col, edgecolors=col, linewidths=0.8,
                       label=f"{lab}: {STABILITY_CODES[code]}")
    for f0 in selected_hz:
        ax.axvline(f0, color="k", lw=0.8, ls="--")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("model order")
    ax.set_xlim(diagram.band_hz)
    ax2 = ax.twinx()
    ax2.semilogy(frequency_hz, np.sqrt(mode_indicator(frf)), color="0.3", lw=0.8)
    ax2.set_ylabel("sqrt(sum |H|^2) (m/N)")
    ax.legend(loc="upper left", fontsize=7, framealpha=0.8)
    ax.set_title("LSCF stabilisation diagram")
    fig.tight_layout()
    return _png(fig)


def overlay_png(frequency_hz, measured, synthesised, labels, kind="receptance", units="m/N", max_curves=6) -> bytes:
    """Magnitude and phase of measured (lines) vs synthesised (dashed) FRFs."""
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 7), sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    m = measured.reshape(-1, measured.shape[-1])
    s = synthesised.reshape(-1, synthesised.shape[-1])
    for k in range(min(m.shape[0], max_curves)):
        line, = ax1.semilogy(frequency_hz, np.abs(m[k]), lw=1.0, label=f"{labels[k]} measured")
        ax1.semilogy(frequency_hz, np.abs(s[k]), "--", color=line.get_color(), lw=1.0)
        ax2.plot(frequency_hz, np.rad2deg(np.angle(m[k])), lw=1.0, color=line.get_color())
        ax2.plot(frequency_hz, np.rad2deg(np.angle(s[k])), "--", lw=1.0, color=line.get_color())
    ax1.set_ylabel(f"|H| ({units})")
    ax1.set_title(f"measured (solid) vs synthesised (dashed) {kind}")
    ax1.legend(fontsize=7)
    ax2.set_ylabel("phase (deg)")
    ax2.set_xlabel("frequency (Hz)")
    ax2.set_yticks([-180, -90, 0, 90, 180])
    fig.tight_layout()
    return _png(fig)
