"""What a kind of measurement is: two protocols and the observations they agree on.

A :class:`MeasurementKind` recognises its files by their header (and, for layouts of its own
that are not the long table, by their text) and reads them into a :class:`Measurement`, which
turns itself into an :class:`ObservationBlock`: the points it observes (commanded
positions and covariates), one row per observed value with the weights ``w`` that project
the machine's six-component error at the row's point onto it, and the nuisance terms of its
set-up (an instrument zero, an alignment, the placement of a tracker). The prediction of a
row is linear in both::

    y ~ w . e(q_point) + nuisance_design . nuisance

so that :func:`volerr_pin.fit.identify.identify` and :func:`volerr_pin.fit.diagnosis.diagnose` fit
every kind with the same exact sensitivities, and nuisance terms need no start values (a
linear term is found in one step from anywhere). Generic code never asks which kind it holds;
a new instrument is one module with a measurement and a kind, registered in
:mod:`volerr_pin.measurements`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Protocol, runtime_checkable

import numpy as np

from ._table import Table

__all__ = ["Measurement", "MeasurementKind", "NuisanceTerm", "ObservationBlock", "ObservationOptions"]


@dataclass(frozen=True)
class ObservationOptions:
    """How measurements are turned into observations.

    Attributes
    ----------
    sigma_um : float
        Standard deviation of position observations [um] (positive, finite: checked by the caller).
    sigma_urad : float
        Standard deviation of rotation observations [urad].
    axis : str, optional
        The moving axis of measurements that do not say which axis moved (runs).
    at : dict of str to float, optional
        Positions of the other axes [m, rad] during measurements along one axis (runs); they
        override what the files say.
    """

    sigma_um: float = 1.0
    sigma_urad: float = 1.0
    axis: str | None = None
    at: dict | None = None


@dataclass(frozen=True)
class NuisanceTerm:
    """A nuisance term of a measurement's set-up: fitted beside the machine's coefficients,
    reported, never written into the machine.

    Attributes
    ----------
    name : str
        Its name in reports, e.g. ``offset[positioning run FILE]``; unique over the data of a fit.
    angular : bool
        True for a term in rad (reported in urad), False for one in m (reported in um).
    """

    name: str
    angular: bool


@dataclass
class ObservationBlock:
    """The observations of one measurement: points, rows and nuisance design (SI).

    Attributes
    ----------
    source : str
        The file (or label) the rows come from.
    q : ndarray, shape (n, n_axes)
        Commanded NC positions of the points [m, rad].
    covariates : dict
        Keyword covariates of the points for :meth:`Machine.volumetric_error`.
    point : ndarray of int, shape (rows,)
        The point (0..n-1) each row observes.
    w : ndarray, shape (rows, 6)
        Weights of the error dx, dy, dz [m], rx, ry, rz [rad] at the row's point in the row's
        prediction.
    y : ndarray, shape (rows,)
        Observed values [m or rad].
    sigma : ndarray, shape (rows,)
        Standard deviations of the rows [m or rad].
    angular : ndarray of bool, shape (rows,)
        True for rows in rad, False for rows in m.
    lines : ndarray, shape (rows,)
        File line (or sample index) of each row, for messages.
    nuisance : ndarray, shape (rows, k)
        Derivative of each row's prediction by each nuisance term [m or rad per SI unit].
    nuisance_terms : tuple of NuisanceTerm
        The ``k`` nuisance terms, in the order of the columns of ``nuisance``.
    poses : ndarray of int, shape (n,), optional
        Pose of every point: the points of one pose are held out together in
        cross-validation. None (default): points at the same commanded positions are one pose.
    """

    source: str
    q: np.ndarray
    covariates: dict
    point: np.ndarray
    w: np.ndarray
    y: np.ndarray
    sigma: np.ndarray
    angular: np.ndarray
    lines: np.ndarray
    nuisance: np.ndarray
    nuisance_terms: tuple = ()
    poses: np.ndarray | None = field(default=None)


@runtime_checkable
class Measurement(Protocol):
    """A measurement as read: it knows where it came from and turns itself into observations.

    Attributes
    ----------
    source : str
        The file (or a label for simulated data).
    unused : tuple of str
        Columns (or keys) of the file that it does not use, for notes.
    """

    source: str
    unused: tuple[str, ...]

    def observations(self, machine, options: ObservationOptions) -> ObservationBlock:
        """The observations of this measurement of ``machine``.

        Parameters
        ----------
        machine : Machine
            The machine observed.
        options : ObservationOptions
            Standard deviations, and the axis and positions of measurements along one axis.

        Returns
        -------
        ObservationBlock
            Points, rows and nuisance design.

        Raises
        ------
        InputError
            If the measurement does not fit the machine (unknown axes, positions outside the
            travel, ...).
        """


@dataclass(frozen=True)
class MeasurementKind:
    """A kind of measurement file, as :mod:`volerr_pin.measurements` knows it: how
    its files are recognised and read.

    Attributes
    ----------
    name : str
        Short name ("points", "runs", "tracker", "ballbar").
    what : str
        What its files hold, for messages ("point measurements").
    needs_machine : bool
        Whether reading needs the machine (its axes name columns, its travels bound them).
    recognises : callable(list of str) -> bool
        Whether a table with these columns (the header) is of this kind.
    read : callable(Table, Machine or None, str or None) -> Measurement
        Reads a table of this kind (the machine, and the moving axis for kinds that measure
        along one axis); raises :class:`~volerr_pin.measurements.MeasurementError`
        naming file, line and column.
    layout : callable(Path, str) -> Table or None, optional
        The file (path, text) as this kind's long table when it is written in another layout
        this kind reads (None when it is not: it is then read as a comma-separated table).
    """

    name: str
    what: str
    needs_machine: bool
    recognises: Callable[[list], bool]
    read: Callable[..., Measurement]
    layout: Callable[[Path, str], Table | None] | None = None
