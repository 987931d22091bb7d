"""A laser tracker: one pose per unit, one row per reflector (target) on the tool, the
tracker's placement as six nuisance terms of the campaign (docs/measurements.md, tracker files).

The planned file is the tracker file identify reads: axis columns (mm / deg), ``target``,
the target's offset ``ox, oy, oz`` from the tool point in the tool frame (mm) and empty
``tx, ty, tz``. Targets off the tool point also observe the tool's orientation (the arm
turns a rotation error into a displacement), so several targets (or tool lengths) separate
angular errors from position errors that one target sees as the same.

Line of sight, when the tracker's position is given: a reflector returns the beam within its
acceptance cone (half-angle :attr:`~volerr_pin.studies.plan.Setup.acceptance`, 30 deg by
default, a typical value for a 1.5 in. spherically mounted retroreflector) about the
direction it faces. Each reflector is set up facing the tracker at the zone's centre and
turns with the tool; a pose is kept only when every reflector still sees the tracker.
Obstruction by the machine's own structure is not modelled.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...measurements import TrackerMeasurements
from ...model import tool_poses
from ._nc import StopsProgram
from ._poses import OneFileOfPoses, pose_candidates
from ._probe import point_table
from ._protocol import Instrument, Setup

__all__ = ["TRACKER", "Tracker", "in_sight"]


def _targets_at(machine, q: np.ndarray, targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nominal target positions (n, k, 3) [m] and tool rotations (n, 3, 3) in the workpiece frame
    at poses ``q`` of the zone (a float array, within the travel)."""
    R, p = tool_poses(machine.model, q, nominal=True)
    return p[:, None, :] + np.einsum("nij,kj->nki", R, targets), R


def in_sight(machine, setup: Setup, q: np.ndarray) -> np.ndarray:
    """Whether every reflector sees the tracker at each pose (see the module docstring).

    Parameters
    ----------
    machine : Machine
        The machine.
    setup : Setup
        Targets, tracker position and acceptance half-angle.
    q : ndarray, shape (n, n_axes)
        Poses [m, rad].

    Returns
    -------
    ndarray of bool, shape (n,)
        True where every reflector sees the tracker (all True without a tracker position).
    """
    q = np.asarray(q, dtype=float)
    if setup.station is None:
        return np.ones(len(q), dtype=bool)
    centre = setup.zone.mean(axis=1)[None, :]
    p0, R0 = _targets_at(machine, centre, setup.targets)
    facing = setup.station[None, :] - p0[0]
    facing = np.einsum("ji,kj->ki", R0[0], facing / np.linalg.norm(facing, axis=1, keepdims=True))  # tool frame
    p, R = _targets_at(machine, q, setup.targets)
    to_station = setup.station[None, None, :] - p
    to_station /= np.linalg.norm(to_station, axis=2, keepdims=True)
    cosine = np.einsum("nki,nki->nk", np.einsum("nij,kj->nki", R, facing), to_station)
    return np.all(cosine >= np.cos(setup.acceptance), axis=1)


@dataclass(frozen=True)
class Tracker(StopsProgram, OneFileOfPoses, Instrument):
    """The laser-tracker instrument (see the module docstring).

    Attributes
    ----------
    name : str
        "tracker".
    unit : str
        "pose".
    default_sigma_um : float
        5 um per coordinate: a tracker's typical uncertainty at a few metres, as a default.
    registers : bool
        True: the tracker's placement is fitted, so a rigid motion of the whole map is not
        determined (:attr:`~volerr_pin.studies.plan.Instrument.registers`).

    Notes
    -----
    The methods of :class:`~volerr_pin.studies.plan.Instrument` (documented there) do here:

    - ``candidates``: poses of the layout over the zone, those out of the tracker's sight left
      out.
    - ``measurements``: one tracker-measurement object: a row per pose and target (pose-major).
    """

    name: str = "tracker"
    unit: str = "pose"
    default_sigma_um: float = 5.0
    registers: bool = True

    def candidates(self, machine, setup: Setup, count: int, layout: str, seed: int) -> list:
        q = pose_candidates(setup.zone, machine.axis_kinds, count, layout, seed)
        return list(q[in_sight(machine, setup, q)])

    def measurements(self, machine, setup: Setup, units: list, values: np.ndarray | None = None
                     ) -> tuple[list, np.ndarray]:
        q = np.asarray(units, dtype=float).reshape(len(units), len(machine.axes))
        k = len(setup.targets)
        nominal, _ = _targets_at(machine, q, setup.targets)
        coordinates = nominal.reshape(-1, 3).copy()
        if values is not None:
            coordinates += np.asarray(values, dtype=float).reshape(-1, 3)
        if setup.station is not None:
            coordinates -= setup.station
        names = tuple(f"T{j + 1}" for j in range(k)) * len(q)
        data = TrackerMeasurements("planned tracker poses", np.repeat(q, k, axis=0), coordinates,
                                   np.tile(setup.targets, (len(q), 1)), names, {}, np.arange(2, len(q) * k + 2))
        return [data], np.repeat(np.arange(len(q)), k)

    def table(self, machine, setup: Setup, units: list) -> str:
        """A tracker file: axis columns (mm / deg), ``target``, ``ox, oy, oz`` (mm) and empty
        ``tx, ty, tz``; one row per pose and target.

        Parameters
        ----------
        machine : Machine
            The machine.
        setup : Setup
            Targets.
        units : list of ndarray
            Poses [m, rad].

        Returns
        -------
        str
            The file's text.
        """
        q = np.asarray(units, dtype=float)
        k = len(setup.targets)
        offsets = np.tile(setup.targets * 1e3, (len(q), 1))
        extra = {"target": [f"T{j + 1}" for j in range(k)] * len(q)}
        extra.update({c: [f"{v:.4f}" for v in offsets[:, i]] for i, c in enumerate(("ox", "oy", "oz"))})
        return point_table(machine, np.repeat(q, k, axis=0), extra, columns=("tx", "ty", "tz"))


#: the laser tracker
TRACKER = Tracker()
