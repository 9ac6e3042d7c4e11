"""Outputs of an identification: figures (stabilisation diagram, measured vs synthesised FRFs), modal JSON
and the synthesised FRFs as UFF 58 (:func:`write_outputs`, used by ``identify`` and the demo).

Figures are rendered to PNG bytes, then every file is written atomically.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import json  # noqa: E402
from pathlib import Path  # noqa: E402

from physics.errors import ConfigError  # noqa: E402
from physics.identification import STABILITY_CODES, Identification, mode_indicator  # noqa: E402
from physics.io import (MeasuredFRF, atomic_write_bytes, figure_png, modal_data_to_dict, write_frf_csv,  # noqa: E402
                        write_uff58)
from physics.io.types import UNNAMED_REFERENCE  # noqa: E402

__all__ = ["overlay_png", "stabilisation_png", "synthesised_frf", "write_outputs"]

_MARKERS = {0: ("o", "0.7", "new"), 1: ("x", "tab:orange", "f"), 2: ("^", "tab:blue", "f+d"),
            3: ("v", "tab:purple", "f+v"), 4: ("s", "tab:green", "stable")}


def stabilisation_png(diagram, frequency_hz, frf, selected_hz=(), units="m/N") -> bytes:
    """Stabilisation diagram over the log mode indicator (in the FRFs' ``units``); selected poles as vertical
    lines."""
    fig, ax = plt.subplots(figsize=(9, 5.5))
    for code, (mk, col, lab) in _MARKERS.items():
        sel = diagram.status == code
        if np.any(sel):
            text = STABILITY_CODES[code]
            ax.scatter(diagram.natural_frequencies_hz[sel], diagram.order[sel], marker=mk, s=14,
                       facecolors="none" if mk == "o" else col, edgecolors=col, linewidths=0.8,
                       label=text if lab == text else f"{lab}: {text}")
    for i, f0 in enumerate(selected_hz):
        ax.axvline(f0, color="k", lw=0.8, ls="--", label="selected mode" if i == 0 else None)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("model order")
    ax.set_xlim(diagram.band_hz)
    ax2 = ax.twinx()
    ax2.semilogy(frequency_hz, np.sqrt(mode_indicator(frf)), color="0.3", lw=0.8)
    ax2.set_ylabel(f"sqrt(sum |H|^2) ({units})")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=5, fontsize=7, frameon=False)
    ax.set_title("LSCF stabilisation diagram")
    fig.tight_layout()
    return figure_png(fig)


def overlay_png(frequency_hz, measured, synthesised, labels, kind="receptance", units="m/N", max_curves=6) -> bytes:
    """Magnitude and phase of measured (solid, light) vs synthesised (dashed) FRFs, one colour per FRF.

    The synthesised phase is unwrapped along frequency; the measured phase is drawn on the same branch
    (synthesised phase plus the wrapped difference), so a +-180 deg wrap never draws a vertical line.
    """
    from matplotlib.lines import Line2D
    from matplotlib.ticker import MultipleLocator

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 7), sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    m = measured.reshape(-1, measured.shape[-1])[:max_curves]
    s = synthesised.reshape(-1, synthesised.shape[-1])[:max_curves]
    phase_s = np.unwrap(np.angle(s), axis=-1)
    phase_m = phase_s + np.angle(m * np.conj(s))
    handles = []
    for k in range(m.shape[0]):
        line, = ax1.semilogy(frequency_hz, np.abs(m[k]), lw=2.0, alpha=0.45)
        ax1.semilogy(frequency_hz, np.abs(s[k]), "--", color=line.get_color(), lw=1.0)
        ax2.plot(frequency_hz, np.rad2deg(phase_m[k]), lw=2.0, alpha=0.45, color=line.get_color())
        ax2.plot(frequency_hz, np.rad2deg(phase_s[k]), "--", lw=1.0, color=line.get_color())
        handles.append(Line2D([], [], color=line.get_color(), lw=2, label=labels[k]))
    handles += [Line2D([], [], color="k", lw=2.0, alpha=0.45, label="measured"),
                Line2D([], [], color="k", lw=1.0, ls="--", label="synthesised (LSFD)")]
    ax1.set_ylabel(f"|H| ({units})")
    ax1.set_title(f"measured (light, solid) and synthesised (dashed) {kind}")
    ax1.legend(handles=handles, fontsize=7, ncol=2)
    ax2.set_ylabel("phase, unwrapped (deg)")
    ax2.set_xlabel("frequency (Hz)")
    span_deg = np.rad2deg(np.ptp(np.concatenate([phase_m.ravel(), phase_s.ravel()]))) if m.size else 0.0
    ax2.yaxis.set_major_locator(MultipleLocator(90 if span_deg <= 720 else 180))
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    return figure_png(fig)


def synthesised_frf(ident: Identification) -> MeasuredFRF:
    """The fitted FRFs as a :class:`MeasuredFRF` of the input's kind, units and (band-limited) lines.

    When the input's axis labels named one unit (e.g. ``g/N``) the values are converted back to it and
    the label written; otherwise (SI, or a dataset-164 unit system) they stay SI with SI labels.
    """
    src = ident.frf
    units = src.metadata.get("units") or {}
    found, factors = units.get("file", []), units.get("factor_to_si", [])
    h, label = ident.synthesised, src.units
    if len(found) == 1 and len(factors) == 1 and found[0].endswith(" (axis labels)") and factors[0] != 1.0:
        h, label = h / factors[0], found[0][: -len(" (axis labels)")]
    return MeasuredFRF(src.frequency_hz, h, src.response_dofs, src.reference_dofs, kind=src.kind, units=label,
                       metadata={"id1": "beam-damage identify: synthesised FRF", "source": src.metadata.get("source")})


def write_outputs(ident: Identification, out_dir) -> dict:
    """Write modal JSON, the synthesised FRFs (UFF 58; CSV when the file does not name the reference DOF),
    stabilisation diagram (LSCF) and overlay PNGs.

    Everything is rendered first, then each file is written atomically; returns their paths.
    """
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ConfigError(f"--out {out_dir}: exists and is not a directory")
    f, h = ident.frf.frequency_hz, ident.frf.frf
    labels = [f"{a}/{b}" for a in ident.frf.response_dofs for b in ident.frf.reference_dofs]
    files = {"modal.json": (json.dumps(modal_data_to_dict(ident.modal_data), indent=1) + "\n").encode()}
    if ident.diagram is not None:
        files["stabilisation.png"] = stabilisation_png(ident.diagram, f, h, ident.estimate.natural_frequencies_hz,
                                                       ident.frf.units)
    files["overlay.png"] = overlay_png(f, h, ident.synthesised, labels, ident.frf.kind, ident.frf.units)
    synth = synthesised_frf(ident)
    written = {}
    for name, data in files.items():
        atomic_write_bytes(out_dir / name, data)
        written[name] = str(out_dir / name)
    if UNNAMED_REFERENCE in synth.reference_dofs:  # a UFF record needs the reference node: CSV keeps the label
        write_frf_csv(out_dir / "synthesised.csv", synth)
        written["synthesised.csv"] = str(out_dir / "synthesised.csv")
    else:
        write_uff58(out_dir / "synthesised.uff", synth)
        written["synthesised.uff"] = str(out_dir / "synthesised.uff")
    return written
