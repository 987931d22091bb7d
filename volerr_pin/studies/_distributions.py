"""How a toleranced error is drawn: one small class per distribution behind one protocol,
found by name in :data:`DISTRIBUTIONS`.

A component with tolerance ``t`` takes the value ``t * xi``, where ``xi`` is the
distribution's standard variable: uniform on [-1, 1] ("within +-t") or standard normal
("t is the standard deviation"). Draws go through the inverse CDF of uniform numbers, so
every distribution consumes the same random stream.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np
from scipy.special import ndtri

from ..base import InputError

__all__ = ["DISTRIBUTIONS", "Distribution", "Normal", "Uniform", "distribution"]


class Distribution(Protocol):
    """A distribution of a toleranced error, scaled by its tolerance.

    Attributes
    ----------
    name : str
        The name files use (``"uniform"``, ``"normal"``).
    std : float
        Standard deviation of the standard variable (per unit of tolerance).
    meaning : str
        What the tolerance means, in words.
    """

    name: str
    std: float
    meaning: str

    def standard(self, u: np.ndarray) -> np.ndarray:
        """The standard variable at uniform numbers (inverse CDF).

        Parameters
        ----------
        u : ndarray
            Uniform numbers in [0, 1).

        Returns
        -------
        ndarray
            The standard variable, same shape (dimensionless).
        """
        ...

    def salib(self, tolerance: float) -> tuple[str, list[float]]:
        """SALib's name of the distribution and its ``bounds`` entry.

        Parameters
        ----------
        tolerance : float
            The tolerance [SI].

        Returns
        -------
        tuple of (str, list of float)
            The name (``unif``, ``norm``) and the bounds entry.
        """
        ...


class Uniform(Distribution):
    """Uniform within +-tolerance.

    Attributes
    ----------
    name : str
        "uniform".
    std : float
        1 / sqrt(3).
    meaning : str
        What the tolerance means.

    Notes
    -----
    The methods of :class:`Distribution` (documented there)
    do here:

    - ``standard``: ``2 u - 1``: uniform on [-1, 1].
    - ``salib``: SALib's ``unif`` on [-tolerance, tolerance].
    """

    name = "uniform"
    std = 1.0 / math.sqrt(3.0)
    meaning = "uniform within +-tolerance"

    def standard(self, u: np.ndarray) -> np.ndarray:
        return 2.0 * np.asarray(u) - 1.0

    def salib(self, tolerance: float) -> tuple[str, list[float]]:
        return "unif", [-tolerance, tolerance]


class Normal(Distribution):
    """Normal with the tolerance as standard deviation.

    Attributes
    ----------
    name : str
        "normal".
    std : float
        1.
    meaning : str
        What the tolerance means.

    Notes
    -----
    The methods of :class:`Distribution` (documented there)
    do here:

    - ``standard``: the standard normal quantile of ``u``.
    - ``salib``: SALib's ``norm`` with mean 0 and standard deviation ``tolerance``.
    """

    name = "normal"
    std = 1.0
    meaning = "normal, standard deviation = tolerance"

    def standard(self, u: np.ndarray) -> np.ndarray:
        return ndtri(np.maximum(np.asarray(u), np.finfo(float).tiny))

    def salib(self, tolerance: float) -> tuple[str, list[float]]:
        return "norm", [0.0, tolerance]


#: every distribution a tolerance file may name
DISTRIBUTIONS: dict[str, Distribution] = {d.name: d for d in (Uniform(), Normal())}


def distribution(name: str, where: str = "distribution") -> Distribution:
    """The distribution called ``name``.

    Parameters
    ----------
    name : str
        A key of :data:`DISTRIBUTIONS`.
    where : str
        What to name in the error (file and key).

    Returns
    -------
    Distribution
        The distribution.

    Raises
    ------
    InputError
        If no distribution has that name.
    """
    try:
        return DISTRIBUTIONS[name]
    except (KeyError, TypeError):
        raise InputError(f"{where}: unknown distribution {name!r} (use {', '.join(DISTRIBUTIONS)})") from None
