"""Identification of error-term coefficients from measurements, with an honest report.

Any mix of measurements becomes one set of weighted observations ``y = w . e(q) + nuisance``
(each kind turns itself into rows, see :mod:`volerr_pin.measurements`): ``w`` picks
the measured error direction and the nuisance terms are the instruments' set-ups (an
interferometer's zero and alignment slope, a tracker's placement, a ballbar's centre and
length). Before fitting, :func:`volerr_pin.fit.analyse` finds what the data cannot
determine; those coefficients are held at their prior values (``convention="prior"``, the
default) or the update is the minimum-norm one (``"min-norm"``). The fit is weighted
Gauss-Newton on the exact sensitivities; uncertainties come from the covariance scaled by the
residual; the held-out RMS from k-fold cross-validation over poses (the points of one pose
stay together).

Parts, private modules each importing only those listed before it: the observations and their
checks (:class:`Observations`, :func:`build_observations`); the data's points checked once for
a model (:class:`FitPoints`), the predictions, sensitivities and the triangular factor of the
weighted design in chunks of points, evaluated by the model's algorithms
(:func:`predict_observations`); Gauss-Newton, start values of non-linear coefficients and
uncertainties; cross-validation over poses (:func:`pose_folds`); :class:`Identification` and
its report; :func:`identify`.
"""

from ._crossval import pose_folds
from ._design import FitPoints, by_halves, predict_observations, rows_of, typical_sizes
from ._fit import identify
from ._observations import (Observations, build_observations, check_observations, point_squares, residual_rms,
                           stack_blocks)
from ._result import Identification, check_report_machine, parameter_units
from ._solver import CONDITION_LIMIT, conditioning_note

__all__ = ["build_observations", "by_halves", "check_observations", "check_report_machine", "CONDITION_LIMIT",
           "conditioning_note", "FitPoints", "Identification", "identify", "Observations",
           "parameter_units", "point_squares", "pose_folds", "predict_observations", "residual_rms",
           "rows_of", "stack_blocks", "typical_sizes"]
