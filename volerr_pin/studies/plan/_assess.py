"""What a campaign determines: predicted uncertainties from the information matrix, and
uncertainties found by simulating the campaign and identifying from it with identify.

Predicted: the covariance of the coefficients is ``(D^T D)^-1`` over the columns a
selection identifies (``D`` weighted by the instrument's noise, unit-own nuisance terms
projected out, shared ones kept as columns: :mod:`~volerr_pin.studies.plan`); the uncertainty
of the volumetric error at a point ``x`` of the zone is ``sqrt(trace(S_x C S_x^T))`` over the
three position components (``S_x`` the sensitivities of dx, dy, dz to the coefficients), its
RMS and largest value over scrambled Sobol' points of the zone are reported.

Simulated: the machine as given is the truth; the prior sets the identified coefficients to
zero; each repeat draws the instrument's noise (fixed seeds), writes the observations into
the instrument's own measurement objects and identifies them with
:func:`volerr_pin.fit.identify.identify` (first-order design, Gauss-Newton on the exact model).
The RMS over repeats of each coefficient's error, and of the volumetric error's error over the
zone, estimate the same quantities as the predicted ones.
"""

from __future__ import annotations

import warnings

import numpy as np

from ...fit import analyse
from ...fit.identify import identify, rows_of, stack_blocks
from ...measurements import ObservationOptions
from ...base import UM_PER_M
from ...model import check_covariates, volumetric_error
from ._design import UnitDesign

__all__ = ["predicted", "rigid_basis", "simulated", "without_rigid", "zone_summary"]


def rigid_basis(points: np.ndarray) -> np.ndarray:
    """An orthonormal basis of the rigid motions (three translations, three small rotations)
    of a displacement field at ``points``, on the stacked x, y, z of every point.

    Parameters
    ----------
    points : ndarray, shape (Z, 3)
        Where the field is [m].

    Returns
    -------
    ndarray, shape (3 Z, 6)
    """
    p = points - points.mean(axis=0)
    B = np.zeros((len(p), 3, 6))
    B[:, :, :3] = np.eye(3)
    x, y, z = p.T
    B[:, 0, 4], B[:, 0, 5] = z, -y      # omega x p
    B[:, 1, 3], B[:, 1, 5] = -z, x
    B[:, 2, 3], B[:, 2, 4] = y, -x
    return np.linalg.qr(B.reshape(-1, 6))[0]


def without_rigid(field: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """A field (Z, 3, ...) less its best rigid motion (the least-squares fit on
    :func:`rigid_basis`), same shape.

    Parameters
    ----------
    field : ndarray, shape (Z, 3) or (Z, 3, F)
        Displacements (or their sensitivities) at the basis' points.
    basis : ndarray, shape (3 Z, 6)
        From :func:`rigid_basis`.

    Returns
    -------
    ndarray
        The same shape.
    """
    f = field.reshape(basis.shape[0], -1)
    return (f - basis @ (basis.T @ f)).reshape(field.shape)


def predicted(design: UnitDesign, units: np.ndarray, columns: np.ndarray, S_zone: np.ndarray) -> dict:
    """Predicted standard uncertainties of a selection of units.

    Parameters
    ----------
    design : UnitDesign
        The design the units index.
    units : ndarray of int
        The selection.
    columns : ndarray of int
        The columns the candidate pool identifies (shared nuisance first, then coefficients).
    S_zone : ndarray, shape (Z, 3, F)
        Sensitivities of dx, dy, dz at the zone's points to the design's F coefficients.

    Returns
    -------
    dict
        ``std`` (len(columns),) standard uncertainties [SI], inf for columns this selection
        does not identify; ``lost`` names of those columns; ``zone`` (Z,) uncertainty of the
        volumetric error at each zone point [m] (None when a coefficient is lost).
    """
    A = design.take(units)[:, columns]
    names = [design.names[c] for c in columns]
    g = int(np.sum(columns < design.n_global))
    analysis = analyse(A, names, protected=g, rtol=1e-9, what="these measurements", typical=design.typical[columns])
    kept = np.array(analysis.kept, dtype=int)
    std = np.full(len(columns), np.inf)
    Ak = A[:, kept]
    norms = np.linalg.norm(Ak, axis=0)
    C = np.linalg.pinv((Ak / norms).T @ (Ak / norms), hermitian=True) / np.outer(norms, norms)  # column-scaled
    diag = np.diag(C)
    std[kept] = np.where(diag > 0, np.sqrt(np.abs(diag)), np.inf)
    kept_set = set(kept.tolist())
    lost = [names[c] for c in range(len(columns)) if c not in kept_set]
    theta_cols = np.flatnonzero(columns >= design.n_global)
    zone = None
    if all(c in kept_set for c in theta_cols):
        where = {c: i for i, c in enumerate(kept)}
        t = np.array([where[c] for c in theta_cols], dtype=int)
        Sz = S_zone[:, :, columns[theta_cols] - design.n_global]
        zone = np.sqrt(np.maximum(np.einsum("zcp,pq,zcq->z", Sz, C[np.ix_(t, t)], Sz), 0.0))
    return {"std": std, "lost": lost, "zone": zone}


def simulated(machine, instrument, setup, units: list, free: np.ndarray, zone_q: np.ndarray, repeats: int,
              seed: int, rigid: np.ndarray | None = None, prior: np.ndarray | None = None) -> dict:
    """Uncertainties found by simulating a campaign and identifying from it (module docstring).

    Parameters
    ----------
    machine : Machine
        The machine (the truth).
    instrument : Instrument
        The instrument.
    setup : Setup
        Zone, noise, targets, station.
    units : list
        The campaign's units.
    free : ndarray of int, shape (F,)
        The coefficients identified (indices into theta); the others stay at the truth.
    zone_q : ndarray, shape (Z, n_axes)
        Points of the zone [m, rad], within the travel.
    repeats : int
        Simulated campaigns (noise seeds ``seed``, ``seed + 1``, ...).
    seed : int
        First seed.
    rigid : ndarray, shape (3 Z, 6), optional
        Measure the zone's error less its best rigid motion (:func:`rigid_basis`).
    prior : ndarray, shape (P,), optional
        The coefficients the fits start from and hold what they cannot determine at (default:
        the truth with the identified ones at zero).

    Returns
    -------
    dict
        ``std`` (F,) RMS over repeats of each coefficient's error [SI]; ``zone_rms`` RMS over
        repeats and zone points of the 3D position error of the identified model [m];
        ``held`` names of coefficients identify held at the prior in some repeat.
    """
    measurements, _ = instrument.measurements(machine, setup, units)
    sigma_um = setup.sigma * 1e6
    obs = stack_blocks([m.observations(machine, ObservationOptions(sigma_um, sigma_um)) for m in measurements],
                       machine)
    model, truth = machine.model, machine.theta
    error = volumetric_error(model, obs.q, truth, check_covariates(model, obs.n_points, obs.covariates, machine.state))
    truth_rows, _ = rows_of(obs.w, obs.point, error, np.zeros((obs.n_points, 6, 0)))
    if prior is None:
        theta0 = machine.theta.copy()
        theta0[free] = 0.0
    else:
        theta0 = np.array(prior, dtype=float)
    prior = machine.with_theta(theta0, limits=False)   # a simulation: no spec limit applies
    zone_cov = check_covariates(model, len(zone_q), None, machine.state)
    e_zone = volumetric_error(model, zone_q, truth, zone_cov)[:, :3]
    errors, zone_sq, held = [], [], set()
    for r in range(repeats):
        rng = np.random.default_rng(seed + r)
        values = truth_rows + rng.normal(0.0, setup.sigma, len(truth_rows))
        data, _ = instrument.measurements(machine, setup, units, values)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit = identify(prior, data, free=free, folds=0, sigma_um=sigma_um, sigma_urad=sigma_um,
                           initialise=False)
        held.update(machine.parameter_names[k] for k in fit.held)
        errors.append(fit.machine.theta[free] - machine.theta[free])
        found = fit.machine
        d = volumetric_error(found.model, zone_q, found.theta, zone_cov if found.model is model else
                             check_covariates(found.model, len(zone_q), None, found.state))[:, :3] - e_zone
        zone_sq.append(np.sum((d if rigid is None else without_rigid(d, rigid)) ** 2, axis=1))
    errors = np.array(errors)
    return {"std": np.sqrt(np.mean(errors ** 2, axis=0)), "zone_rms": float(np.sqrt(np.mean(zone_sq))),
            "held": sorted(held)}


def zone_summary(zone: np.ndarray | None) -> dict:
    """RMS and largest uncertainty over the zone's points, in um (None when undetermined).

    Parameters
    ----------
    zone : ndarray, shape (Z,), or None
        Uncertainty at each point [m].

    Returns
    -------
    dict
        ``zone_rms_um`` and ``zone_max_um``.
    """
    if zone is None:
        return {"zone_rms_um": None, "zone_max_um": None}
    return {"zone_rms_um": float(np.sqrt(np.mean(zone ** 2)) * UM_PER_M), "zone_max_um": float(zone.max() * UM_PER_M)}
