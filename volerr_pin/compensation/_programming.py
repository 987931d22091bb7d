"""How the coordinates of a program are read: the programming modes, behind one protocol.

A program's coordinate words are *program coordinates*; a controller turns them into axis
positions and interpolates its moves linearly (or along arcs) in program coordinates:

- ``"axes"`` (``AxisProgramming``): the words are axis positions (plain axis programming);
- ``"tool-tip"`` (``ToolTipProgramming``): the linear words are the tool tip in the workpiece
  frame and the rotary words the rotary axis positions (tool centre point programming:
  Fanuc G43.4, Siemens TRAORI, RTCP). The controller finds the linear axis positions that put
  the nominal tool tip there.

A new mode is one module with a subclass of :class:`Programming`, listed in
:data:`~volerr_pin.compensation.PROGRAMMINGS`; the path compensation never asks which mode it
has.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

__all__ = ["Programming"]


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
