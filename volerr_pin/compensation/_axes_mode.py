"""Plain axis programming: program coordinates are axis positions."""

from __future__ import annotations

import numpy as np

from ..model import Machine


class AxisProgramming:
    """Program coordinates are axis positions (the maps are the identity).

    Parameters
    ----------
    machine : Machine
        The machine (any).

    Attributes
    ----------
    name : str
        ``"axes"``.
    identity : bool
        True.
    """

    name = "axes"
    identity = True

    def __init__(self, machine: Machine):
        self.machine = machine

    def to_axes(self, words: np.ndarray) -> np.ndarray:
        """The axis positions: ``words`` themselves.

        Parameters
        ----------
        words : ndarray, shape (N, n_axes)
            Program coordinates [m, rad].

        Returns
        -------
        ndarray, shape (N, n_axes)
            The same array.
        """
        return words

    def to_words(self, q: np.ndarray) -> np.ndarray:
        """The program coordinates: ``q`` itself.

        Parameters
        ----------
        q : ndarray, shape (N, n_axes)
            Axis positions [m, rad].

        Returns
        -------
        ndarray, shape (N, n_axes)
            The same array.
        """
        return q

    def word_rows(self, rows: np.ndarray, jacobian: np.ndarray) -> np.ndarray:
        """Derivatives with respect to program coordinates: ``rows`` themselves.

        Parameters
        ----------
        rows : ndarray, shape (N, m, n_axes)
            Derivatives with respect to the axis positions.
        jacobian : ndarray, shape (N, 6, n_axes)
            Not used.

        Returns
        -------
        ndarray, shape (N, m, n_axes)
            The same array.
        """
        return rows
