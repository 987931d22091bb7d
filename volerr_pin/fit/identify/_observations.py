"""Observations: the measurements of a fit as weighted rows ``y ~ w . e(q_point) + nuisance``.

Each measurement turns itself into a block of rows (see
:class:`~volerr_pin.measurements.Measurement`); :func:`build_observations` stacks the
blocks, merges the covariates the files give, and keeps the poses the points are held out by.
:func:`check_observations` refuses observations a fit cannot use. Residual RMS values are over
points: the norm of each point's position (or rotation) residual.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass

import numpy as np

from ...base import UM_PER_M, URAD_PER_RAD, InputError, measurement_sigma
from ...model import Machine, TemperatureHistory
from ...measurements import Measurement, ObservationBlock, ObservationOptions, read_any

__all__ = ["WEIGHTED_LIMIT", "Observations", "build_observations", "check_observations", "data_names", "point_squares",
           "residual_rms", "stack_blocks", "take_covariates"]

#: largest observation a fit takes, in standard deviations: far beyond any measurement (1e94 m
#: at 1 um), and far enough below overflow (1e154) that the sums of squares of residuals and
#: trial residuals stay finite
WEIGHTED_LIMIT = 1e100


@dataclass
class Observations:
    """Weighted observations of a machine's error, ready for the solver (SI).

    ``q`` and ``covariates`` per point; one row per observation with its point ``point``,
    6-vector ``w`` (prediction ``w . e(q_point)``), value ``y``, standard deviation ``sigma``,
    ``angular`` flag, and the nuisance design ``nuisance`` with names ``nuisance_names``;
    ``sources`` and ``lines`` say where each row came from.

    Attributes
    ----------
    q : ndarray, shape (N, n_axes)
        NC positions of the points [m, rad].
    covariates : dict
        Keyword covariates of the points for :meth:`Machine.volumetric_error` (``t`` (N,) [s],
        ``temperatures`` {sensor: (N,)} [degC], ``forces`` (N, 3) [N], ``directions`` (N, n_axes)).
    point : ndarray of int, shape (rows,)
        The point each observation row belongs to.
    w : ndarray, shape (rows, 6)
        Weights of the error components dx, dy, dz, rx, ry, rz in each observation.
    y : ndarray, shape (rows,)
        Observed values [m or rad].
    sigma : ndarray, shape (rows,)
        Standard deviations of the observations [m or rad].
    angular : ndarray of bool, shape (rows,)
        True for rotation observations (rad), False for position ones (m).
    nuisance : ndarray, shape (rows, n_nuisance)
        Design of the nuisance terms (instrument zero, alignment slope, tracker placement,
        ballbar set-up).
    nuisance_names : list of str
        Names of the nuisance columns (e.g. ``offset[positioning run FILE]``).
    sources : list of str
        File of each row.
    lines : ndarray, shape (rows,)
        File line (or sample index) of each row.
    nuisance_angular : ndarray of bool, shape (n_nuisance,), optional
        True for nuisance terms in rad (reported in urad). Default: a term is angular when a
        row it acts on is.
    pose : ndarray of int, shape (N,), optional
        The pose of every point (the points of one pose are held out together). Default:
        points at the same positions (to 1e-12) are one pose.
    """

    q: np.ndarray
    covariates: dict
    point: np.ndarray
    w: np.ndarray
    y: np.ndarray
    sigma: np.ndarray
    angular: np.ndarray
    nuisance: np.ndarray
    nuisance_names: list[str]
    sources: list[str]
    lines: np.ndarray
    nuisance_angular: np.ndarray | None = None
    pose: np.ndarray | None = None

    def __post_init__(self):
        if self.nuisance_angular is None:
            self.nuisance_angular = np.array([bool(np.any(self.angular[self.nuisance[:, c] != 0]))
                                              for c in range(np.shape(self.nuisance)[1])], dtype=bool)

    @property
    def n_points(self) -> int:
        """Number of points (rows of ``q``), int."""
        return len(self.q)

    def subset(self, points: np.ndarray) -> "Observations":
        """The observations of the given points (nuisance columns kept).

        Parameters
        ----------
        points : ndarray of int, shape (M,)
            Indices of the points to keep, in the order the new points take.

        Returns
        -------
        Observations
            The rows of those points, with ``point`` renumbered to 0..M-1.
        """
        keep = np.isin(self.point, points)
        remap = -np.ones(self.n_points, dtype=int)
        remap[points] = np.arange(len(points))
        cov = take_covariates(self.covariates, points)
        return Observations(self.q[points], cov, remap[self.point[keep]], self.w[keep], self.y[keep],
                            self.sigma[keep], self.angular[keep], self.nuisance[keep],
                            self.nuisance_names, [s for s, k in zip(self.sources, keep) if k],
                            self.lines[keep], self.nuisance_angular, None if self.pose is None else self.pose[points])

    def poses(self) -> np.ndarray:
        """The pose of every point, numbered from 0 (see :attr:`pose`).

        Returns
        -------
        ndarray of int, shape (N,)
            :attr:`pose` when given, else the index of each point's positions (rounded to
            1e-12) among the distinct positions, in sorted order.
        """
        if self.pose is not None:
            return np.asarray(self.pose)
        _, group = np.unique(np.round(self.q, 12), axis=0, return_inverse=True)
        return group.ravel()


def take_covariates(cov: dict, idx) -> dict:
    """The covariates of some points.

    Parameters
    ----------
    cov : dict
        Keyword covariates of all points (``temperatures`` a dict of arrays).
    idx : index
        The points: an index array, a boolean mask or a slice.

    Returns
    -------
    dict
        The same keys, each array indexed by ``idx``.
    """
    out = {}
    for key, value in cov.items():
        if key == "history":
            out[key] = value   # the whole record: lagged temperatures read it, not only these points
        else:
            out[key] = {k: v[idx] for k, v in value.items()} if isinstance(value, dict) else value[idx]
    return out


def build_observations(machine: Machine, data, *, sigma_um: float = 1.0, sigma_urad: float = 1.0,
                       run_axis: str | None = None, at: dict[str, float] | None = None) -> Observations:
    """Turn measurements into observations: each measurement gives its own block (see
    :class:`~volerr_pin.measurements.Measurement`), stacked here.

    Point measurements observe each measured deviation direction. Runs: the moving axis is
    the run's (or ``run_axis``); the other axes stand at the run's ``# at:`` positions,
    ``at`` (m / rad), or mid travel (rotary axes at 0). A positioning run observes the
    error along the axis' own motion; a component run the component's direction. Every run
    file gets an offset (the instrument zero); straightness runs also a slope (the reference
    line's alignment). A tracker file gets six nuisance terms (a small translation and
    rotation of the tracker), a ballbar file three (the set-up's centre offset along both
    plane axes and the bar's length error).

    Parameters
    ----------
    machine : Machine
        The machine observed.
    data : iterable of measurements or files, or one of them
        Objects following :class:`~volerr_pin.measurements.Measurement`:
        :class:`~volerr_pin.measurements.PointMeasurements`,
        :class:`~volerr_pin.measurements.Runs`,
        :class:`~volerr_pin.measurements.TrackerMeasurements`,
        :class:`~volerr_pin.measurements.BallbarRun`, or a registered kind's; or the
        paths of their files (str or path-like), read with
        :func:`~volerr_pin.measurements.read_any` (a run file's axis from ``run_axis``;
        columns a file gives and nothing uses are warned about).
    sigma_um : float, default 1.0
        Standard deviation of position observations [um].
    sigma_urad : float, default 1.0
        Standard deviation of rotation observations [urad].
    run_axis : str, optional
        Moving axis of runs that do not name it.
    at : dict of str to float, optional
        Positions of the other axes during runs [m, rad]; overrides the files' ``# at:``.

    Returns
    -------
    Observations
        The stacked observations; covariates given by some files only are merged (see the
        warnings and errors below).

    Raises
    ------
    InputError
        If ``sigma_um`` or ``sigma_urad`` is not positive and finite, ``at`` names an axis the
        machine does not have or a value that is not finite, a run's axis is unknown
        or not given, its target unit does not fit the axis kind, its positions leave the
        travel, a component run belongs to another axis, an object is not a measurement,
        there are no observations, or a covariate the model reads is missing from some files.
    MeasurementError
        If a file is malformed (naming it, its line and column).

    Warns
    -----
    UserWarning
        For a file with columns that nothing uses, naming them.
    """
    sigma_um = measurement_sigma("sigma_um", sigma_um)
    sigma_urad = measurement_sigma("sigma_urad", sigma_urad)
    options = ObservationOptions(sigma_um, sigma_urad, run_axis, _positions(machine, at))
    if isinstance(data, (Measurement, str, os.PathLike)):
        data = [data]  # one measurement object or file
    blocks = []
    for item in data:
        if isinstance(item, (str, os.PathLike)):
            item = read_any(item, machine, run_axis)
            if item.unused:
                warnings.warn(f"{item.source}: columns not used: {', '.join(item.unused)}", stacklevel=2)
        if not isinstance(item, Measurement):
            raise InputError(f"cannot use {type(item).__name__} as measurements: give measurement objects or "
                             "the paths of their files")
        blocks.append(item.observations(machine, options))
    return stack_blocks(blocks, machine)


def _positions(machine: Machine, at) -> dict[str, float] | None:
    """The other axes' positions during runs [m, rad], ``at`` as given, checked."""
    if at is None:
        return None
    out = {}
    for name, value in dict(at).items():
        if name not in machine.axes:
            raise InputError(f"at names '{name}', not an axis of {machine.name} ({', '.join(machine.axes)})",
                             parameters=("at",))
        value = float(value)
        if not np.isfinite(value):
            raise InputError(f"at: {name} = {value} is not a finite position", parameters=("at",))
        out[name] = value
    return out


def stack_blocks(blocks: list[ObservationBlock], machine: Machine) -> Observations:
    """The observations of several measurements as one set: points, rows and nuisance columns
    in the order of the blocks.

    Parameters
    ----------
    blocks : list of ObservationBlock
        The measurements' observations.
    machine : Machine
        The machine observed (which covariates it reads).

    Returns
    -------
    Observations
        The stacked observations. Poses: the points of a block that gives its ``poses`` keep
        them; all other points at the same commanded positions (to 1e-12) are one pose.

    Raises
    ------
    InputError
        If there are no observation rows, or a covariate the model reads is missing from some
        blocks.
    """
    if not sum(len(b.point) for b in blocks):
        raise InputError("no observations")
    sizes = [len(b.q) for b in blocks]
    q = np.vstack([b.q for b in blocks])
    covariates = _merge_covariates([b.covariates for b in blocks], sizes, machine)
    starts = np.cumsum([0] + sizes)
    rows = np.cumsum([0] + [len(b.point) for b in blocks])
    cols = np.cumsum([0] + [len(b.nuisance_terms) for b in blocks])
    nuisance = np.zeros((int(rows[-1]), int(cols[-1])))
    for k, b in enumerate(blocks):
        nuisance[rows[k]:rows[k + 1], cols[k]:cols[k + 1]] = b.nuisance
    terms = [t for b in blocks for t in b.nuisance_terms]
    return Observations(
        q, covariates, np.concatenate([b.point + start for b, start in zip(blocks, starts)]).astype(int),
        np.vstack([b.w for b in blocks]).astype(float), np.concatenate([b.y for b in blocks]).astype(float),
        np.concatenate([b.sigma for b in blocks]).astype(float),
        np.concatenate([b.angular for b in blocks]).astype(bool), nuisance, [t.name for t in terms],
        [src for b in blocks for src in [b.source] * len(b.point)],
        np.concatenate([b.lines for b in blocks]), np.array([t.angular for t in terms], dtype=bool),
        _stacked_poses(blocks, q, starts))


def _stacked_poses(blocks: list[ObservationBlock], q: np.ndarray, starts: np.ndarray) -> np.ndarray | None:
    """Pose labels over all points; None when no block gives its own (poses are then found by
    position when asked for, :meth:`Observations.poses`)."""
    if all(b.poses is None for b in blocks):
        return None
    pose = np.empty(len(q), dtype=int)
    by_position = np.concatenate([np.arange(starts[k], starts[k + 1]) for k, b in enumerate(blocks)
                                  if b.poses is None] or [np.zeros(0, int)])
    count = 0
    if by_position.size:
        _, group = np.unique(np.round(q[by_position], 12), axis=0, return_inverse=True)
        pose[by_position] = group.ravel()
        count = int(group.max()) + 1
    for k, b in enumerate(blocks):
        if b.poses is not None:
            _, labels = np.unique(np.asarray(b.poses), return_inverse=True)
            pose[starts[k]:starts[k + 1]] = labels.ravel() + count
            count += int(labels.max()) + 1 if labels.size else 0
    return pose


#: what the files call each covariate (the measurement files' columns, docs/measurements.md)
COLUMNS_OF = {"t": "the time column t is", "temperatures": "the temperature columns T_<sensor> are",
              "forces": "the force columns Fx, Fy, Fz are", "directions": "the direction columns dir_<axis> are",
              "series": "the series column is"}


def _merge_covariates(parts: list[dict], sizes: list[int], machine: Machine) -> dict:
    """Stack per-file covariates; a covariate the model reads must be in every file or in none
    (directions default to +1 where a file does not give them); one it does not read and only
    some files give is left out with a warning."""
    keys = dict.fromkeys(k for p in parts for k in p)  # first-seen order: notes come out the same every run
    merged: dict = {}
    for key in keys:
        if key == "directions":
            merged[key] = np.vstack([p.get(key, np.ones((n, len(machine.axes))))
                                     for p, n in zip(parts, sizes)])
            continue
        missing = [i for i, p in enumerate(parts) if key not in p]
        if missing:
            name = COLUMNS_OF.get(key, f"covariate '{key}' is")
            if key in machine.covariates_used:
                raise InputError(f"{name} in some measurement files but not in others "
                                 f"(missing from {len(missing)} of {len(parts)}); the model of "
                                 f"{machine.name} needs it at every point")
            warnings.warn(f"{name} in some measurement files but not in others; "
                          f"{machine.name}'s model does not read it, so it is not used", stacklevel=5)
            continue
        if key == "temperatures":
            sensors = set(parts[0][key])
            if any(set(p[key]) != sensors for p in parts):
                raise InputError("the measurement files name different temperature sensors")
            merged[key] = {s: np.concatenate([p[key][s] for p in parts]) for s in sensors}
        else:
            merged[key] = np.concatenate([p[key] for p in parts])
    if "t" in merged and len(parts) > 1 and "series" not in merged:
        # each file is its own time series (its clock may start at 0 again): a lag stays inside it
        merged["series"] = np.repeat(np.arange(len(parts), dtype=float), sizes)
    if "t" in merged and merged.get("temperatures"):
        # the whole record: a fold, a chunk or a half of the points reads lagged temperatures from it
        merged["history"] = TemperatureHistory(np.asarray(merged["t"], dtype=float),
                                               np.asarray(merged.get("series", np.zeros(sum(sizes))), dtype=float),
                                               {s: np.asarray(v, dtype=float)
                                                for s, v in merged["temperatures"].items()})
    return merged


def check_observations(obs: Observations) -> None:
    """Refuse observations a fit cannot use, naming the file and line of the first bad row.

    Parameters
    ----------
    obs : Observations
        The observations.

    Raises
    ------
    InputError
        If the arrays do not have one entry per row (or point indices leave the points, or
        the nuisance flags or poses do not have one per column or point), a
        value, weight or nuisance entry is not finite, a standard deviation is not
        positive and finite, a position is not finite, or an observation exceeds
        :data:`WEIGHTED_LIMIT` standard deviations (the fit's sums of squares would overflow).
    """
    rows = len(obs.y)
    shapes = {"point": np.shape(obs.point), "w": np.shape(obs.w), "sigma": np.shape(obs.sigma),
              "angular": np.shape(obs.angular), "nuisance": np.shape(obs.nuisance)[:1], "lines": np.shape(obs.lines)}
    expected = {"w": (rows, 6), "nuisance": (rows,)}
    for name, shape in shapes.items():
        if shape != expected.get(name, (rows,)):
            raise InputError(f"obs.{name} has shape {shape}; expected {expected.get(name, (rows,))} (one per row)",
                             parameters=("obs",))
    if len(obs.sources) != rows or np.shape(obs.nuisance)[1:] != (len(obs.nuisance_names),):
        raise InputError("obs.sources and obs.nuisance_names must name every row and nuisance column",
                         parameters=("obs",))
    if np.shape(obs.nuisance_angular) != (len(obs.nuisance_names),):
        raise InputError(f"obs.nuisance_angular has shape {np.shape(obs.nuisance_angular)}; expected "
                         f"({len(obs.nuisance_names)},) (one per nuisance column)", parameters=("obs",))
    if obs.pose is not None and (np.shape(obs.pose) != (obs.n_points,)
                                 or not np.issubdtype(np.asarray(obs.pose).dtype, np.integer)):
        raise InputError(f"obs.pose must hold one integer pose per point ({obs.n_points}), got shape "
                         f"{np.shape(obs.pose)}", parameters=("obs",))
    if rows and (obs.point.min() < 0 or obs.point.max() >= obs.n_points):
        raise InputError(f"obs.point refers to points outside 0 to {obs.n_points - 1}", parameters=("obs",))
    bad_q = np.argwhere(~np.isfinite(obs.q))
    if bad_q.size:
        i = int(bad_q[0][0])
        rows = np.flatnonzero(obs.point == i)
        where = f"{obs.sources[rows[0]]}:{obs.lines[rows[0]]}" if rows.size else f"point {i}"
        raise InputError(f"{where}: position {obs.q[i, bad_q[0][1]]} is not a finite number")
    checks = (("value", ~np.isfinite(obs.y)), ("standard deviation", ~(np.isfinite(obs.sigma) & (obs.sigma > 0))),
              ("weight", ~np.all(np.isfinite(obs.w), axis=1)),
              ("nuisance design", ~np.all(np.isfinite(obs.nuisance), axis=1)))
    for what, mask in checks:
        if mask.any():
            i = int(np.argmax(mask))
            raise InputError(f"{obs.sources[i]}:{obs.lines[i]}: observation {what} is not a "
                             f"{'positive ' if what == 'standard deviation' else ''}finite number")
    with np.errstate(over="ignore"):
        weighted = np.abs(obs.y / obs.sigma)
    if not weighted.max(initial=0.0) <= WEIGHTED_LIMIT:
        i = int(np.argmax(weighted))
        unit, factor = ("urad", URAD_PER_RAD) if obs.angular[i] else ("um", UM_PER_M)
        raise InputError(f"{obs.sources[i]}:{obs.lines[i]}: observation {obs.y[i] * factor:.6g} {unit} is too large "
                         f"to fit: {weighted[i]:.3g} times its standard deviation (the sums of squares a fit forms "
                         f"overflow double precision beyond {WEIGHTED_LIMIT:.0e})")


def data_names(obs: Observations) -> str:
    """The files of the observations, for messages: the first three, and how many more.

    Parameters
    ----------
    obs : Observations
        The observations.

    Returns
    -------
    str
        ``"a.csv, b.csv, c.csv and 2 more"``.
    """
    names = list(dict.fromkeys(obs.sources))
    return ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")


def point_squares(point: np.ndarray, residual: np.ndarray) -> np.ndarray:
    """Squared norm of the residual at each point that has rows.

    Parameters
    ----------
    point : ndarray of int, shape (rows,)
        The point each observation row belongs to (:attr:`Observations.point`).
    residual : ndarray, shape (rows,)
        Residual of each row (components of one point add up to its squared norm), in any
        unit.

    Returns
    -------
    ndarray, shape (points with rows,)
        Sum of the squared residuals of each point's rows, in the order of the points
        (unit of ``residual`` squared).
    """
    used, index = np.unique(point, return_inverse=True)
    return np.bincount(index, residual ** 2, minlength=used.size)


def residual_rms(obs: Observations, residual_si: np.ndarray, angular: bool = False) -> float | None:
    """RMS over points of the norm of the position (or rotation) residual.

    Parameters
    ----------
    obs : Observations
        The observations.
    residual_si : ndarray, shape (rows,)
        Residual of every row [m or rad].
    angular : bool, default False
        Use the rotation rows [urad] instead of the position rows [um].

    Returns
    -------
    float or None
        The RMS [um] (``angular``: [urad]); None without such rows.
    """
    rows = obs.angular == angular
    if not rows.any():
        return None
    rms = np.sqrt(point_squares(obs.point[rows], residual_si[rows]).mean())
    return float(rms * (URAD_PER_RAD if angular else UM_PER_M))
