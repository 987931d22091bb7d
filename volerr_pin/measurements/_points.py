"""Point measurements: the tool's deviation from its commanded pose, point by point.

Columns ``x,y,z[,a,b,c],dx,dy,dz[,rx,ry,rz]`` plus optional covariates
``t,T_<sensor>...,Fx,Fy,Fz,dir_<axis>...``; positions in mm / deg (commanded NC positions, one
column per machine axis, lower-case axis names), deviations in um and urad (measured tool
point minus commanded, relative to the workpiece), ``t`` in s, ``T_*`` in degC, ``F*`` in N,
``dir_*`` +1/-1. Columns may carry their unit (``x_mm``, ``dx_um``, ``rx_urad``); an empty
deviation cell means "not measured". Each measured deviation is one observation of the
error's component.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..base import InputError
from ._columns import DEVIATION_UNITS, DEVIATIONS, header_columns, positions_and_covariates
from ._protocol import Measurement, MeasurementKind, ObservationBlock, ObservationOptions
from ._table import MeasurementError, Table, read_table

__all__ = ["KIND", "PointMeasurements", "read_points"]


@dataclass(frozen=True)
class PointMeasurements(Measurement):
    """Point measurements in SI.

    ``q`` (N, n_axes) commanded positions [m, rad]; ``values`` (N, 6) deviations dx, dy, dz [m],
    rx, ry, rz [rad] with NaN where not measured; ``covariates`` keyword arrays for the
    model; ``lines`` the file line of each row; ``unused`` columns present but not used.

    Attributes
    ----------
    source : str
        The file (or a label for simulated data).
    q : ndarray, shape (N, n_axes)
        Commanded NC positions [m, rad].
    values : ndarray, shape (N, 6)
        Deviations dx, dy, dz [m], rx, ry, rz [rad]; NaN where not measured.
    covariates : dict
        Keyword covariates for :meth:`Machine.volumetric_error`: ``t`` (N,) [s],
        ``temperatures`` {sensor: (N,)} [degC], ``forces`` (N, 3) [N], ``directions``
        (N, n_axes) of +1/-1; only those present.
    lines : ndarray of int, shape (N,)
        File line of each row.
    unused : tuple of str
        Columns present but not used.

    Notes
    -----
    The methods of :class:`~volerr_pin.measurements.Measurement` (documented there) do here:

    - ``observations``: one row per measured deviation, in point order; no nuisance term.
    """

    source: str
    q: np.ndarray
    values: np.ndarray
    covariates: dict
    lines: np.ndarray
    unused: tuple[str, ...] = ()

    @property
    def measured(self) -> np.ndarray:
        """Where a deviation was measured: ndarray of bool, shape (N, 6)."""
        return ~np.isnan(self.values)


    def observations(self, machine, options: ObservationOptions) -> ObservationBlock:
        values = np.asarray(self.values, dtype=float)
        if values.ndim != 2 or values.shape != (len(self.q), 6):
            raise InputError(f"{self.source}: values has shape {values.shape}; expected ({len(self.q)}, 6): "
                             "dx, dy, dz, rx, ry, rz of every point")
        i, k = np.nonzero(~np.isnan(values))
        return ObservationBlock(self.source, self.q, self.covariates, i, np.eye(6)[k], values[i, k],
                                np.where(k >= 3, options.sigma_urad, options.sigma_um) * 1e-6, k >= 3,
                                np.asarray(self.lines)[i], np.zeros((len(i), 0)))


def read_points(path: str | Path | Table, machine) -> PointMeasurements:
    """Read a point-measurement file for ``machine`` (positions checked against its travel).

    See the module docstring for the columns and their units.

    Parameters
    ----------
    path : str, Path or Table
        The file, or a table read already.
    machine : Machine
        The machine (its axes name the position columns).

    Returns
    -------
    PointMeasurements
        The measurements in SI.

    Raises
    ------
    MeasurementError
        If the table is malformed, a column's unit is not the file unit or a column is given
        twice under two spellings, a position column is missing or outside the travel, a
        covariate column is invalid, there is no deviation column, a row has no measured
        deviation, or a value lies beyond its plausibility limit (docs/measurements.md).
    """
    table = read_table(path)
    columns = header_columns(table, machine)
    q, covariates, used = positions_and_covariates(table, columns, machine)
    values = np.full((len(table.rows), 6), np.nan)
    present = [k for k, name in enumerate(DEVIATIONS) if name in columns]
    if not present:
        raise MeasurementError(f"{table.path}:{table.header_line}: no deviation column "
                               "(dx, dy, dz [um] or rx, ry, rz [urad])")
    for k in present:
        col = columns[DEVIATIONS[k]]
        used.add(col)
        limit = "error_length" if k < 3 else "error_angle"
        values[:, k] = table.column(col, allow_empty=True, limit=limit, unit=DEVIATION_UNITS[DEVIATIONS[k]],
                                    unit_scale=1e-6) * 1e-6  # um and urad
    empty = np.flatnonzero(np.all(np.isnan(values), axis=1))
    if empty.size:
        raise MeasurementError(f"{table.path}:{table.lines[empty[0]]}: row has no measured deviation")
    unused = tuple(table.header[c] for c in range(len(table.header)) if c not in used)
    return PointMeasurements(table.path, q, values, covariates, np.array(table.lines), unused)



#: point measurements: the catch-all kind, whatever no other kind recognises (registered last)
KIND = MeasurementKind("points", "point measurements", True, recognises=lambda header: True,
                       read=lambda table, machine=None, axis=None: read_points(table, machine))
