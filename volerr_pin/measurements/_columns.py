"""Columns that several kinds of point-wise measurement share: the commanded positions (one
column per machine axis, mm / deg, checked against the travel), the covariates (``t`` [s],
``T_<sensor>`` [degC], ``Fx, Fy, Fz`` [N], ``dir_<axis>`` +1/-1) and the units a column name
may carry (``x_mm``, ``dx_um``, ``rx_urad``, ``tx_mm``).
"""

from __future__ import annotations

import numpy as np

from ..base import AXIS_UNIT, PLAUSIBLE, TEMPERATURE, TEMPERATURE_LIKE, axis_scale, split_key
from ._table import MeasurementError, Table

__all__ = ["DEVIATIONS", "DEVIATION_UNITS", "header_columns", "positions_and_covariates", "temperature_column"]

#: deviation columns of point measurements, in the order of the error's six components
DEVIATIONS = ("dx", "dy", "dz", "rx", "ry", "rz")
DEVIATION_UNITS = {"dx": "um", "dy": "um", "dz": "um", "rx": "urad", "ry": "urad", "rz": "urad"}


def header_columns(table: Table, machine) -> dict[str, int]:
    """Column stem -> index, with the units in the names checked against the file units.

    Parameters
    ----------
    table : Table
        The table.
    machine : Machine
        The machine (its axes name the position columns and their units).

    Returns
    -------
    dict of str to int
        Column name without its unit suffix -> column index (0-based).

    Raises
    ------
    MeasurementError
        If a column carries a unit other than the file unit of that column (mm / deg for
        positions, um / urad for deviations, s, degC, N, mm for tracker coordinates), or one
        column is given twice under two spellings (``dx`` and ``dx_um``).
    """
    columns: dict[str, int] = {}
    for col, name in enumerate(table.header):
        stem, unit = temperature_column(table, col) if name.startswith("T_") else (None, None)
        if stem is None:
            stem, unit = split_key(name, ("length", "angle", "time", "temperature", "force"))
        if stem in columns:
            first = table.header[columns[stem]]
            raise MeasurementError(f"{table.path}:{table.header_line}:{col + 1}: columns '{first}' "
                                   f"(column {columns[stem] + 1}) and '{name}' are both {stem}; keep one")
        columns[stem] = col
        expected = _expected_unit(stem, machine)
        if unit is not None and expected is not None and unit != expected and not (
                expected == "degC" and unit in TEMPERATURE):
            raise MeasurementError(f"{table.path}:{table.header_line}:{col + 1}: column '{name}': "
                                   f"unit '{unit}' is not the file unit '{expected}' of {stem}")
    return columns


def positions_and_covariates(table: Table, columns: dict[str, int], machine) -> tuple[np.ndarray, dict, set]:
    """NC positions (SI, checked against the travel), covariates, and the columns used.

    Parameters
    ----------
    table : Table
        The table.
    columns : dict of str to int
        Column stem -> index, from :func:`header_columns`.
    machine : Machine
        The machine.

    Returns
    -------
    q : ndarray, shape (n_rows, n_axes)
        NC positions [m, rad] (the file gives mm / deg).
    covariates : dict
        ``t`` [s], ``temperatures`` {sensor: values} [degC], ``forces`` (n_rows, 3) [N] and
        ``directions`` (n_rows, n_axes) of +1/-1 (+1 for axes without a column), those the
        file gives.
    used : set of int
        Indices of the columns read.

    Raises
    ------
    MeasurementError
        If a position column is missing or leaves the travel, a value is not a finite number
        or lies beyond its plausibility limit, only some of Fx, Fy, Fz are given, or a
        direction is not +1 or -1.
    """
    used = set()
    q = np.empty((len(table.rows), len(machine.axes)))
    for j, (axis, kind) in enumerate(zip(machine.axes, machine.axis_kinds)):
        key = axis.lower()
        if key not in columns:
            raise MeasurementError(f"{table.path}:{table.header_line}: missing position column "
                                   f"'{key}' for axis {axis} ({AXIS_UNIT[kind]})")
        col = columns[key]
        used.add(col)
        factor = axis_scale(kind)
        q[:, j] = table.column(col, limit=f"position_{'length' if kind == 'linear' else 'angle'}",
                               unit=AXIS_UNIT[kind], unit_scale=factor) * factor
        lo, hi = machine.travel[j]
        bad = np.flatnonzero((q[:, j] < lo - 1e-9 * max(1.0, hi - lo)) | (q[:, j] > hi + 1e-9 * max(1.0, hi - lo)))
        if bad.size:
            shown, unit = 1.0 / factor, AXIS_UNIT[kind]
            raise MeasurementError(f"{table.where(bad[0], col)}: {key} = {q[bad[0], j] * shown:g} {unit} is "
                                   f"outside the travel of {axis} [{lo * shown:g}, {hi * shown:g}] {unit}")
    covariates: dict = {}
    if "t" in columns:
        covariates["t"] = table.column(columns["t"], limit="time", unit="s")
        used.add(columns["t"])
    temps = {}
    for name, col in columns.items():
        if name.startswith("T_") and len(name) > 2:
            unit = temperature_column(table, col)[1] or "degC"
            if unit == "degC":
                values = table.column(col, limit="temperature", unit="degC")
            else:   # converted to degC first; the refusal shows the value in both units
                scale, offset = TEMPERATURE[unit]
                raw = table.column(col)
                values = raw * scale + offset
                low, high = PLAUSIBLE["temperature"]
                bad = np.flatnonzero((values < low) | (values > high))
                if bad.size:
                    r = int(bad[0])
                    raise MeasurementError(f"{table.where(r, col)}: column '{table.header[col]}': {raw[r]:g} {unit} "
                                           f"= {values[r]:g} degC is implausible: a temperature lies within "
                                           f"{low:g} .. {high:g} degC (docs/measurements.md)")
            temps[name[2:]] = values
            used.add(col)
    if temps:
        covariates["temperatures"] = temps
    force_cols = [columns.get(f"F{c}") for c in "xyz"]
    if any(c is not None for c in force_cols):
        missing = [f"F{c}" for c, col in zip("xyz", force_cols) if col is None]
        if missing:
            raise MeasurementError(f"{table.path}:{table.header_line}: force columns need all of "
                                   f"Fx, Fy, Fz (missing {', '.join(missing)})")
        covariates["forces"] = np.column_stack([table.column(c, limit="force", unit="N") for c in force_cols])
        used.update(force_cols)
    dir_cols = [columns.get(f"dir_{a.lower()}") for a in machine.axes]
    if any(c is not None for c in dir_cols):
        directions = np.ones((len(table.rows), len(machine.axes)))
        for j, col in enumerate(dir_cols):
            if col is None:
                continue
            used.add(col)
            directions[:, j] = table.column(col)
            bad = np.flatnonzero(~np.isin(directions[:, j], (-1.0, 1.0)))
            if bad.size:
                raise MeasurementError(f"{table.where(bad[0], col)}: column '{table.header[col]}': "
                                       f"direction must be +1 or -1, got {table.rows[bad[0]][col].strip()}")
        covariates["directions"] = directions
    return q, covariates, used


def temperature_column(table: Table, col: int) -> tuple[str | None, str | None]:
    """The sensor column and temperature unit a ``T_`` column names.

    ``T_spindle`` is in degC; ``T_spindle_degC``, ``T_spindle_K`` and ``T_spindle_degF`` name
    their unit (the values are converted to degC as they are read).

    Parameters
    ----------
    table : Table
        The table.
    col : int
        Index of a column whose name starts with ``T_``.

    Returns
    -------
    (str or None, str or None)
        The column's stem (``T_spindle``) and its unit (None when the name gives none);
        ``(None, None)`` when the name ends in another quantity's unit (``T_spindle_mm``),
        which :func:`header_columns` refuses as the wrong unit.

    Raises
    ------
    MeasurementError
        If the name ends in something that reads like a temperature unit but is none of
        degC, K and degF (``T_spindle_F``, ``T_spindle_kelvin``, ``T_spindle_degc``): it would
        otherwise be read as a sensor of that name, in degC.
    """
    name = table.header[col]
    stem, sep, suffix = name.rpartition("_")
    if sep and stem.startswith("T_") and len(stem) > 2:
        if suffix in TEMPERATURE:
            return stem, suffix
        if suffix.lower() in TEMPERATURE_LIKE:
            raise MeasurementError(
                f"{table.path}:{table.header_line}:{col + 1}: column '{name}': unit '{suffix}' is not "
                f"one the reader knows; a temperature column names degC, K or degF "
                f"({stem}_degC, {stem}_K, {stem}_degF), or none for degC")
        if split_key(name, ("length", "angle", "time", "force"))[1] is not None:
            return None, None
    return name, None


def _expected_unit(stem: str, machine) -> str | None:
    if stem in DEVIATION_UNITS:
        return DEVIATION_UNITS[stem]
    for axis, kind in zip(machine.axes, machine.axis_kinds):
        if stem == axis.lower():
            return AXIS_UNIT[kind]
    if stem == "t":
        return "s"
    if stem.startswith("T_"):
        return "degC"
    if stem in ("Fx", "Fy", "Fz"):
        return "N"
    if stem in ("tx", "ty", "tz", "ox", "oy", "oz"):  # tracker coordinates, target offsets
        return "mm"
    return None

