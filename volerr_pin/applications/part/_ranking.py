"""Which error sources decide a feature of a part: per component, the profile it gives the
feature alone, to first order (its coefficients times the exact sensitivities at the measured
points), and its share of the feature (:func:`feature_ranking`).
"""

from __future__ import annotations

import numpy as np

from ...base import UM_PER_M
from ...model import Machine, check_covariates, sensitivity
from ._features import CircleFeature, LineFeature
from ._cone import ConeSection

__all__ = ["feature_ranking"]


def _component_columns(machine: Machine) -> dict[str, list[int]]:
    """Each component's coefficient columns, in the machine's order."""
    out: dict[str, list[int]] = {}
    for term in machine.model.term_info():
        out.setdefault(term["component"], []).extend(machine.parameter_names.index(n) for n in term["parameters"])
    return out


def _contributions(machine: Machine, q: np.ndarray, covariates: dict | None = None) -> dict[str, np.ndarray]:
    """Each component's first-order part of the tool's pose error at ``q`` (M, 6: dx, dy, dz
    [m], rx, ry, rz [rad]): its coefficients times the exact sensitivities. ``q`` are a
    feature's measured points, on the cut (within the travel); ``covariates`` those the path
    set there, with the machine's state."""
    theta = machine.theta
    cov = check_covariates(machine.model, len(q), covariates, state=machine.state)
    columns = _component_columns(machine)
    weights = np.zeros((len(theta), len(columns)))   # each component's coefficients in its column
    for k, cols in enumerate(columns.values()):
        weights[cols, k] = theta[cols]
    parts = sensitivity(machine.model, q, theta, cov)[:, :6, :] @ weights   # (one product, not one a component)
    return {component: parts[:, :, k] for k, component in enumerate(columns)}


def _in_plane(parts: dict[str, np.ndarray], plane) -> dict[str, np.ndarray]:
    return {c: p[:, list(plane)] for c, p in parts.items()}


def _rows(profiles: dict[str, np.ndarray]) -> list[dict]:
    energy = {c: float(np.sum(p ** 2)) for c, p in profiles.items()}
    total = sum(energy.values()) or 1.0
    rows = [{"component": c, "alone_um": float(np.ptp(p) * UM_PER_M), "share": energy[c] / total}
            for c, p in profiles.items()]
    return sorted(rows, key=lambda r: -r["share"])


def feature_ranking(machine: Machine, feature, *, cache: dict | None = None) -> list[dict]:
    """Which error sources decide a feature: per component, the feature's profile it causes
    alone (to first order, from the exact sensitivities) and its share.

    The profile is what the feature's value is the range of: a circle's radial deviation less
    its least-squares circle, a side's deviation across it less its least-squares line, a pair's
    zone coordinate with the datum's least-squares line, a cone's section's radial deviation
    (from the error of the tool's position and orientation at the cutting point) less its
    least-squares circle. Per component, ``alone_um`` is the
    range of its own profile (the feature if it acted alone) and ``share`` its share of the sum
    of the profiles' squares, as ``rank``'s share is of the tool point's mean square.

    Parameters
    ----------
    machine : Machine
        The machine the feature was measured on.
    feature : CircleFeature, LineFeature, PairFeature or ConeSection
        The feature (:func:`measure`).
    cache : dict, optional
        Each feature's sources, kept between calls (a side is in its own straightness and in
        every pair it belongs to): pass the same dict for the features of one measurement.

    Returns
    -------
    list of dict
        ``component``, ``alone_um``, ``share``; largest share first.
    """
    def parts(f):   # in its plane for a circle or a side; the whole pose error for a cone's section
        if cache is None or id(f) not in cache:
            found = _contributions(machine, f.q, f.covariates)
            found = found if isinstance(f, ConeSection) else _in_plane(found, f.plane)
            if cache is None:
                return found
            cache[id(f)] = (f, found)   # f kept beside: its id stays its own
        return cache[id(f)][1]

    if isinstance(feature, (CircleFeature, LineFeature, ConeSection)):
        return _rows(feature.profiles(parts(feature)))
    datum, other = feature.datum, feature.toleranced
    u0, n0 = datum.direction, datum.across
    s = datum.along()
    relative = other.measured - datum.start
    datum_parts, other_parts = parts(datum), parts(other)
    # per component (columns), the datum line's turn to first order, and the zone coordinate
    slope = np.polyfit(s, np.stack([p @ n0 for p in datum_parts.values()], axis=1), 1)[0]
    if feature.kind == "parallelism":
        value = np.stack([p @ n0 for p in other_parts.values()], axis=1) - np.outer(relative @ u0, slope)
    else:
        value = np.stack([p @ u0 for p in other_parts.values()], axis=1) + np.outer(relative @ n0, slope)
    value -= value.mean(axis=0)
    return _rows(dict(zip(other_parts, value.T)))
