"""Modal identification from measured FRFs.

Modules (each name below is re-exported here):

``modes``     :class:`ModalEstimate`, the identified modes every method returns; shapes from residues, MPC
``sdof``      single-mode methods: peak picking with half-power damping, circle fit (eq. 3.13)
``poles``     stabilisation diagrams and the automatic selection of physical poles
``lscf``      poly-reference LSCF poles; :func:`identify_lscf` (LSCF, pole selection and LSFD in one call)
``lsfd``      LSFD residues for given poles, residual terms, weighting and noise model
``methods``   :data:`METHODS`, the table of identification methods (function, help, uncertainty, options)
``measured``  :func:`identify_frf` on a :class:`~physics.io.MeasuredFRF` or an FRF file, by a method of the table
``ssi``       output-only: covariance-driven stochastic subspace identification of response records
``fdd``       output-only: frequency-domain decomposition and enhanced FDD of response records
``fft_peak``  output-only baseline: peaks of the zero-padded FFT of the whole record (method ``fftpeak``)
``setups``    output-only: several setups (roving sensors, fixed references) merged into one set of shapes
``free_decay`` output-only, free responses: the decays after hits, ERA and the least-squares refinement
``damped_sinusoids`` variable-projection fit of damped sinusoids common to free decays (one sigma of the poles)
``output_only`` :func:`identify_records` on response records (no force) by an output-only method of the table, or
              the one it picks (free response: ``era``; otherwise ``ssi``)
``channel_weights`` each channel of a multichannel record in units of its own noise floor before the output-only
              methods, the shapes returned on the recorded channels

Conventions: FRF arrays are ``(n_responses, n_references, n_lines)`` receptances
(m/N) unless stated; frequencies carry ``_hz`` or ``_rad_s`` in their names.
Complex modes follow the package's conjugate-pair convention (see
:mod:`physics.modal`).
"""

from physics.identification.lscf import LSCFIdentification, identify_lscf, lscf
from physics.identification.lsfd import ESTIMATION_PASSES, WEIGHTINGS, LSFDResult, estimate_noise_model, lsfd
from physics.identification.measured import (Identification, identify_file, identify_frf, identify_frfs,
                                             read_measured_frf, reconstruction_error_db)
from physics.identification.methods import MAX_LSCF_VALUES, METHODS, MethodSpec
from physics.identification.modes import ModalEstimate, modal_phase_collinearity, shapes_from_residues
from physics.identification.output_only import (DEFAULT_OUTPUT_ONLY, RecordsIdentification, holds_response_records,
                                                identify_records, read_response_records, response_records)
from physics.identification.poles import (STABILITY_CODES, SelectedPoles, StabilisationDiagram, select_poles,
                                          stability_status)
from physics.identification.sdof import (CircleFit, circle_fit, circle_fit_sdof, complex_modes_from_driving_point,
                                         find_peaks_indicator, mode_indicator, peak_picking, real_modes_from_peaks)

__all__ = ["DEFAULT_OUTPUT_ONLY", "RecordsIdentification", "holds_response_records", "identify_records",
           "read_response_records", "response_records",
           "CircleFit", "ESTIMATION_PASSES", "Identification", "LSCFIdentification", "LSFDResult", "MAX_LSCF_VALUES",
           "METHODS", "MethodSpec", "ModalEstimate", "STABILITY_CODES", "SelectedPoles", "StabilisationDiagram",
           "WEIGHTINGS", "circle_fit", "circle_fit_sdof", "complex_modes_from_driving_point", "estimate_noise_model",
           "find_peaks_indicator", "identify_file", "identify_frf", "identify_frfs", "identify_lscf", "lscf", "lsfd",
           "modal_phase_collinearity", "mode_indicator", "peak_picking", "read_measured_frf", "real_modes_from_peaks",
           "reconstruction_error_db", "select_poles", "shapes_from_residues", "stability_status"]
