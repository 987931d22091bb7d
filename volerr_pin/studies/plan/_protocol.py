"""What an instrument is to the planner: one protocol, one module per kind.

An :class:`Instrument` proposes candidate *units* of measurement (a pose of the machine for
a tracker or a probe, a positioning run for an interferometer, a circle for a ballbar) over
a working zone, turns any selection of them into the measurement objects
:func:`volerr_pin.fit.identify.identify` reads (so that the planned design is exactly the design
identify will have, nuisance terms included), writes a selection as the measurement file the
instrument produces (deviation columns empty) and says which axis positions the machine
visits. Generic code (the design's choice and :func:`~volerr_pin.studies.plan.plan`) never
asks which instrument it holds.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["LAYOUTS", "Instrument", "Setup", "numbered_files"]

#: how candidate units are laid out over the zone: scrambled Sobol' points (the pool a plan
#: chooses from), a regular grid, or uniform random draws
LAYOUTS = ("sobol", "grid", "random")


@dataclass(frozen=True)
class Setup:
    """Where and how an instrument measures (SI).

    Attributes
    ----------
    zone : ndarray, shape (n_axes, 2)
        Lower and upper NC position of each axis [m, rad] the campaign may visit.
    sigma : float
        The instrument's standard uncertainty of one observed value [m].
    targets : ndarray, shape (k, 3)
        Target (reflector, stylus) offsets from the tool point in the tool frame [m]; one row
        (0, 0, 0) by default.
    station : ndarray, shape (3,) or None
        Tracker position in the workpiece frame [m], for its line of sight; None: every pose
        is in sight.
    acceptance : float
        Half-angle of a reflector's acceptance cone [rad].
    """

    zone: np.ndarray
    sigma: float
    targets: np.ndarray = field(default_factory=lambda: np.zeros((1, 3)))
    station: np.ndarray | None = None
    acceptance: float = float(np.radians(30.0))


@runtime_checkable
class Instrument(Protocol):
    """A kind of instrument, as the planner uses it.

    Attributes
    ----------
    name : str
        Its name on the command line ("tracker", "probe", "interferometer", "ballbar").
    unit : str
        What one unit of measurement is, in words ("pose").
    default_sigma_um : float
        Standard uncertainty of one observed value stated for the instrument [um].
    registers : bool
        Its own placement is fitted with the machine (a tracker's three shifts and rotations):
        a rigid motion of the whole error map is then not determined by any campaign, and the
        plan's headline is the map less its best rigid fit. Optional (default False).
    """

    name: str
    unit: str
    default_sigma_um: float

    def candidates(self, machine, setup: Setup, count: int, layout: str, seed: int) -> list:
        """Candidate units over the zone.

        Parameters
        ----------
        machine : Machine
            The machine.
        setup : Setup
            Zone, targets, station.
        count : int
            How many units to propose (fewer when some are out of sight).
        layout : str
            One of :data:`LAYOUTS`.
        seed : int
            Seed of the scrambling or the draws.

        Returns
        -------
        list
            The units (the instrument's own objects).
        """

    def measurements(self, machine, setup: Setup, units: list, values: np.ndarray | None = None
                     ) -> tuple[list, np.ndarray]:
        """The units as measurement objects identify reads.

        Parameters
        ----------
        machine : Machine
            The machine.
        setup : Setup
            Targets, station.
        units : list
            The units.
        values : ndarray, shape (rows,), optional
            Observed values in the order of the rows of the measurements' observation blocks,
            stacked [m or rad]; None: zero (a design without data).

        Returns
        -------
        measurements : list of Measurement
            Objects following :class:`~volerr_pin.measurements.Measurement`.
        unit_of_point : ndarray of int, shape (points,)
            The unit of every point of the stacked blocks.
        """

    def outputs(self, out, count: int) -> list:
        """The files a plan of ``count`` units writes for the plan file ``out`` (one file, or
        one per unit for instruments whose files hold one unit each).

        Parameters
        ----------
        out : str or Path
            The plan's file as given.
        count : int
            Number of units.

        Returns
        -------
        list of Path
            The files, in the order of :meth:`files`.
        """

    def files(self, machine, setup: Setup, units: list) -> list:
        """The units as the measurement files the instrument produces, deviation cells empty.

        Parameters
        ----------
        machine : Machine
            The machine.
        setup : Setup
            Targets.
        units : list
            The units, in the order they are measured.

        Returns
        -------
        list of str
            The files' texts (engineering units: mm, deg), in the order of :meth:`outputs`.
        """

    def visits(self, machine, units: list) -> np.ndarray:
        """The axis positions the machine stands at, in order, one per measurement.

        Parameters
        ----------
        machine : Machine
            The machine.
        units : list
            The units.

        Returns
        -------
        ndarray, shape (n, n_axes)
            NC positions [m, rad].
        """

    def program(self, machine, units: list, feed_mm_min: float, dwell_s: float, title: str = "") -> str:
        """The NC program that runs the units in order, with a dwell for each measurement
        (:class:`~volerr_pin.studies.plan.StopsProgram` for instruments that measure at stops).

        Parameters
        ----------
        machine : Machine
            The machine.
        units : list
            The units, in the order measured.
        feed_mm_min : float
            Feed [mm/min].
        dwell_s : float
            Dwell per measurement [s].
        title : str, optional
            A comment line at the top.

        Returns
        -------
        str
            The program (mm, deg, absolute).
        """

    def duration(self, machine, units: list, feed_mm_min: float, dwell_s: float) -> dict:
        """The time the program of :meth:`program` takes.

        Parameters
        ----------
        machine : Machine
            The machine.
        units : list
            The units, in order.
        feed_mm_min : float
            Feed [mm/min].
        dwell_s : float
            Dwell per measurement [s].

        Returns
        -------
        dict
            ``moves_s``, ``dwell_s``, ``total_s``, ``total_min``, ``feed_mm_min``,
            ``dwell_per_pose_s``, ``path_mm``, ``model`` (see :func:`~volerr_pin.studies.plan.time_estimate`).
        """


def numbered_files(out, count: int, word: str) -> list[Path]:
    """The files of an instrument whose files hold one unit each: ``STEM_<word>01.csv`` ...
    beside the plan's file, numbered from 1 with at least two digits (as many as ``count``
    needs).

    Parameters
    ----------
    out : str or Path
        The plan's file as given.
    count : int
        Number of units.
    word : str
        What a unit is called in the names ("circle", "run").

    Returns
    -------
    list of Path
        One file per unit, in order.
    """
    out = Path(out)
    width = max(2, len(str(count)))
    return [out.with_name(f"{out.stem}_{word}{i + 1:0{width}d}{out.suffix}") for i in range(count)]
