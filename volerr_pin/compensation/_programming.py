"""How the coordinates of a program are read: the programming modes, behind one protocol.

A program's coordinate words are *program coordinates*; a controller turns them into axis
positions and interpolates its moves linearly (or along arcs) in program coordinates:

- ``"axes"`` (:mod:`.axes_mode`): the words are axis positions (plain axis programming);
- ``"tool-tip"`` (:mod:`.tool_tip`): the linear words are the tool tip in the workpiece
  frame and the rotary words the rotary axis positions (tool centre point programming:
  Fanuc G43.4, Siemens TRAORI, RTCP). The controller finds the linear axis positions that put
  the nominal tool tip there.

A new mode is one module with a class that implements :class:`Programming`, listed in
:data:`PROGRAMMINGS`; the path compensation never asks which mode it has.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from ..base import InputError
from ..model import Machine

__all__ = ["PROGRAMMINGS", "Programming", "programming_for"]


class Programming(Protocol):
    """The map between program coordinates and axis positions (SI: m, rad).

    Attributes
    ----------
    name : str
        The mode's name (``"axes"``, ``"tool-tip"``).
    identity : bool
        Program coordinates are axis positions (the maps are the identity).
    """

    name: str
    identity: bool

    def to_axes(self, words: np.ndarray) -> np.ndarray:
        """Axis positions of program coordinates.

        Parameters
        ----------
        words : ndarray, shape (N, n_axes)
            Program coordinates in the order of the machine's axes [m, rad].

        Returns
        -------
        ndarray, shape (N, n_axes)
            Axis positions [m, rad].
        """
        ...

    def word_rows(self, rows: np.ndarray, jacobian: np.ndarray) -> np.ndarray:
        """Derivatives with respect to axis positions turned into derivatives with respect to
        program coordinates (the chain rule through :meth:`to_axes`).

        Parameters
        ----------
        rows : ndarray, shape (N, m, n_axes)
            Derivatives of some quantity with respect to the axis positions.
        jacobian : ndarray, shape (N, 6, n_axes)
            The nominal axis Jacobian at the same poses (:func:`~volerr_pin.model.axis_jacobian`).

        Returns
        -------
        ndarray, shape (N, m, n_axes)
            The derivatives with respect to the program coordinates.
        """
        ...

    def to_words(self, q: np.ndarray) -> np.ndarray:
        """Program coordinates of axis positions (the inverse of :meth:`to_axes`).

        Parameters
        ----------
        q : ndarray, shape (N, n_axes)
            Axis positions [m, rad].

        Returns
        -------
        ndarray, shape (N, n_axes)
            Program coordinates [m, rad].
        """
        ...


def _registry() -> dict:
    from ._axes_mode import AxisProgramming
    from ._tool_tip import ToolTipProgramming

    return {AxisProgramming.name: AxisProgramming, ToolTipProgramming.name: ToolTipProgramming}


#: the programming modes by name (filled on first use)
PROGRAMMINGS: dict = {}


def programming_for(name: str, machine: Machine) -> Programming:
    """The programming mode ``name`` for a machine.

    Parameters
    ----------
    name : str
        A key of :data:`PROGRAMMINGS` (``"axes"`` or ``"tool-tip"``).
    machine : Machine
        The machine.

    Returns
    -------
    Programming
        The mode.

    Raises
    ------
    InputError
        If the mode is unknown or the machine cannot be programmed in it (naming
        ``programming``).
    """
    if not PROGRAMMINGS:
        PROGRAMMINGS.update(_registry())
    kind = PROGRAMMINGS.get(name)
    if kind is None:
        raise InputError(f"programming must be one of {', '.join(sorted(PROGRAMMINGS))}, got {name!r}",
                         parameters=("programming",))
    return kind(machine)
