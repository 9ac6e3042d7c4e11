"""Physics of vibrating beams: FE models, reduction, complex modes, FRFs, updating.

Modules (one concept each; float64, batched over leading axes, SI units)
------------------------------------------------------------------------
``errors``          exceptions (all user errors derive from ``BeamDamageError``, a ``ValueError``)
``fem``             Euler-Bernoulli elements, assembly, boundary conditions and DOF names
``properties``      thesis specimens (presets), closed-form cantilever results, section rigidity
``reduction``       Guyan, IRS, IIRS (eqs. 3.35-3.44)
``modal``           complex and undamped modes, f/zeta <-> eigenvalue, MAC
``frf``             receptance by direct inversion, pole-residue and state space; FRF kinds
``updating``        Lancaster/Pilkey damping and stiffness updating; the analyst mass
``ratio_trend``     where a mode lies by the measured/model frequency ratios of the others (pairing)
``estimation``      FRF estimation from time histories (H1, H2, Hv)
``identification``  modal identification from FRFs (peak picking, circle fit, LSCF/LSFD)
``io``              file formats (one table, ``physics.io.FORMATS``: readers, writers, sniffing) and atomic writes
``thesis``          the thesis's printed numbers as package data
``frf_kernels``     compiled (numba) pole-pair FRF synthesis

The names below are the public API other packages (``datagen``, ``learn``,
``experiments``) import; ``io`` and ``identification`` are used as modules.
"""

from physics import errors, estimation, fem, frf, modal, properties, reduction, supports, thesis, updating
from physics.errors import (BeamDamageError, ConfigError, ConvergenceError, FileFormatError, OverdampedError,
                            ShapeError)
from physics.estimation import FRFEstimate, estimate_frf
from physics.fem import FEModel, KeptDofs, beam_model, kept_dofs, lumped_mass
from physics.frf import (FRF_KINDS, FRF_UNITS, PoleResidues, convert_frf, pole_residue, poles_and_residues,
                         receptance, receptance_modal, receptance_state_space)
from physics.modal import (ComplexModes, complex_modes, eigenvalues_from_modal, mac, modal_parameters,
                           undamped_modes, underdamped_modes)
from physics.properties import (CANTILEVER_BETA_L, PRESETS, BeamPreset, beam_preset, cantilever_curvature_squared,
                                cantilever_frequencies_hz)
from physics.reduction import Reduction, guyan, iirs, irs
from physics.supports import SUPPORTS, Support, support
from physics.updating import (MASS_MODELS, UpdateResult, analyst_mass, lancaster_direct, mass_model_name, pilkey,
                              reduced_mass)

__all__ = [
    # modules
    "errors", "estimation", "fem", "frf", "modal", "properties", "reduction", "supports", "thesis", "updating",
    # errors
    "BeamDamageError", "ConfigError", "ConvergenceError", "FileFormatError", "OverdampedError", "ShapeError",
    # FE model
    "FEModel", "KeptDofs", "beam_model", "kept_dofs", "lumped_mass",
    # supports
    "SUPPORTS", "Support", "support",
    # properties
    "CANTILEVER_BETA_L", "PRESETS", "BeamPreset", "beam_preset", "cantilever_curvature_squared",
    "cantilever_frequencies_hz",
    # reduction
    "Reduction", "guyan", "irs", "iirs",
    # modes
    "ComplexModes", "complex_modes", "underdamped_modes", "undamped_modes", "modal_parameters",
    "eigenvalues_from_modal", "mac",
    # FRFs
    "FRF_KINDS", "FRF_UNITS", "PoleResidues", "convert_frf", "pole_residue", "poles_and_residues", "receptance",
    "receptance_modal", "receptance_state_space", "FRFEstimate", "estimate_frf",
    # updating
    "MASS_MODELS", "UpdateResult", "analyst_mass", "lancaster_direct", "mass_model_name", "pilkey", "reduced_mass",
]
