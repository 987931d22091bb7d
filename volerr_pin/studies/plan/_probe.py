"""A probe (or any instrument that reads the tool point's deviation at a pose): one pose per
unit, three observations (dx, dy, dz) each, no nuisance term; its file is a point-measurement
file (``x,y,z[,a,b,c],dx,dy,dz``, positions in mm / deg, deviations in um: docs/measurements.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...base import InputError, axis_scales
from ...measurements import PointMeasurements
from ._poses import OneFileOfPoses, pose_candidates
from ._nc import StopsProgram
from ._protocol import Instrument, Setup

__all__ = ["PROBE", "Probe", "point_table"]


def point_table(machine, q: np.ndarray, extra: dict | None = None, columns=("dx", "dy", "dz")) -> str:
    """Rows of axis positions (mm / deg) with empty deviation columns, as a measurement file.

    Parameters
    ----------
    machine : Machine
        The machine (its axes name the columns).
    q : ndarray, shape (n, n_axes)
        NC positions [m, rad].
    extra : dict of str to list of str, optional
        Further columns (name -> one text per row) placed after the positions.
    columns : sequence of str
        The empty deviation columns.

    Returns
    -------
    str
        The file's text with a header row.
    """
    extra = extra or {}
    names = [a.lower() for a in machine.axes]
    scale = axis_scales(machine.axis_kinds)
    header = ",".join([*names, *extra, *columns])
    rows = []
    for i, row in enumerate(np.asarray(q) / scale):
        cells = [f"{v:.4f}" for v in row] + [extra[k][i] for k in extra] + [""] * len(columns)
        rows.append(",".join(cells))
    return header + "\n" + "\n".join(rows) + "\n"


@dataclass(frozen=True)
class Probe(StopsProgram, OneFileOfPoses, Instrument):
    """The probe instrument (see the module docstring).

    Attributes
    ----------
    name : str
        "probe".
    unit : str
        "pose".
    default_sigma_um : float
        1 um: a touch-trigger probe's repeatability on a reference artefact, as a default.

    Notes
    -----
    The methods of :class:`~volerr_pin.studies.plan.Instrument` (documented there) do here:

    - ``candidates``: poses of the layout over the zone (see
      :func:`~volerr_pin.studies.plan._poses.pose_candidates`).
    - ``measurements``: one point-measurement object: rows dx, dy, dz of every pose, in pose
      order.
    """

    name: str = "probe"
    unit: str = "pose"
    default_sigma_um: float = 1.0

    def candidates(self, machine, setup: Setup, count: int, layout: str, seed: int) -> list:
        if np.any(setup.targets != 0):
            raise InputError("targets: a probe file gives the deviation of the tool point only (dx, dy, dz): "
                             "targets off the tool point need a tracker", parameters=("targets",))
        return list(pose_candidates(setup.zone, machine.axis_kinds, count, layout, seed))

    def measurements(self, machine, setup: Setup, units: list, values: np.ndarray | None = None
                     ) -> tuple[list, np.ndarray]:
        q = np.asarray(units, dtype=float).reshape(len(units), len(machine.axes))
        dev = np.zeros((len(q), 6))
        dev[:, 3:] = np.nan
        if values is not None:
            dev[:, :3] = np.asarray(values, dtype=float).reshape(len(q), 3)
        return [PointMeasurements("planned probe poses", q, dev, {}, np.arange(2, len(q) + 2))], np.arange(len(q))

    def table(self, machine, setup: Setup, units: list) -> str:
        """A point-measurement file: axis columns (mm / deg) and empty ``dx,dy,dz``.

        Parameters
        ----------
        machine : Machine
            The machine.
        setup : Setup
            Unused.
        units : list of ndarray
            Poses [m, rad].

        Returns
        -------
        str
            The file's text.
        """
        return point_table(machine, np.asarray(units))


#: the probe
PROBE = Probe()
