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

from .covariance import Covariance, covariance_from_campaign, covariance_from_report
from .engine import InProcess, connect, local_cluster
from .tolerance import ToleranceStudy, study_tolerances
from .tolerances import Tolerances, read_tolerance_file
from .uncertainty import UncertaintyStudy, study_uncertainty

__all__ = ["Covariance", "InProcess", "ToleranceStudy", "Tolerances", "UncertaintyStudy", "connect",
           "covariance_from_campaign", "covariance_from_report", "local_cluster", "read_tolerance_file",
           "study_tolerances", "study_uncertainty"]
