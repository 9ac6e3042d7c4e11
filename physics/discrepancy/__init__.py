"""Model discrepancy: where a beam model misses measured data, which physical effect it lacks, and what it cannot tell.

Workflow (:func:`analyse`)
--------------------------
1. Pair measured and model modes by the rule given (``beam-damage discrepancy``: ``classify``'s, frequency order
   kept and never beyond 35 %, MAC >= 0.5 with two or more sensors; else MAC when shapes exist, else frequency)
   and stop before any fit when a measured mode pairs with none (:func:`pair_measured`); then
   form residuals: frequency error (%), damping ratio error, MAC, and FRF error
   per band (dB) when FRFs are given (:func:`mode_residuals`). Measured modes are
   bending modes: a free-free model's two lowest modes (rigid-body, or bounce and
   pitch on a suspension) are left out (:func:`bending_modes`).
2. Recalibrate the global parameters first: ``EI`` always, the mass per length
   when FRFs fix the absolute scale. From frequencies alone ``EI/m`` scales
   every frequency by one factor, so only frequency *ratios* (and shapes, FRF
   shapes) carry information about a missing effect; an effect is named only
   when it explains what this recalibration cannot.
3. Damping is modal: every measured mode keeps its own measured damping ratio
   (the null model, one free ratio per mode, as in most real tests), so the
   ratios themselves never score a candidate. A local dashpot keeps only its
   non-proportional coupling (the off-diagonal modal damping), visible in the
   imaginary parts of complex mode shapes and in FRFs; without those it is
   not tested.
4. For each candidate of the beam's supports (:func:`physics.effects.candidates_for`
   its ``bc``: shear deformation, rotary inertia, added mass, local damping and
   the support's own effect: root or clamp springs, bearing springs, suspension), a bounded,
   multi-start least-squares fit of its parameters together with the global
   ones on every residual present (frequencies, real and imaginary parts of
   shapes, FRF magnitudes), each whitened by its noise level (:class:`Noise`).
   FRFs enter as their mean level per mode band (:func:`_band_mean_db`; it
   fixes the mass), their modes as the identified modal data.
   Score: ``sum_b chi^2_b / c_b + k ln n``, the BIC with the noise given
   (Schwarz 1978; ``chi^2`` is ``-2 ln L`` up to a constant for Gaussian
   errors of known variance), with ``c_b`` the best fit's ``chi^2_b / dof_b``
   where a chi^2 test rejects block ``b``'s noise as too small
   (quasi-likelihood variance inflation, Burnham & Anderson 2002), else 1
   (with ``estimate_noise``, an assumed noise is first scaled to the data:
   ``c_b = s^2 < 1`` from round 1's best-fitting model, see :func:`analyse`);
   and a leave-one-mode-out (LOMO) prediction error of each mode's data.
5. The best candidate is named when its score is at least
   :data:`BIC_SIGNIFICANT` below the current model's ("strong evidence",
   Kass & Raftery 1995) and its LOMO error is not worse; else ``"none"``.
   Other significant candidates whose fitted predictions of the measured
   quantities differ from the winner's by less than :data:`DISTINCT` (squared,
   in noise units) are reported as indistinguishable, with the measurement that
   separates them most (a higher mode, mode shapes, or the driving-point
   antiresonances, predicted by the two fitted models). The data block whose
   chi^2 fell most is the effect's evidence.
6. The named effect joins the model and the search repeats (at most
   ``max_effects`` effects); it stops when nothing significant remains.
7. The final model's chi^2 is tested against its degrees of freedom
   (:func:`noise_check`): is the residual consistent with the assumed noise? Above
   :data:`STOP_CHI2_PER_DOF` nothing is written (:func:`failed_noise_check` names the likely cause).
8. Every candidate not named gets a detection limit (:func:`detection_limits`):
   the size it would need to be named with these data and this noise.

Modules
-------
``measurement``  measured data and noise; ``model``  model modes at the measured
points, pairing, residuals, simulated measurements; ``candidates``  the
parameters of each effect; ``fitting``  one candidate's fit; ``selection``  the
score, the decision of a round, the chi^2 noise test; ``limits``  detection
limits; ``pairing``  which model mode each measured mode is, and when to stop (several poles in a mode's band:
:mod:`physics.ratio_trend`);
``workflow``  :func:`analyse`;
``files``  :func:`analyse_file`, the workflow on a measurement
file with its outputs (calibrated beam file, tables, figures).
"""

from physics.discrepancy.candidates import g_core_pa
from physics.discrepancy.fitting import BLOCKS, Fit
from physics.discrepancy.limits import DETECTION_POWER, SIZES, DetectionLimit, detection_limits
from physics.discrepancy.measurement import Measurement, Noise, frf_scatter_db, has_complex_shapes
from physics.discrepancy.model import (ModeResiduals, Prediction, bending_modes, mode_residuals, pair_modes_by_mac,
                                       predict, rayleigh_fit, simulate_measurement)
from physics.discrepancy.selection import (BIC_SIGNIFICANT, DISTINCT, NOISE_DOF_MIN, P_NOISE, NoiseCheck, Step,
                                           noise_check)
from physics.discrepancy.pairing import (STOP_CHI2_PER_DOF, ImplausibleTest, Pairing, failed_noise_check,
                                         pair_measured)
from physics.discrepancy.workflow import DiscrepancyResult, analyse, check_candidates
from physics.discrepancy.files import (EXAMPLE, analyse_file, assumed_noise, estimated_noise, load_measurement,
                                      measured_test_notes, measurement_mesh)

__all__ = ["BIC_SIGNIFICANT", "BLOCKS", "DETECTION_POWER", "DISTINCT", "DetectionLimit", "DiscrepancyResult", "EXAMPLE",
           "Fit", "ImplausibleTest", "Pairing", "STOP_CHI2_PER_DOF", "analyse_file", "failed_noise_check",
           "pair_measured", "assumed_noise", "estimated_noise", "load_measurement", "measured_test_notes",
           "measurement_mesh",
           "Measurement", "ModeResiduals", "NOISE_DOF_MIN", "Noise", "NoiseCheck", "P_NOISE", "Prediction", "SIZES",
           "Step", "analyse", "bending_modes", "check_candidates", "detection_limits", "frf_scatter_db", "g_core_pa",
           "has_complex_shapes", "mode_residuals", "noise_check", "pair_modes_by_mac", "predict", "rayleigh_fit",
           "simulate_measurement"]
