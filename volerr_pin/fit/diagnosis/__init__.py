"""Find where model and measurements disagree, name the missing effect, add it, repeat.

The loop (:func:`diagnose`):

1. fit the base model to the data (:func:`volerr_pin.fit.identify.identify`; with ``fixed`` the
   spec's values are kept);
2. look at the residuals against positions, time, temperatures, forces and approach
   directions (correlations, reversal steps, a periodogram over each linear axis);
3. build candidates for every axis, direction and sensor they can apply to: the catalogue
   effects - ``thermal_drift`` (time, each temperature), ``thermal_expansion``,
   ``backlash``, ``force_deflection``, ``periodic_pitch`` - the geometric terms the spec
   leaves out (``positioning``, ``straightness``, ``angular``, ``squareness``,
   ``location``), and the base model's own adequacy: every polynomial component one degree
   higher, every table with twice the nodes. Each is fitted jointly with the base model
   (linearised at the base fit, non-linear coefficients by grid search or periodogram);
4. score them: BIC ranks them; the best is accepted only if (a) an F-test of its extra
   parameters is significant at ``alpha`` divided by the number of candidates (Bonferroni;
   a period found by searching a periodogram is further divided by the number of independent
   periods searched), (b) it lowers the k-fold cross-validated RMS, and (c) after the
   joint refit its size is significant: the largest |value| / standard uncertainty of its
   linear coefficients is at least 3 (for a raised degree: the new top coefficient). A
   winning under-modelled component is accepted together with the other components that
   pass on their own (they are checked one by one after the refit);
5. repeat until no candidate passes; compare every named candidate that a round's accepted
   raises swallowed (or that swallowed a raise) with them once more, each reading refitted on
   every observation: within :data:`EVIDENCE_BIC` of each other the finding is "possible,
   cannot be told apart" (both readings, the BIC difference, where they differ most), and a
   named reading better by more than that replaces the raises; refit; drop any effect whose size is no longer
   significant; estimate the noise floor (from repeated points if any, else an upper bound
   from the final residual) and say whether the final model reaches it.

A real machine's geometry is never exactly the spec's. A smooth residual that a higher
degree of an existing component explains as well as an effect does is reported as
"geometric component X under-modelled (degree n -> m)" in :attr:`Diagnosis.under_modelled`,
not as a physical effect. A periodic pitch must have a period in the ball-screw range
(:data:`~volerr_pin.fit.diagnosis._candidates.PITCH_PERIOD_MM`) and at least
:data:`~volerr_pin.fit.diagnosis._effects.MIN_PERIODS` periods inside the measured
travel.

Effects whose effect at the tool is the same wherever they sit (a drift in x through any
axis of a Cartesian machine) are reported with ``axis`` None: the data cannot tell which.

The catalogue effects are plug-ins: each kind is a class (:class:`EffectKind`) with its
candidates, its coefficients' prefix, its label and the properties the loop asks about, found
through a registry (:data:`EFFECTS`, :func:`register`); no part of the loop asks for an effect by
name.

Each round is a pipeline the model goes through once, each stage a private module: what the
model could be missing is offered (the candidates, the error-joint sensitivity, the tables made
richer); every candidate is fitted jointly with the base model on the round's projector and
scored; the best that stays significant is applied to the spec as a typed edit and refitted.
Around the rounds: typed results (candidates, scores, changes, rounds, the :class:`Diagnosis`
and its JSON report), residual analysis, the noise floor and the evidence for pictures
(:func:`residual_analysis`, :func:`evidence`), and :func:`diagnose`.
"""

from ._candidates import axis_directions, build_candidates, geometric_term, raised_term
from ._changes import raise_components
from ._loop import diagnose
from ._report import drift_series, driver_values, evidence, residual_analysis
from ._effects import EFFECTS, EffectKind, effect_kind, register
from ._results import (EVIDENCE_BIC, PRACTICAL_AMPLITUDE, PRACTICAL_GAIN, SIGNIFICANCE, Alternative, Candidate, Change,
                      Diagnosis, DriftSeries, Evidence, Raise, Role, Score, Separation, Step, ThermalModel)

__all__ = ["Alternative", "axis_directions", "build_candidates", "Candidate", "Change", "diagnose", "Diagnosis", "EVIDENCE_BIC",
           "drift_series", "DriftSeries", "driver_values", "effect_kind", "EffectKind", "EFFECTS", "Evidence",
           "evidence", "geometric_term", "PRACTICAL_AMPLITUDE", "PRACTICAL_GAIN", "Raise", "raise_components",
           "raised_term", "register", "residual_analysis", "Role", "Score", "Separation", "SIGNIFICANCE", "Step",
           "ThermalModel"]
