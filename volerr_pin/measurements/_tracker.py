"""Laser-tracker measurements: absolute target coordinates in the tracker's own frame.

A tracker measures where its reflectors (targets) are, in its own frame - not the deviation
of the tool from its nominal pose. A file gives, per row, the NC positions, the target's
measured coordinates ``tx, ty, tz`` (mm, tracker frame), and optionally which target it was
(``target``) and where that target sits on the tool (``ox, oy, oz``, mm, in the tool frame;
0 when absent). Several targets per pose are several rows with the same positions:

.. code-block:: text

    x,y,z,target,ox,oy,oz,tx,ty,tz
    250,200,200,T1,0,0,0,2011.4472,-987.1180,512.0031
    250,200,200,T2,50,0,-20,2054.7561,-962.1099,491.9987

Covariate columns (``t``, ``T_<sensor>``, ``Fx..``, ``dir_<axis>``) are read as for point
measurements.

As observations (:meth:`TrackerMeasurements.observations`) the tracker's placement is a
nuisance: a first registration maps the nominal target positions onto the measured ones by
least squares (Kabsch); the measurements, brought into the workpiece frame with it, become
deviations of each target from its nominal position, and six nuisance terms per file - a
small translation and rotation of the tracker - refine the registration in the fit. A
target at offset ``o`` sees the tool's position error plus its rotation error times
``R_nominal o`` (first order: exact to ``|rotation error|^2 |o|``, 0.1 um for 1 mrad on
200 mm), so targets off the tool point also observe the tool's orientation. The linearised
registration is exact to ``|rotation left|^2 x distance``: the first registration takes
out all but the rigid part of the machine's own errors.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..base import InputError
from ..model import check_q, tool_poses
from ._columns import header_columns, positions_and_covariates
from ._protocol import Measurement, MeasurementKind, NuisanceTerm, ObservationBlock, ObservationOptions
from ._table import MeasurementError, Table, read_table

__all__ = ["KIND", "TrackerMeasurements", "is_tracker_file", "read_tracker", "register", "tracker_observations"]

COORDINATES = ("tx", "ty", "tz")
OFFSETS = ("ox", "oy", "oz")


@dataclass(frozen=True)
class TrackerMeasurements(Measurement):
    """Laser-tracker measurements of target coordinates, in SI.

    ``q`` (N, n_axes) SI; ``coordinates`` (N, 3) m in the tracker frame; ``offsets``
    (N, 3) m in the tool frame; ``targets`` (N,) names; covariates as for point data.

    Attributes
    ----------
    source : str
        The file (or a label for simulated data).
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    coordinates : ndarray, shape (N, 3)
        Measured target coordinates in the tracker frame [m].
    offsets : ndarray, shape (N, 3)
        Target offsets in the tool frame [m] (0 when the file gives none).
    targets : tuple of str
        Target name of each row ("" when the file gives none).
    covariates : dict
        Keyword covariates, as for :class:`~volerr_pin.measurements.PointMeasurements`.
    lines : ndarray of int, shape (N,)
        File line of each row.
    unused : tuple of str
        Columns present but not used.

    Notes
    -----
    The methods of :class:`~volerr_pin.measurements.Measurement` (documented there) do here:

    - ``observations``: three rows per target (its deviation from its nominal position along x,
      y, z, in the workpiece frame after the first registration) and six nuisance terms: the
      tracker's small translation and rotation (see :func:`tracker_observations`).
    """

    source: str
    q: np.ndarray
    coordinates: np.ndarray
    offsets: np.ndarray
    targets: tuple[str, ...]
    covariates: dict
    lines: np.ndarray
    unused: tuple[str, ...] = ()

    def observations(self, machine, options: ObservationOptions) -> ObservationBlock:
        obs = tracker_observations(machine, self)
        tag = f"tracker {self.source}"
        terms = tuple(NuisanceTerm(f"shift_{a}[{tag}]", False) for a in "xyz") + tuple(
            NuisanceTerm(f"rotation_{a}[{tag}]", True) for a in "xyz")
        n = len(self.q)
        i = np.repeat(np.arange(n), 3)                       # rows: x, y, z of every point
        return ObservationBlock(self.source, self.q, self.covariates, i, obs["w"].reshape(3 * n, 6),
                                obs["deviation"].reshape(3 * n), np.full(3 * n, options.sigma_um * 1e-6),
                                np.zeros(3 * n, bool), np.asarray(self.lines)[i], obs["nuisance"].reshape(3 * n, 6),
                                terms)


def is_tracker_file(header: list[str]) -> bool:
    """Whether a header is that of a tracker file.

    Parameters
    ----------
    header : list of str
        Column names.

    Returns
    -------
    bool
        True if the columns include ``tx``, ``ty`` and ``tz`` (with or without ``_mm``).
    """
    stems = {h.rsplit("_mm", 1)[0] if h.endswith("_mm") else h for h in header}
    return set(COORDINATES) <= stems


def read_tracker(path: str | Path | Table, machine) -> TrackerMeasurements:
    """Read a tracker file for ``machine`` (see the module docstring).

    Parameters
    ----------
    path : str, Path or Table
        The file, or a table read already.
    machine : Machine
        The machine (its axes name the position columns, checked against its travel).

    Returns
    -------
    TrackerMeasurements
        The measurements in SI (the file gives mm / deg and mm).

    Raises
    ------
    MeasurementError
        If the table is malformed, ``tx``, ``ty`` or ``tz`` is missing, only some of ``ox``,
        ``oy``, ``oz`` are given, a coordinate or offset lies beyond 1 km, a target name is
        empty, one target has two different offsets, or a position or covariate column is
        invalid (see :func:`~volerr_pin.measurements.positions_and_covariates`).
    """
    table = read_table(path)
    columns = header_columns(table, machine)
    missing = [c for c in COORDINATES if c not in columns]
    if missing:
        raise MeasurementError(f"{table.path}:{table.header_line}: a tracker file needs the columns tx, ty, tz "
                               f"(mm, tracker frame); missing {', '.join(missing)}")
    q, covariates, used = positions_and_covariates(table, columns, machine)
    coordinates = np.column_stack([table.column(columns[c], limit="position_length", unit="mm", unit_scale=1e-3)
                                   for c in COORDINATES]) * 1e-3
    used.update(columns[c] for c in COORDINATES)
    present = [c for c in OFFSETS if c in columns]
    if present and len(present) != 3:
        raise MeasurementError(f"{table.path}:{table.header_line}: target offsets need all of ox, oy, oz "
                               f"(missing {', '.join(c for c in OFFSETS if c not in columns)})")
    offsets = np.zeros((len(table.rows), 3))
    if present:
        offsets = np.column_stack([table.column(columns[c], limit="position_length", unit="mm", unit_scale=1e-3)
                                   for c in OFFSETS]) * 1e-3
        used.update(columns[c] for c in OFFSETS)
    if "target" in columns:
        targets = tuple(row[columns["target"]].strip() for row in table.rows)
        used.add(columns["target"])
        if "" in targets:
            r = targets.index("")
            raise MeasurementError(f"{table.where(r, columns['target'])}: column 'target': empty target name "
                                   "(name every target, or leave the column out)")
        first: dict[str, tuple[np.ndarray, int]] = {}
        for i, name in enumerate(targets):
            if name in first and not np.allclose(first[name][0], offsets[i], rtol=0, atol=1e-12):
                raise MeasurementError(f"{table.path}:{table.lines[i]}: target '{name}' has the offset "
                                       f"{offsets[i] * 1e3} mm here but {first[name][0] * 1e3} mm on line "
                                       f"{table.lines[first[name][1]]}")
            first.setdefault(name, (offsets[i], i))
    else:
        targets = tuple("" for _ in table.rows)
    unused = tuple(table.header[c] for c in range(len(table.header)) if c not in used)
    return TrackerMeasurements(table.path, q, coordinates, offsets, targets, covariates,
                               np.array(table.lines), unused)


def register(points: np.ndarray, measured: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation R and translation t minimising |R points + t - measured| (Kabsch).

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Points in the source frame.
    measured : ndarray, shape (N, 3)
        The same points measured in the target frame (same unit).

    Returns
    -------
    R : ndarray, shape (3, 3)
        Rotation (proper: determinant +1).
    t : ndarray, shape (3,)
        Translation, in the unit of the points.
    """
    cp, cm = points.mean(axis=0), measured.mean(axis=0)
    H = (points - cp).T @ (measured - cm)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T))
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    return R, cm - R @ cp


def tracker_observations(machine, data: TrackerMeasurements) -> dict:
    """Deviations of each target from its nominal position, ready for the model.

    Deviations in the workpiece frame after the first registration, their observation
    vectors ``w``, and the registration nuisance design: translation x, y, z, then small
    rotation about x, y, z.

    Parameters
    ----------
    machine : Machine
        The machine.
    data : TrackerMeasurements
        The measurements (at least 3 target positions, not on one line); their positions are
        checked against the machine's travel here.

    Returns
    -------
    dict
        ``deviation`` (N, 3) [m]; ``w`` (N, 3, 6): weights of the error dx, dy, dz [m],
        rx, ry, rz [rad] in each deviation component; ``nuisance`` (N, 3, 6): derivative of
        each deviation component by the tracker's small translation [m] and rotation [rad];
        ``rotation`` (3, 3) and ``translation`` (3,) [m] of the first registration
        (workpiece frame to tracker frame); ``nominal`` (N, 3): nominal target positions in
        the workpiece frame [m].

    Raises
    ------
    InputError
        If a position is invalid or outside the travel (:func:`~volerr_pin.model.check_q`), or
        the targets lie on a line or are fewer than 3: the tracker's placement cannot be found.
    """
    R_nom, p_nom = tool_poses(machine.model, check_q(machine.model, data.q), nominal=True)
    arm = np.einsum("nij,nj->ni", R_nom, data.offsets)   # target offset in the workpiece frame
    nominal = p_nom + arm
    spread = np.linalg.svd(nominal - nominal.mean(axis=0), compute_uv=False)
    if len(nominal) < 3 or spread[1] < 1e-6 * max(spread[0], 1e-12):
        raise InputError(f"{data.source}: the measured targets lie on a line (or are fewer than 3): "
                         "the tracker's placement cannot be found")
    R0, t0 = register(nominal, data.coordinates)
    deviation = (data.coordinates - t0) @ R0 - nominal     # R0^T (m - t0), row-wise
    eye = np.eye(3)
    w = np.zeros((len(nominal), 3, 6))
    w[:, :, :3] = eye
    w[:, :, 3:] = np.cross(arm[:, None, :], eye[None, :, :])  # (r x v)_k = r . (v x e_k)
    nuisance = np.zeros((len(nominal), 3, 6))
    nuisance[:, :, :3] = eye
    nuisance[:, :, 3:] = np.cross(eye[None, :, :], nominal[:, None, :]).transpose(0, 2, 1)  # (e_j x p)_k
    return {"deviation": deviation, "w": w, "nuisance": nuisance, "rotation": R0, "translation": t0,
            "nominal": nominal}


#: laser-tracker target coordinates (tx, ty, tz)
KIND = MeasurementKind("tracker", "tracker measurements", True, recognises=is_tracker_file,
                       read=lambda table, machine=None, axis=None: read_tracker(table, machine))
