"""What a controller format is, and what a compensation it applies is: two protocols.

A :class:`ControllerFormat` lays out the tables its controller can hold for a machine
(refusing machines it cannot serve), rounds values to what its files can say, writes its
files and reads them back. A :class:`Compensation` is what the controller then does: the
set-point corrections it adds at each commanded position, linear (at least to first order)
in the values the files hold, so one least-squares fit (:mod:`volerr_pin.export.fit`) and one
simulation (:mod:`volerr_pin.export.simulate`) serve every format. Generic code never asks
which format or which kind of compensation it holds.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol, runtime_checkable

import numpy as np
import scipy.sparse as sp

from ..machine import Machine
from .zone import Zone

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
        """The same compensation with other values (shape (P,), SI)."""

    def correction(self, q: np.ndarray, directions: np.ndarray, tool: np.ndarray) -> np.ndarray:
        """Set-point corrections (N, n_axes) [m, rad] the controller adds at commanded positions
        ``q`` (N, n_axes), moving in ``directions`` (N, n_axes) of +1/-1, with a tool ``tool``
        (N,) [m] longer than the machine's tool point."""

    def basis(self, q: np.ndarray, directions: np.ndarray, tool: np.ndarray) -> sp.spmatrix:
        """d correction / d values at the same arguments: a (N * n_axes, P) matrix, row
        ``i * n_axes + j`` for axis j at point i (exact for tables, first order for a model)."""

    def naive(self, machine: Machine) -> "Compensation":
        """The same compensation filled by sampling the machine's component errors at the
        nodes (what the fit is compared with)."""

    def contents(self) -> tuple:
        """Everything the files say, values included (nested tuples of numbers and arrays, SI):
        what must survive writing and reading."""

    def describe(self, machine: Machine) -> list[str]:
        """One line per table, for reports."""

    def axis_nodes(self) -> list[np.ndarray | None]:
        """The node positions at which each axis is tabulated (None where no table reads it)."""


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
        The kinds of tables it offers, in order of reach; the last is the default.
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
        """The tables of ``kind`` for ``machine`` over ``zone`` (values zero), ``nodes`` per
        axis (None: the format's default); raises ``SpecError`` for a machine the controller
        cannot serve this way and ``InputError`` for a node count beyond its limits."""

    def quantise(self, compensation: Compensation, machine: Machine) -> Compensation:
        """The values rounded to what the files can hold; raises ``InputError`` for a value
        beyond the format's range."""

    def files(self, compensation: Compensation, machine: Machine) -> dict[str, str]:
        """File name (relative to the output folder) -> text, for quantised values."""

    def read(self, texts: Mapping[str, str], machine: Machine) -> Compensation:
        """The compensation the files describe, parsed by the controller's rules; raises
        ``InputError`` for what the controller would refuse."""
