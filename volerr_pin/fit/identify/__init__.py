"""Identification of error-term coefficients from measurements, with an honest report.

Any mix of measurements becomes one set of weighted observations ``y = w . e(q) + nuisance``
(each kind turns itself into rows, see :mod:`volerr_pin.measurements.protocol`): ``w`` picks
the measured error direction and the nuisance terms are the instruments' set-ups (an
interferometer's zero and alignment slope, a tracker's placement, a ballbar's centre and
length). Before fitting, :func:`volerr_pin.fit.identifiability.analyse` finds what the data cannot
determine; those coefficients are held at their prior values (``convention="prior"``, the
default) or the update is the minimum-norm one (``"min-norm"``). The fit is weighted
Gauss-Newton on the exact sensitivities; uncertainties come from the covariance scaled by the
residual; the held-out RMS from k-fold cross-validation over poses (the points of one pose
stay together).

Parts, each importing only those listed before it:

- :mod:`~volerr_pin.fit.identify.observations`: the observations and their checks;
- :mod:`~volerr_pin.fit.identify.design`: predictions, sensitivities and the triangular factor of
  the weighted design, in chunks of points;
- :mod:`~volerr_pin.fit.identify.solver`: Gauss-Newton, start values of non-linear coefficients,
  uncertainties;
- :mod:`~volerr_pin.fit.identify.crossval`: cross-validation over poses;
- :mod:`~volerr_pin.fit.identify.result`: :class:`Identification` and its report;
- :mod:`~volerr_pin.fit.identify.fit`: :func:`identify`.
"""

from .crossval import pose_folds
from .design import FitPoints, predict_observations
from .fit import identify
from .observations import (Observations, build_observations, check_observations, point_squares, residual_rms,
                           stack_blocks)
from .result import Identification, check_report_machine, parameter_units
from .solver import CONDITION_LIMIT, conditioning_note

__all__ = ["CONDITION_LIMIT", "FitPoints", "Identification", "Observations", "build_observations", "check_observations",
           "check_report_machine", "conditioning_note", "identify", "parameter_units", "point_squares",
           "pose_folds", "predict_observations", "residual_rms", "stack_blocks"]
