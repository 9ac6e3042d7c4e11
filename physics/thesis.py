"""The thesis's printed numbers as package data (``physics/data/thesis/*.json``).

Fixtures (transcribed from /work/shared/thesis, see each file's ``source`` notes):

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

#: Fixture names (files ``physics/data/thesis/NAME.json``).
FIXTURES = ("beams", "example1_two_dof", "example2_ortiz_beam", "modeshape_example")
#: Keys of the identified models in ``beams.json`` per analyst mass model (:data:`physics.updating.MASS_MODELS`).
_MASS_KEYS = {"iirs": "reduced_mass", "lumped": "lumped_mass"}


def load(name: str) -> dict:
    """A fresh copy of the thesis fixture ``name`` (one of :data:`FIXTURES`) as parsed JSON."""
    if name not in FIXTURES:
        raise BeamDamageError(f"thesis fixture {name!r} unknown; expected one of {', '.join(FIXTURES)}")
    return json.loads(resources.files("physics").joinpath("data", "thesis", f"{name}.json").read_text())


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
    from physics.updating import mass_model_name

    key = _MASS_KEYS[mass_model_name(mass_model)]
    ident = load("beams")["beams"][beam]["identified_models"]
    if state not in ident:
        raise BeamDamageError(f"state {state!r} unknown; expected one of {', '.join(ident)}")
    M = np.array(ident["undamaged"][key]["M"], float)
    return M, np.array(ident[state][key]["C"], float), np.array(ident[state][key]["K"], float)
