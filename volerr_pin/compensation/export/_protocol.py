"""What a controller format is, and what a compensation it applies is: two protocols.

A :class:`ControllerFormat` lays out the tables its controller can hold for a machine
(refusing machines it cannot serve), rounds values to what its files can say, writes its
files and reads them back. A :class:`Compensation` is what the controller then does: the
set-point corrections it adds at each commanded position, linear (at least to first order)
in the values the files hold, so one least-squares fit (:func:`~volerr_pin.compensation.export.fit_values`)
and one simulation (:func:`~volerr_pin.compensation.export.simulate`) serve every format. Generic code never asks
which format or which kind of compensation it holds.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol, runtime_checkable

import numpy as np
import scipy.sparse as sp

from ...model import Machine
from ._zone import Zone

__all__ = ["Compensation", "ControllerFormat"]


@runtime_checkable
class Compensation(Protocol):
    """What a controller does with its tables: corrections of the axis set-points.

    Attributes
    ----------
    kind : str
        The kind of tables, as the format names it.
    notes : tuple of str
        Facts about the layout for reports.
    """

    kind: str
    notes: tuple[str, ...]

    @property
    def values(self) -> np.ndarray:
        """The values the files hold that a fit may choose, SI, ndarray of shape (P,)."""

    def with_values(self, values: np.ndarray) -> "Compensation":
        """The same compensation with other values.

        Parameters
        ----------
        values : ndarray, shape (P,)
            The values [m, rad], ordered as :attr:`values`.

        Returns
        -------
        Compensation
            A copy.
        """

    def correction(self, q: np.ndarray, directions: np.ndarray, tool: np.ndarray) -> np.ndarray:
        """The set-point corrections the controller adds.

        Parameters
        ----------
        q : ndarray, shape (N, n_axes)
            Commanded positions [m, rad].
        directions : ndarray, shape (N, n_axes)
            +1 / -1: the direction each axis last moved in.
        tool : ndarray, shape (N,)
            Tool extension beyond the machine's tool point [m].

        Returns
        -------
        ndarray, shape (N, n_axes)
            Corrections [m, rad].
        """

    def basis(self, q: np.ndarray, directions: np.ndarray, tool: np.ndarray) -> sp.spmatrix:
        """d correction / d values (exact for tables, first order for a model).

        Parameters
        ----------
        q : ndarray, shape (N, n_axes)
            Commanded positions [m, rad].
        directions : ndarray, shape (N, n_axes)
            +1 / -1 motion directions.
        tool : ndarray, shape (N,)
            Tool extensions [m].

        Returns
        -------
        scipy.sparse matrix, shape (N * n_axes, P)
            Row ``i * n_axes + j``: axis j at point i.
        """

    def naive(self, machine: Machine) -> "Compensation":
        """The same compensation filled by sampling the machine's component errors at the nodes.

        Parameters
        ----------
        machine : Machine
            The machine.

        Returns
        -------
        Compensation
            What the fit is compared with.
        """

    def contents(self) -> tuple:
        """Everything the files say, values included: what must survive writing and reading.

        Returns
        -------
        tuple
            Nested tuples of ints, bools and arrays (SI).
        """

    def describe(self, machine: Machine) -> list[str]:
        """One line per table, for reports.

        Parameters
        ----------
        machine : Machine
            The machine (axis names and units).

        Returns
        -------
        list of str
            The lines.
        """

    def axis_nodes(self) -> list[np.ndarray | None]:
        """The node positions at which each axis is tabulated.

        Returns
        -------
        list of (ndarray or None)
            One entry per machine axis [m, rad]; None where no table reads the axis.
        """


@runtime_checkable
class ControllerFormat(Protocol):
    """A controller's compensation files: layout, rounding, writing and reading back.

    Attributes
    ----------
    name : str
        The registry key (``"linuxcnc"``).
    title : str
        The controller and function, for reports.
    kinds : tuple of str
        The kinds of tables it offers, in order of reach; the last is the most capable.
    convention : str
        What the numbers in its files mean (error or correction, unit), for reports.
    manual : str
        The manual and section each fact of the format comes from.
    """

    name: str
    title: str
    kinds: tuple[str, ...]
    convention: str
    manual: str

    def layout(self, machine: Machine, zone: Zone, kind: str, nodes: int | None) -> Compensation:
        """The tables of ``kind`` for ``machine`` over ``zone``, values zero.

        Parameters
        ----------
        machine : Machine
            The machine.
        zone : Zone
            Where the nodes lie.
        kind : str
            One of :attr:`kinds`.
        nodes : int or None
            Nodes per axis (None: the format's default).

        Returns
        -------
        Compensation
            The layout.

        Raises
        ------
        SpecError
            For a machine the controller cannot serve this way.
        InputError
            For a node count beyond the format's limits.
        """

    def quantise(self, compensation: Compensation, machine: Machine) -> Compensation:
        """The values rounded to what the files can hold.

        Parameters
        ----------
        compensation : Compensation
            Fitted or naive values.
        machine : Machine
            The machine.

        Returns
        -------
        Compensation
            Rounded.

        Raises
        ------
        InputError
            For a value beyond the format's range.
        """

    def files(self, compensation: Compensation, machine: Machine) -> dict[str, str]:
        """The files, for quantised values.

        Parameters
        ----------
        compensation : Compensation
            Quantised values.
        machine : Machine
            The machine.

        Returns
        -------
        dict of str to str
            File name (relative to the output folder) -> text.
        """

    def read(self, texts: Mapping[str, str], machine: Machine) -> Compensation:
        """The compensation the files describe, parsed by the controller's rules.

        Parameters
        ----------
        texts : mapping of str to str
            File name -> text.
        machine : Machine
            The machine.

        Returns
        -------
        Compensation
            What the controller would load.

        Raises
        ------
        InputError
            For what the controller would refuse.
        """
