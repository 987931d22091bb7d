"""Plain axis programming: program coordinates are axis positions."""

from __future__ import annotations

import numpy as np

from ..model import Machine
from ._programming import Programming


class AxisProgramming(Programming):
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

    Notes
    -----
    The methods of :class:`~volerr_pin.compensation.Programming` (documented there) do here:

    - ``to_axes``: the axis positions: ``words`` themselves.
    - ``to_words``: the program coordinates: ``q`` itself.
    - ``word_rows``: derivatives with respect to program coordinates: ``rows`` themselves.
    """

    name = "axes"
    identity = True

    def __init__(self, machine: Machine):
        self.machine = machine

    def to_axes(self, words: np.ndarray) -> np.ndarray:
        return words

    def to_words(self, q: np.ndarray) -> np.ndarray:
        return q

    def word_rows(self, rows: np.ndarray, jacobian: np.ndarray) -> np.ndarray:
        return rows
