"""Uncertainty and tolerance studies by Monte Carlo, in this process or on Dask (docs/studies.md).

- :func:`study_uncertainty` with a :class:`Covariance` from :func:`covariance_from_report`
  (an identification report) or :func:`covariance_from_campaign` (an instrument and a stated
  campaign): linear propagation and Monte Carlo side by side, for the error map and a
  compensation's residual;
- :func:`study_tolerances` with :func:`read_tolerance_file`: the distribution of the largest
  and RMS error, the probability of meeting a target, Sobol' drivers, a least-cost
  re-allocation checked by re-simulation;
- engines: :class:`InProcess` (default), :func:`local_cluster`, :func:`connect`.
"""

from ._covariance import Covariance, covariance_from_campaign, covariance_from_report
from ._engine import (TASK_SECONDS, DaskEngine, InProcess, PortableMachine, available_cores, connect,
                      local_cluster)
from ._tolerance import ToleranceStudy, check_arguments, study_tolerances, tolerance_source
from ._tolerances import Tolerances, read_tolerance_file, tolerances_toml
from ._uncertainty import UncertaintyStudy, study_uncertainty
from ._evaluator import Evaluator
from ._montecarlo import grid_points, make_points, run_monte_carlo
from ._shapes import work_offset_components

__all__ = ["available_cores", "check_arguments", "connect",
           "Covariance", "covariance_from_campaign", "covariance_from_report", "DaskEngine", "Evaluator", "grid_points",
           "InProcess", "local_cluster", "make_points", "PortableMachine", "read_tolerance_file", "run_monte_carlo",
           "study_tolerances", "study_uncertainty", "TASK_SECONDS", "tolerance_source", "Tolerances", "tolerances_toml", "ToleranceStudy", "UncertaintyStudy",
           "work_offset_components"]
