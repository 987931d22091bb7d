"""Where the uncertainty of a machine's coefficients comes from.

- :func:`covariance_from_report`: the JSON report of ``volerr identify``: every
  fitted coefficient's value and standard uncertainty (held and fixed ones have none and
  are not propagated), and their correlations (``correlation``: ``{"parameters": [names],
  "matrix": [[...]]}``), which the fit's covariance ``s^2 (J^T J)^-1`` carries: GUM 5.2 needs
  them (the coefficients of one component's polynomial correlate up to -0.97). A report
  without them (made before they were written) is propagated as uncorrelated, with a warning.
- :func:`covariance_from_campaign`: the covariance a least-squares identification would
  have, from a stated campaign: the tool position measured in x, y and z at ``points``
  poses (Sobol' points over the travels) with an instrument of standard uncertainty
  ``sigma`` per coordinate, independent. ``Sigma = sigma^2 (J^T J)^-1`` over the coefficients
  such a campaign determines (:func:`volerr_pin.fit.analyse`, as ``identify``
  decides it); the others are held at their values, as ``identify`` holds them, and are
  not propagated.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..base import UM, InputError, read_json, require_memory, sensible
from ..fit import analyse
from ..fit.identify import check_report_machine, parameter_units
from ..model import Machine, check_covariates, sample, sensitivity

__all__ = ["Covariance", "covariance_from_campaign", "covariance_from_report"]


@dataclass(frozen=True)
class Covariance:
    """A machine's coefficient estimate and the covariance of the uncertain ones (SI).

    Attributes
    ----------
    machine : Machine
        The machine with the estimated coefficients.
    indices : ndarray of int, shape (p,)
        Coefficients (into ``machine.theta``) that carry an uncertainty.
    matrix : ndarray, shape (p, p)
        Their covariance [SI unit of each coefficient squared, or products].
    source : str
        Where it comes from, in words.
    not_propagated : tuple of str
        Coefficients without an uncertainty (held, fixed, or not in the report).
    """

    machine: Machine
    indices: np.ndarray
    matrix: np.ndarray
    source: str
    not_propagated: tuple[str, ...] = ()

    @property
    def std(self) -> np.ndarray:
        """Standard uncertainties of the uncertain coefficients, shape (p,) [SI]."""
        return np.sqrt(np.clip(np.diag(self.matrix), 0.0, None))

    def factor(self) -> np.ndarray:
        """A square root ``F`` of the covariance, embedded in the full coefficient vector.

        Returns
        -------
        ndarray, shape (P, p)
            ``F @ F.T`` is the covariance of all P coefficients (zero rows for the others),
            from the symmetric eigen-decomposition (negative rounding eigenvalues as 0).
        """
        values, vectors = np.linalg.eigh((self.matrix + self.matrix.T) / 2)
        root = vectors * np.sqrt(np.clip(values, 0.0, None))
        out = np.zeros((len(self.machine.parameter_names), len(self.indices)))
        out[self.indices] = root
        return out


def _report_error(path: Path, message: str) -> InputError:
    return InputError(f"{path}: {message}")


def covariance_from_report(machine: Machine, path: str | Path) -> Covariance:
    """The estimate and covariance an identification report gives.

    Parameters
    ----------
    machine : Machine
        The machine the report was made for (its coefficient names and units).
    path : str or Path
        The JSON report ``volerr identify`` printed.

    Returns
    -------
    Covariance
        The machine with the report's values, the uncertain coefficients and their
        covariance (diagonal unless the report has ``correlation``).

    Raises
    ------
    InputError
        Naming the file (and the line and column of a JSON error, or the coefficient), if it
        is not JSON, has no ``parameters``, names a coefficient the machine does not have,
        gives another unit than the machine's, a value or uncertainty that is not a finite
        number (a negative uncertainty), no uncertainty at all, or a correlation matrix that
        is not square, symmetric, within [-1, 1] with a unit diagonal and positive
        semi-definite.

    Warns
    -----
    UserWarning
        When the report gives no correlations (written before identify gave them): its
        coefficients are propagated as uncorrelated.
    """
    path = Path(path)
    report = read_json(path, InputError, "identification report")
    if not isinstance(report, dict) or not isinstance(report.get("parameters"), dict):
        raise _report_error(path, "no 'parameters' object: not an identification report")
    check_report_machine(report, machine, str(path))
    units = parameter_units(machine)
    names = machine.parameter_names
    theta = machine.theta
    bounds = machine.theta_bounds
    sigma = np.full(len(names), np.nan)
    for name, entry in report["parameters"].items():
        if name not in units:
            raise _report_error(path, f"parameters.{name}: not a coefficient of {machine.name}")
        if not isinstance(entry, dict):
            raise _report_error(path, f"parameters.{name}: expected an object with value and uncertainty")
        factor, unit = units[name]
        if entry.get("unit", unit) != unit:
            raise _report_error(path, f"parameters.{name}: unit {entry.get('unit')!r}, but {machine.name} gives "
                                      f"it in {unit!r}; was the report made for this machine?")
        k = names.index(name)
        low, high = bounds[k] / factor
        value = entry.get("value")
        if value is not None:
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise _report_error(path, f"parameters.{name}.value: expected a number, got {value!r}")
            if not low <= value <= high:
                raise _report_error(path, f"parameters.{name}.value: {value:.10g} {unit} is implausible: a spec "
                                          f"refuses values beyond {low:.10g} .. {high:.10g} {unit}")
            theta[k] = value * factor
        u = entry.get("uncertainty")
        if u is not None:
            if isinstance(u, bool) or not isinstance(u, (int, float)) or not math.isfinite(u) or u < 0:
                raise _report_error(path, f"parameters.{name}.uncertainty: expected a non-negative number, got {u!r}")
            if u > high - low:
                raise _report_error(path, f"parameters.{name}.uncertainty: {u:.10g} {unit} is implausible: wider "
                                          f"than all a spec allows ({low:.10g} .. {high:.10g} {unit})")
            sigma[k] = u * abs(factor)
    indices = np.flatnonzero(np.isfinite(sigma) & (sigma > 0))
    if not indices.size:
        raise _report_error(path, "no coefficient has an uncertainty (was the fit under the min-norm convention, "
                                  "or did it not converge?)")
    D = sigma[indices]
    R = np.eye(len(indices))
    corr = report.get("correlation")
    if corr is not None:
        R = _correlation(path, corr, [names[k] for k in indices], machine)
    elif len(indices) > 1:
        warnings.warn(f"{path}: the report gives no correlations between its {len(indices)} coefficients' "
                      "uncertainties; they are propagated as uncorrelated, which misstates every uncertainty "
                      "that depends on several (GUM 5.2): identify again to get a report that has them",
                      stacklevel=2)
    return Covariance(machine.with_theta(theta), indices, R * np.outer(D, D), f"identification report {path}",
                      tuple(names[k] for k in range(len(names)) if k not in set(indices.tolist())))


def _correlation(path: Path, corr, wanted: list[str], machine: Machine) -> np.ndarray:
    if not isinstance(corr, dict) or not isinstance(corr.get("parameters"), list):
        raise _report_error(path, "correlation: expected {\"parameters\": [...], \"matrix\": [[...]]}")
    given = corr["parameters"]
    for i, name in enumerate(given):
        if not isinstance(name, str) or name not in machine.parameter_names:
            raise _report_error(path, f"correlation.parameters[{i}]: {name!r} is not a coefficient of "
                                      f"{machine.name}; a correlation is used in full or not at all")
        if name in given[:i]:
            raise _report_error(path, f"correlation.parameters[{i}]: {name!r} is named twice")
    missing = [name for name in wanted if name not in given]
    if missing:
        raise _report_error(path, f"correlation.parameters: {missing[0]} has an uncertainty but no correlation"
                                  + (f" (nor {len(missing) - 1} more)" if len(missing) > 1 else "")
                                  + "; a correlation is used in full or not at all")
    rows = corr.get("matrix")
    n = len(given)
    if not isinstance(rows, list) or len(rows) != n or not all(isinstance(row, list) and len(row) == n for row in rows):
        raise _report_error(path, f"correlation.matrix: expected {n} rows of {n} numbers (one per coefficient "
                                  "named)")
    for i, row in enumerate(rows):
        for j, entry in enumerate(row):
            if isinstance(entry, bool) or not isinstance(entry, (int, float)):
                raise _report_error(path, f"correlation.matrix[{i}][{j}] ({given[i]}, {given[j]}): expected a "
                                          f"number, got {entry!r}")
    matrix = np.asarray(rows, dtype=float)
    if matrix.shape != (n, n) or not np.isfinite(matrix).all():
        raise _report_error(path, f"correlation.matrix: expected {n} x {n} finite numbers, got shape {matrix.shape}")
    if not np.allclose(matrix, matrix.T, atol=1e-9) or np.any(np.abs(matrix) > 1 + 1e-9) \
            or not np.allclose(np.diag(matrix), 1.0, atol=1e-9):
        raise _report_error(path, "correlation.matrix: not symmetric with a unit diagonal and entries in [-1, 1]")
    if np.linalg.eigvalsh((matrix + matrix.T) / 2).min() < -1e-8:
        raise _report_error(path, "correlation.matrix: not positive semi-definite")
    where = {name: i for i, name in enumerate(given)}
    R = np.eye(len(wanted))
    for a, na in enumerate(wanted):
        for b, nb in enumerate(wanted):
            if a != b and na in where and nb in where:
                R[a, b] = matrix[where[na], where[nb]]
    return R


def covariance_from_campaign(machine: Machine, sigma: float, *, points: int = 200, seed: int = 0,
                             rtol: float = 1e-9) -> Covariance:
    """The covariance of a least-squares identification from a stated campaign.

    Parameters
    ----------
    machine : Machine
        The machine (its coefficients are the estimate; the sensitivities are taken there).
    sigma : float
        Standard uncertainty of the instrument per measured coordinate [m].
    points : int, default 200
        Poses measured: Sobol' points over the travels (seed ``seed``); at each, x, y, z.
    seed : int, default 0
        Seed of the poses.
    rtol : float, default 1e-9
        Relative tolerance of the identifiability tests.

    Returns
    -------
    Covariance
        ``sigma^2 (J^T J)^-1`` over the coefficients the campaign determines.

    Raises
    ------
    InputError
        If ``sigma`` is not a positive finite number, ``points`` is below 1, or the campaign
        determines no coefficient.
    """
    if not (isinstance(sigma, (int, float)) and math.isfinite(sigma) and sigma > 0):
        raise InputError(f"instrument_sigma must be a positive number of um, got {sigma / UM if sigma else sigma!r}",
                         parameters=("instrument_sigma",))
    sensible("instrument_sigma", sigma, "error_length", "um", UM)
    if isinstance(points, bool) or int(points) != points or points < 1:
        raise InputError(f"campaign_points must be >= 1, got {points!r}", parameters=("campaign_points",))
    require_memory(points * 6.0 * len(machine.parameter_names) * 8 * 3, f"a campaign of {points:,} poses",
                   ("campaign_points",))
    q = sample(machine, int(points), seed=seed)   # within the travel
    model = machine.model
    J = sensitivity(model, q, machine.theta, check_covariates(model, len(q), None, machine.state)
                    )[:, :3, :].reshape(-1, len(machine.parameter_names))
    analysis = analyse(J, machine.parameter_names, rtol=rtol, what="a tool-point campaign")
    kept = np.array(sorted(analysis.kept), dtype=int)
    if not kept.size:
        raise InputError(f"a campaign of {points} poses determines no coefficient of {machine.name}",
                         parameters=("campaign_points",))
    Jk = J[:, kept]
    scale = np.linalg.norm(Jk, axis=0)
    scale[scale == 0] = 1.0
    Js = Jk / scale
    cov = np.linalg.pinv(Js.T @ Js) / np.outer(scale, scale) * sigma**2
    names = machine.parameter_names
    return Covariance(machine, kept, cov,
                      f"a campaign of {points} tool-point poses (x, y, z), instrument sigma {sigma / UM:g} um",
                      tuple(names[k] for k in range(len(names)) if k not in set(kept.tolist())))
