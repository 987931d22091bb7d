"""Which error sources move the tool, where and by how much; and which cannot be told apart.

:func:`rank` samples the workspace and, for every component error (or every coefficient),
reports the tool-point error it causes per unit and at its current (or toleranced) size,
its share of the total, the seed 004 contribution degree within its axis, and its share of
the tool-orientation error. :func:`tool_identifiability` finds coefficients whose effect at
the tool is zero, exactly collinear with another's, or a linear combination of others.
All of it is first order: exact sensitivities at the machine's current errors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..base import (ARCSEC, ARCSEC_PER_RAD, LENGTH, UM, UM_PER_M, InputError, SpecError, integer, positive,
                    require_memory, scale, split_key, within)
from ._identifiability import IdentifiabilityGroup, analyse
from ..model import (Machine, check_covariates, check_q, component_sensitivity, component_values, parse_component_name,
                     read_toml, sample, sensitivity)

DIRECTIONS = {"x": [0], "y": [1], "z": [2], "all": [0, 1, 2]}


@dataclass(frozen=True)
class Ranking:
    """Result of :func:`rank`; ``rows`` are sorted by influence (see :meth:`to_dict`).

    Attributes
    ----------
    machine : str
        Machine name.
    points : int
        Number of workspace points.
    direction : str
        "x", "y", "z" or "all": the tool-point error component(s) measured.
    by : str
        "component" or "parameter".
    basis : str
        "current values" or "tolerances": what sizes the contributions.
    rows : list of dict
        One row per component or coefficient, largest mean-square contribution first, with
        the fields listed in :func:`rank` and ``ms``, the mean-square contribution [um^2].
    """

    machine: str
    points: int
    direction: str
    by: str
    basis: str  # "current values" or "tolerances"
    rows: list[dict] = field(default_factory=list)

    def to_dict(self, top: int | None = None) -> dict:
        """The JSON report fields (docs/reports.md).

        Parameters
        ----------
        top : int, optional
            List only the first ``top`` rows (default, or 0: all).

        Returns
        -------
        dict
            ``machine``, ``points``, ``direction``, ``by``, ``basis`` and ``ranking``: the rows
            without ``ms``, with ``share`` renormalised over the rows listed and
            ``share_of_all`` over every term.

        Raises
        ------
        InputError
            If ``top`` is not a whole number >= 0.
        """
        top = None if top is None else integer("top", top, 0)
        rows = [dict(r) for r in (self.rows[:top] if top else self.rows)]
        total = sum(r["ms"] for r in rows)
        grand = sum(r["ms"] for r in self.rows)
        for r in rows:
            r["share"] = r["ms"] / total if total > 0 else 0.0
            r["share_of_all"] = r["ms"] / grand if grand > 0 else 0.0
        for r in rows:
            del r["ms"]
        return {"machine": self.machine, "points": self.points, "direction": self.direction,
                "by": self.by, "basis": self.basis, "ranking": rows}


def tolerance_key(key: str, value, machine: Machine, seen: dict, path: str | Path) -> tuple[str, str, float]:
    """One key of a tolerance file read by a spec's rules: its stem (a component of the
    machine, or ``default``), its quantity and its SI value.

    Parameters
    ----------
    key : str
        The key, with its unit (``EXX_um``, ``default_arcsec``).
    value : object
        Its value (a number).
    machine : Machine
        The machine.
    seen : dict
        ``(stem, quantity) -> key`` of the keys read so far (updated): one value under one key.
    path : str or Path
        The file, for messages.

    Returns
    -------
    tuple of (str, str, float)
        Stem, ``"length"`` or ``"angle"``, the value [m or rad].

    Raises
    ------
    SpecError
        Naming the file and the key: no unit or one of the wrong kind, a component the machine
        lacks, a tolerance given under two keys (``EXX_um`` and ``EXX_mm``), a value that is not
        a non-negative finite number or lies beyond a spec's plausibility limits (an error of
        1 m or 1 rad).
    """
    stem, unit = split_key(key)
    where = f"{path}: {key}"
    if unit is None:
        raise SpecError(f"{where}: give the unit in the key, e.g. {key}_um or {key}_arcsec")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
        raise SpecError(f"{where}: expected a non-negative number, got {value!r}")
    if stem == "default":
        quantity = "length" if unit in LENGTH else "angle"
    elif stem in machine.components:
        quantity = "length" if parse_component_name(stem)[0] in "XYZ" else "angle"
    else:
        raise SpecError(f"{where}: '{stem}' is not an error term of {machine.name} "
                        f"(terms: {', '.join(machine.components)})")
    first = seen.setdefault((stem, quantity), key)
    if first != key:
        raise SpecError(f"{path}: both {first} and {key} given; give the tolerance once, with its unit")
    factor = scale(unit, quantity, where)
    within(np.array([value * factor]), f"error_{quantity}", where, unit, factor)
    return stem, quantity, value * factor


def read_tolerances(path: str | Path, machine: Machine) -> dict[str, float]:
    """Read ``term -> expected magnitude`` from a TOML file.

    Keys carry their unit (``EXX_um = 5``, ``EC0Y_arcsec = 3``), with optional
    ``default_um`` / ``default_arcsec`` for the rest.

    Parameters
    ----------
    path : str or Path
        The TOML file.
    machine : Machine
        The machine whose components need tolerances.

    Returns
    -------
    dict of str to float
        SI magnitudes [m, rad] for every component of the machine.

    Raises
    ------
    SpecError
        Naming the file and the term when one is unknown, has no or the wrong unit, is given
        twice, is not a non-negative number or is beyond sense (:func:`tolerance_key`), or is
        missing.
    """
    path = Path(path)
    data = read_toml(path)
    defaults: dict[str, float] = {}
    values: dict[str, float] = {}
    seen: dict[tuple[str, str], str] = {}
    for key, value in data.items():
        stem, quantity, si = tolerance_key(key, value, machine, seen, path)
        (defaults if stem == "default" else values)[quantity if stem == "default" else stem] = si
    missing = []
    for name in machine.components:
        if name not in values:
            quantity = "length" if parse_component_name(name)[0] in "XYZ" else "angle"
            if quantity in defaults:
                values[name] = defaults[quantity]
            else:
                missing.append(name)
    if missing:
        raise SpecError(f"{path}: no tolerance for {', '.join(missing)} (give them, or "
                        "default_um / default_arcsec)")
    return values


def rank(machine: Machine, q: np.ndarray | None = None, *, points: int = 2048, seed: int = 0,
         tolerances: dict[str, float] | None = None, direction: str = "all",
         by: str = "component") -> Ranking:
    """Rank the error sources of ``machine`` by the tool-point error they cause.

    Parameters
    ----------
    machine : Machine
        The machine (its current errors: the sensitivities are exact there).
    q : ndarray, shape (N, n_axes), optional
        Workspace points (SI: m, rad); default: ``points`` scrambled Sobol' points over the
        travels.
    points : int, default 2048
        Number of sampled points when ``q`` is not given.
    seed : int, default 0
        Seed of the sampling.
    tolerances : dict, optional
        Component name -> expected magnitude (SI: m or rad). Then each term's contribution is
        its sensitivity times its tolerance and ``share`` is its share of the variance of the
        tool-point error (independent terms). Default: the spec's current values. With
        ``by="parameter"`` every coefficient of a component takes the component's tolerance.
    direction : "x", "y", "z" or "all"
        Which component(s) of the tool-point error to measure.
    by : "component" or "parameter"
        Rank component errors (EXX) or single coefficients (EXX.c2).

    Returns
    -------
    Ranking
        Each row has ``parameter``, ``term``, ``axis``, ``max_um``, ``rms_um`` (the term's
        contribution at the tool) [um], ``share`` (mean-square share), ``per_unit_max``,
        ``per_unit_rms`` and ``per_unit`` (um per um or um per arcsec),
        ``contribution_degree`` (seed 004: the term's per-unit RMS over the sum within its
        axis and kind, translational or angular; None with ``by="parameter"``),
        ``orientation_max_arcsec`` [arcsec] and ``orientation_share``.

    Raises
    ------
    InputError
        If ``direction`` or ``by`` is not one of the values above, ``q`` is invalid or holds no
        points, ``points`` is not a whole number >= 1 or ``seed`` one >= 0, the ranking would
        not fit in the free memory, or ``tolerances`` misses a component or gives one a
        value that is not a non-negative finite number.
    """
    if direction not in DIRECTIONS:
        raise InputError(f"direction must be one of x, y, z, all; got {direction!r}", parameters=("direction",))
    if by not in ("component", "parameter"):
        raise InputError(f"by must be 'component' or 'parameter'; got {by!r}", parameters=("by",))
    if tolerances is not None:
        _check_tolerances(machine, tolerances)
    q = _points(machine, q, points, seed, 8 * 6 * 4 * (len(machine.parameter_names) + len(machine.components)),
                "a ranking")
    rows_dir = DIRECTIONS[direction]
    model, theta, cov = machine.model, machine.theta, _covariates(machine, q)
    if by == "component":
        sens = component_sensitivity(model, q, theta, cov)   # (N, 6, C) per SI unit
        names = list(machine.components)
        if tolerances is None:
            size = component_values(model, q, theta, cov)    # (N, C) current values
        else:
            size = np.tile([tolerances[n] for n in names], (len(q), 1))
        terms = names
    else:
        sens = sensitivity(model, q, theta, cov)             # (N, 6, P)
        names = list(machine.parameter_names)
        terms = [n.split(".", 1)[0] for n in names]
        if tolerances is None:
            size = np.tile(machine.theta, (len(q), 1))
        else:
            size = np.tile([tolerances[t] for t in terms], (len(q), 1))
    angular = np.array([parse_component_name(t)[0] in "ABC" for t in terms])
    unit_factor = np.where(angular, ARCSEC, UM)  # SI per um or per arcsec
    pos = sens[:, rows_dir, :]                           # (N, d, T)
    per_unit = np.linalg.norm(pos, axis=1) * unit_factor * UM_PER_M  # um per (um | arcsec)
    contribution = np.linalg.norm(pos * size[:, None, :], axis=1) * UM_PER_M
    orient = np.linalg.norm(sens[:, 3:, :] * size[:, None, :], axis=1) * ARCSEC_PER_RAD
    ms = np.mean(contribution**2, axis=0)
    ms_orient = np.mean(orient**2, axis=0)
    owners = {c: parse_component_name(c)[2] for c in set(terms)}
    per_unit_rms = np.sqrt(np.mean(per_unit**2, axis=0))
    # second-order leftovers (products of two error angles) are not an influence
    effective = np.where(per_unit_rms > 1e-9 * max(per_unit_rms.max(), 1e-300), per_unit_rms, 0.0)
    degree = np.full(len(names), np.nan)
    if by == "component":
        for i, t in enumerate(terms):
            group = [j for j, u in enumerate(terms)
                     if owners[u] == owners[t] and angular[j] == angular[i]
                     and parse_component_name(u)[1] == parse_component_name(t)[1]]
            total = effective[group].sum()
            degree[i] = effective[i] / total if total > 0 else 0.0
    rows = []
    for i in np.argsort(-ms, kind="stable"):
        rows.append({
            "parameter": names[i],
            "term": terms[i],
            "axis": owners[terms[i]],
            "max_um": float(contribution[:, i].max()),
            "rms_um": float(np.sqrt(ms[i])),
            "ms": float(ms[i]),
            "per_unit_max": float(per_unit[:, i].max()),
            "per_unit_rms": float(per_unit_rms[i]),
            "per_unit": "um/arcsec" if angular[i] else "um/um",
            "contribution_degree": None if np.isnan(degree[i]) else float(degree[i]),
            "orientation_max_arcsec": float(orient[:, i].max()),
            "orientation_share": float(ms_orient[i] / ms_orient.sum()) if ms_orient.sum() > 0 else 0.0,
        })
    return Ranking(machine.name, int(len(q)), direction, by,
                   "tolerances" if tolerances is not None else "current values", rows)


def _points(machine: Machine, q, points, seed, point_bytes: int, what: str) -> np.ndarray:
    """The workspace points of a study: ``q`` checked, or ``points`` Sobol' points, sized
    (``point_bytes`` per point) before anything is allocated."""
    if q is None:
        points = integer("points", points, 1)
        seed = integer("seed", seed, 0)
        require_memory(points * (point_bytes + 8 * 4 * len(machine.axes)), f"{what} over {points:,} workspace samples",
                       ("points",))
        q = sample(machine, points, seed=seed)
    q = check_q(machine.model, q)
    if len(q) == 0:
        raise InputError("q holds no points", parameters=("q",))
    require_memory(len(q) * point_bytes, f"{what} over the {len(q):,} positions given")
    return q


def _covariates(machine: Machine, q: np.ndarray):
    """The covariates of the points ``q`` (checked) in the machine's state."""
    return check_covariates(machine.model, len(q), None, machine.state)


def _check_tolerances(machine: Machine, tolerances: dict) -> None:
    missing = [c for c in machine.components if c not in tolerances]
    if missing:
        raise InputError(f"tolerances: no value for {', '.join(missing)} (every component of {machine.name} needs "
                         "one)", parameters=("tolerances",))
    for name in machine.components:
        value = tolerances[name]
        try:
            ok = math.isfinite(float(value)) and float(value) >= 0
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise InputError(f"tolerances: {name} = {value!r} is not a non-negative finite number [m or rad]",
                             parameters=("tolerances",))


def tool_identifiability(machine: Machine, q: np.ndarray | None = None, *, points: int = 2048,
                         seed: int = 0, orientation: bool = False, rtol: float = 1e-9
                         ) -> list[IdentifiabilityGroup]:
    """Coefficients whose effect at the tool cannot be told apart.

    Those whose effect on the tool point (and orientation, if asked) is zero, exactly
    collinear with another's, or a linear combination of others, over the sampled
    workspace (see :func:`volerr_pin.fit.analyse` for the tests and tolerances).

    Parameters
    ----------
    machine : Machine
        The machine.
    q : ndarray, shape (N, n_axes), optional
        Workspace points [m, rad]; default ``points`` scrambled Sobol' points.
    points : int, default 2048
        Number of sampled points when ``q`` is not given.
    seed : int, default 0
        Seed of the sampling.
    orientation : bool, default False
        Also use the rotation rows (rx, ry, rz) of the sensitivity.
    rtol : float, default 1e-9
        Relative tolerance of the tests (see :func:`~volerr_pin.fit.analyse`).

    Returns
    -------
    list of IdentifiabilityGroup
        The zero, collinear and combination groups.

    Raises
    ------
    InputError
        If ``q`` is invalid or holds no points, ``points`` is not a whole number >= 1 or
        ``seed`` one >= 0, ``rtol`` is not between 0 and 1, or the analysis would not fit in
        the free memory.
    """
    rtol = positive("rtol", rtol)
    if rtol >= 1:
        raise InputError(f"rtol must be below 1, got {rtol}", parameters=("rtol",))
    # the sensitivities and the analysis' three copies of their rows
    rows = 6 if orientation else 3
    q = _points(machine, q, points, seed, 8 * len(machine.parameter_names) * (6 + 3 * rows) + 400,
                "an identifiability analysis")
    S = sensitivity(machine.model, q, machine.theta, _covariates(machine, q))
    rows = slice(0, 6) if orientation else slice(0, 3)
    A = S[:, rows, :].reshape(-1, S.shape[2])
    what = "the tool point and orientation" if orientation else "the tool point"
    return list(analyse(A, machine.parameter_names, rtol=rtol,
                        what=f"{what} anywhere in the sampled workspace").groups)
