"""The thesis's printed numbers as package data (``physics/data/thesis/*.json``).

Fixtures (transcribed from the thesis; the files carry ``source`` and ``note`` fields):

* ``beams`` - geometry, Table 4.1 specimen data, beam 5's measured modes
  (Tables 4.5, 4.6), its IIRS-reduced matrices and identified models (Chapter Six);
* ``example1_two_dof`` - Example 1 (two DOFs, Pilkey iterates);
* ``example2_ortiz_beam`` - Example 2 (Ortiz's beam, printed iterates);
* ``modeshape_example`` - the real-mode-shape example of eq. 3.25.

Used by ``beam-damage validate``, the demo and the tests alike.
"""

from __future__ import annotations

import json
from importlib import resources

import numpy as np

from physics.errors import BeamDamageError
from physics.updating import mass_model_name
from physics.frf import receptance
from physics.io import MeasuredFRF
from physics.modal import complex_modes
from physics.noise import complex_normal

__all__ = ["BEAM5_DOFS", "BEAM5_TIP", "FIXTURES", "beam5_reduced_model", "beam_state", "identified_model", "load",
           "simulated_beam5_test"]

_DATA = resources.files("physics").joinpath("data", "thesis")
#: Fixture names: every ``physics/data/thesis/NAME.json`` (a fixture added there needs no code change).
FIXTURES = tuple(sorted(p.name[:-5] for p in _DATA.iterdir() if p.name.endswith(".json")))
#: Keys of the identified models in ``beams.json`` per analyst mass model (:data:`physics.updating.MASS_MODELS`).
_MASS_KEYS = {"iirs": "reduced_mass", "lumped": "lumped_mass"}


def load(name: str) -> dict:
    """A fresh copy of the thesis fixture ``name`` (one of :data:`FIXTURES`) as parsed JSON."""
    if name not in FIXTURES:
        raise BeamDamageError(f"thesis fixture {name!r} unknown; expected one of {', '.join(FIXTURES)}")
    return json.loads(_DATA.joinpath(f"{name}.json").read_text())


def beam_state(state: str, beam: str = "5") -> dict:
    """Measured modal data of a thesis beam in ``state`` ("undamaged" = baseline, "damaged"), as stored.

    Parse it with :func:`physics.io.modal_data_from_dict`.
    """
    b = load("beams")["beams"][beam]
    if state not in ("undamaged", "damaged"):
        raise BeamDamageError(f"state {state!r} unknown; expected 'undamaged' or 'damaged'")
    return b[state]


def identified_model(state: str, mass_model: str = "iirs", beam: str = "5"):
    """The printed identified model ``(M, C, K)`` of Chapter Six (Tables 6.x) as float arrays.

    ``M`` of the damaged models is the undamaged ``M`` (the thesis prints it once).

    Parameters
    ----------
    state : {"undamaged", "damaged"}
    mass_model : {"iirs", "lumped"}   (alias "reduced" accepted)
    beam : str
    """
    key = _MASS_KEYS[mass_model_name(mass_model)]
    ident = load("beams")["beams"][beam]["identified_models"]
    if state not in ident:
        raise BeamDamageError(f"state {state!r} unknown; expected one of {', '.join(ident)}")
    M = np.array(ident["undamaged"][key]["M"], float)
    return M, np.array(ident[state][key]["C"], float), np.array(ident[state][key]["K"], float)


def beam5_reduced_model(damping: str = "thesis"):
    """Beam 5's printed IIRS-reduced ``M``, ``K`` (nodes 2..5) with a damping matrix ``C``.

    ``damping="thesis"``: the ``C`` the thesis identified for the baseline
    (undamaged) beam 5 with the reduced mass (Chapter Six), damping ratios
    0.1-0.4 %. ``damping="heavy"``: Rayleigh damping ``2 M + 4e-6 K`` plus
    dashpots of 0.2 and 0.4 N s/m at the root-side and tip DOFs (non-proportional,
    damping ratios 1-9 %).

    Returns
    -------
    M (kg), C (N s/m), K (N/m) : ndarray, shape (4, 4)
    """
    b5 = load("beams")["beams"]["5"]
    M, K = np.array(b5["iirs_reduced"]["M"], float), np.array(b5["iirs_reduced"]["K"], float)
    if damping == "thesis":
        return M, np.array(b5["identified_models"]["undamaged"]["reduced_mass"]["C"], float), K
    if damping != "heavy":
        raise BeamDamageError(f"damping {damping!r} unknown; expected 'thesis' or 'heavy'")
    C = 2.0 * M + 4e-6 * K
    C[3, 3] += 0.4
    C[0, 0] += 0.2
    return M, C, K


#: DOF labels of beam 5's measured translations (UFF convention) and the index of the tip (reference DOF).
BEAM5_DOFS = ("2:+Y", "3:+Y", "4:+Y", "5:+Y")
BEAM5_TIP = 3


def simulated_beam5_test(noise: float = 0.01, seed: int = 0, df_hz: float = 0.5, fmax_hz: float = 800.0,
                         damping: str = "thesis"):
    """A simulated modal test of beam 5: noisy receptances to a tip force and the exact modes.

    Receptances of :func:`beam5_reduced_model` on lines ``df_hz, 2 df_hz, ..., fmax_hz``
    (reference DOF = tip, node 5), with complex Gaussian noise of standard
    deviation ``noise |H|`` on each line (split evenly over real and imaginary parts).

    Returns
    -------
    frf : physics.io.MeasuredFRF, shape (4, 1, n_lines)
    modes : physics.modal.ComplexModes   (exact)
    """
    M, C, K = beam5_reduced_model(damping)
    f = np.arange(df_hz, fmax_hz + df_hz / 2, df_hz)
    H = receptance(M, C, K, 2 * np.pi * f, reference=[BEAM5_TIP])
    rng = np.random.default_rng(seed)
    H = H + complex_normal(rng, H.shape, noise * np.abs(H))
    frf = MeasuredFRF(f, H, BEAM5_DOFS, (BEAM5_DOFS[BEAM5_TIP],),
                      metadata={"source": f"simulated beam5 seed {seed}"})
    return frf, complex_modes(M, C, K)
