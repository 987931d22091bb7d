"""The result of an identification and its JSON report (docs/reports.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...base import UM_PER_M, URAD_PER_RAD, InputError
from .._identifiability import Analysis
from ...model import Machine

__all__ = ["Identification", "check_report_machine", "parameter_units"]


@dataclass
class Identification:
    """Result of :func:`~volerr_pin.fit.identify.identify`; :meth:`to_dict` gives the JSON report (docs/reports.md).

    Attributes
    ----------
    machine : Machine
        The machine with the fitted coefficients.
    prior : Machine
        The machine as given (prior values).
    free : ndarray of int
        Indices (into theta) of the coefficients that were free to move.
    analysis : Analysis
        Identifiability of the columns [nuisance | free coefficients].
    fitted : ndarray of int
        Indices (into theta) actually fitted.
    held : ndarray of int
        Free but unidentifiable: held at prior (or min-norm).
    uncertainty : ndarray, shape (P,)
        Standard uncertainties (SI unit of each coefficient), NaN where not fitted.
    nuisance : dict of str to float
        Fitted nuisance values (SI: m or rad).
    rms_fit_um : float
        RMS over points of the position residual norm [um] (0.0 without position rows).
    rms_fit_urad : float or None
        Same for the rotation residual [urad]; None without rotation rows.
    rms_holdout_um : float or None
        Held-out RMS of the position residual [um]; None without cross-validation.
    holdout : str
        How the held-out RMS was obtained (or why not).
    n_points : int
        Number of points.
    n_observations : int
        Number of observation rows.
    iterations : int
        Gauss-Newton iterations.
    convention : str
        "prior" or "min-norm".
    residual_sigma : float
        Weighted residual standard deviation (1 = as stated); NaN without degrees of freedom.
    groups : list of IdentifiabilityGroup
        The unidentifiable groups.
    angular_nuisance : frozenset of str
        Names of the nuisance terms in rad (reported in urad).
    solver : str
        "converged", "stalled" or "iteration limit" (see :attr:`solver_text`).
    ill_conditioned : bool
        The column-scaled design is numerically rank-deficient or its condition number
        exceeds :data:`~volerr_pin.fit.identify.CONDITION_LIMIT`: the fitted values along its weakest directions are
        rounding noise.
    covariance : ndarray, shape (len(fitted), len(fitted)), or None
        The covariance of the fitted coefficients, in the order of ``fitted`` (SI units of each
        pair), ``s^2 (J^T J)^-1`` with the nuisance terms marginalised out; NaN in the rows of
        coefficients not determined; None without it (min-norm convention, no degrees of
        freedom).
    """

    machine: Machine                  # with the fitted coefficients
    prior: Machine
    free: np.ndarray                  # indices of the coefficients that were free to move
    analysis: Analysis                # identifiability of [nuisance | free coefficients]
    fitted: np.ndarray                # indices (into theta) actually fitted
    held: np.ndarray                  # free but unidentifiable: held at prior (or min-norm)
    uncertainty: np.ndarray           # (P,) standard uncertainties, NaN where not fitted
    nuisance: dict[str, float]
    rms_fit_um: float
    rms_fit_urad: float | None
    rms_holdout_um: float | None
    holdout: str
    n_points: int
    n_observations: int
    iterations: int
    convention: str
    residual_sigma: float             # weighted residual standard deviation (1 = as stated)
    groups: list = field(default_factory=list)
    angular_nuisance: frozenset = frozenset()
    solver: str = "converged"         # or "stalled", "iteration limit": see solve
    ill_conditioned: bool = False     # beyond what double precision resolves: see CONDITION_LIMIT
    covariance: np.ndarray | None = None   # of the fitted coefficients, in the order of fitted

    @property
    def converged(self) -> bool:
        """True when the solver converged (bool)."""
        return self.solver == "converged"

    @property
    def solver_text(self) -> str:
        """The solver status in words, for reports (str)."""
        return {"converged": "converged",
                "stalled": "stalled (no step lowered the residual the linearised model said it would: "
                           "far from linear here, or ill-conditioned)",
                "iteration limit": "stopped at the iteration limit before converging"}[self.solver]

    def to_dict(self) -> dict:
        """The JSON report (docs/reports.md).

        Returns
        -------
        dict
            ``machine``, ``n_points``, ``n_observations``, ``rank``, ``n_parameters``,
            ``condition_number``, ``ill_conditioned`` (the design is numerically
            rank-deficient or conditioned beyond what double precision resolves),
            ``unidentifiable``, ``convention``, ``solver``,
            ``rms_fit_um``, ``rms_fit_urad``, ``rms_holdout_um``, ``holdout``,
            ``residual_sigma``, ``iterations``, ``nuisance`` (value in um or urad, with its
            ``unit``) and ``parameters``: per coefficient its ``value``, ``prior`` and
            ``uncertainty`` in the spec's display unit, the ``unit`` and a ``status``; and
            ``correlation`` (:meth:`correlation`).
        """
        m, prior = self.machine, self.prior
        params = {}
        units = parameter_units(m)
        for k, name in enumerate(m.parameter_names):
            factor, unit = units[name]
            status = ("fitted" if k in set(self.fitted.tolist()) else
                      "held (not identifiable)" if k in set(self.held.tolist()) else "fixed (not selected)")
            if status == "fitted" and self.solver != "converged":
                status = f"not fitted: the fit {self.solver_text}"
            elif status == "fitted" and self.uncertainty[k] > _undetermined_limit(m, k):
                status = "fitted, not determined (its uncertainty exceeds any plausible value)"
            params[name] = {
                "value": float(m.theta[k] / factor), "prior": float(prior.theta[k] / factor),
                "uncertainty": (float(self.uncertainty[k] / factor) if math.isfinite(self.uncertainty[k])
                                else None),
                "unit": unit, "status": status}
        return {
            "machine": m.name, "n_points": self.n_points, "n_observations": self.n_observations,
            "rank": sum(c >= len(self.nuisance) for c in self.analysis.kept), "n_parameters": int(len(self.free)),
            "condition_number": self.analysis.condition,
            "ill_conditioned": self.ill_conditioned,
            "unidentifiable": [g.to_dict() for g in self.groups],
            "convention": self.convention,
            "solver": self.solver,
            "rms_fit_um": self.rms_fit_um, "rms_fit_urad": self.rms_fit_urad,
            "rms_holdout_um": self.rms_holdout_um, "holdout": self.holdout,
            "residual_sigma": self.residual_sigma, "iterations": self.iterations,
            "nuisance": {n: {"value": v * (URAD_PER_RAD if n in self.angular_nuisance else UM_PER_M),
                             "unit": "urad" if n in self.angular_nuisance else "um"}
                         for n, v in self.nuisance.items()},
            "parameters": params,
            "correlation": self.correlation(),
        }

    def correlation(self) -> dict | None:
        """The correlations of the fitted coefficients that have an uncertainty, as the report
        gives them: ``{"parameters": [names], "matrix": [[...]]}``
        (:func:`~volerr_pin.studies.covariance_from_report` propagates them; GUM 5.2).

        Returns
        -------
        dict or None
            None when the fit gives no covariance (min-norm convention, no degrees of freedom,
            a fit that did not converge) or no coefficient has an uncertainty.
        """
        if self.covariance is None or self.solver != "converged":
            return None
        u = np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))
        keep = np.flatnonzero(np.isfinite(u) & (u > 0))   # what the report's reader propagates
        if not keep.size:
            return None
        C = self.covariance[np.ix_(keep, keep)]
        matrix = np.clip(C / np.outer(u[keep], u[keep]), -1.0, 1.0)
        np.fill_diagonal(matrix, 1.0)
        return {"parameters": [self.machine.parameter_names[self.fitted[i]] for i in keep],
                "matrix": matrix.tolist()}


def _undetermined_limit(machine: Machine, k: int) -> float:
    """An uncertainty beyond which a coefficient is not determined at all (SI): 10 mm for a
    length, 0.01 rad (0.6 deg) for an angle, ten times its value for a non-linear one."""
    if k in set(machine.nonlinear_parameters):
        return 10.0 * abs(machine.theta[k])
    return 0.01  # m or rad alike (coefficients per newton or per kelvin are far below it)


def parameter_units(machine: Machine) -> dict[str, tuple[float, str]]:
    """Coefficient name -> (SI per display unit, display unit), the spec's units.

    Parameters
    ----------
    machine : Machine
        The machine.

    Returns
    -------
    dict of str to tuple of (float, str)
        For every coefficient name, the SI value of one display unit and the unit's name.
    """
    return {name: unit for comp in machine.spec.components for tspec in comp.terms
            for name, unit in zip(tspec.names(comp.name), tspec.term.coefficient_units())}


def check_report_machine(report: dict, machine: Machine, source: str, what: str = "report") -> None:
    """Refuse a report read back (an identification, a diagnosis) that names another machine in
    its ``machine`` field: its coefficients or components may share names with this machine's.

    Parameters
    ----------
    report : dict
        The report.
    machine : Machine
        The machine it is used for.
    source : str
        Its file, for messages.
    what : str
        What the report is, for messages.

    Raises
    ------
    InputError
        Naming the file and both machines.
    """
    named = report.get("machine")
    if named is not None and named != machine.name:
        raise InputError(f"{source}: machine: the {what} is of {named!r}, not of {machine.name!r}; give one made "
                         f"for {machine.name}")
