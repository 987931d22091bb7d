"""Checks of the numbers callers pass in, shared by the library: each converts a value once, at
the boundary, or raises an :class:`~volerr_pin.base.InputError` naming the parameter (the
command line says it as its option)."""

from __future__ import annotations

import math

import numpy as np

from ._errors import InputError
from ._units import within

__all__ = ["counts", "feed_rate", "fraction", "integer", "one_point", "positive", "measurement_sigma", "real_array", "sensible",
           "whole_numbers"]


def measurement_sigma(name: str, value) -> float:
    """A standard uncertainty of measured values, ``sigma_um`` or ``sigma_urad``: positive,
    finite and within what a deviation may be (1 m, 1 rad).

    Parameters
    ----------
    name : str
        ``"sigma_um"`` or ``"sigma_urad"`` (its unit is read from the name).
    value : object
        The value given, in that unit.

    Returns
    -------
    float
        The number, in the unit given.

    Raises
    ------
    InputError
        Naming ``name``.
    """
    number = positive(name, value)
    limit = "error_angle" if name.endswith("_urad") else "error_length"
    sensible(name, number * 1e-6, limit, name.rpartition("_")[2], 1e-6)
    return number


def sensible(name: str, values, limit: str, unit: str, unit_scale: float = 1.0) -> np.ndarray:
    """SI values refused unless finite and within the plausibility limit a spec's value of the
    same kind has (:data:`volerr_pin.base.PLAUSIBLE`).

    Parameters
    ----------
    name : str
        The parameter's name, for the message (the command line says its option).
    values : array_like
        The values, SI.
    limit : str
        A key of :data:`~volerr_pin.base.PLAUSIBLE` ("error_length", "position_length", ...).
    unit : str
        The unit the caller gave the values in, for the message.
    unit_scale : float, default 1.0
        SI value of one such unit.

    Returns
    -------
    ndarray
        The values as floats.

    Raises
    ------
    InputError
        Naming ``name``, the first value beyond the limit (or not a number) and the limit in
        ``unit`` (:func:`~volerr_pin.base.within`).
    """
    return within(values, limit, name, unit, unit_scale, error=InputError, parameters=(name,))


def _number(name: str, value, what: str) -> float:
    """``value`` as a float, or an :class:`InputError` ``NAME must be WHAT, got VALUE``."""
    try:
        return float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be {what}, got {value!r}", parameters=(name,)) from None


def feed_rate(name: str, value) -> float:
    """A feed rate in mm/min for a program the product writes: a number within what a feed may
    be (:data:`~volerr_pin.base.PLAUSIBLE`: 0.001 mm/min to 1000 m/min).

    Parameters
    ----------
    name : str
        The parameter's name, for the message.
    value : object
        The value given [mm/min].

    Returns
    -------
    float
        The number [mm/min].

    Raises
    ------
    InputError
        Naming ``name``.
    """
    number = _number(name, value, "a feed rate in mm/min")
    sensible(name, [number / 60e3], "feed", "mm/min", 1.0 / 60e3)
    return number


def positive(name: str, value) -> float:
    """``value`` as a float, refused unless it is a positive, finite number.

    Parameters
    ----------
    name : str
        The parameter's name, for the message.
    value : object
        The value given.

    Returns
    -------
    float
        The number.

    Raises
    ------
    InputError
        Naming ``name``.
    """
    number = _number(name, value, "a positive number")
    if not (number > 0 and math.isfinite(number)):
        raise InputError(f"{name} must be positive and finite, got {value}", parameters=(name,))
    return number


def integer(name: str, value, minimum: int, *, also: tuple[int, ...] = (), what: str = "") -> int:
    """``value`` as an int, refused unless it is a whole number >= ``minimum`` (or one of ``also``).

    Parameters
    ----------
    name : str
        The parameter's name, for the message.
    value : object
        The value given (``3.0`` is 3; ``3.5`` is refused, not truncated).
    minimum : int
        The smallest value allowed.
    also : tuple of int, optional
        Values allowed below ``minimum`` (e.g. 0 for "none").
    what : str, optional
        What the allowed values mean, appended to the message.

    Returns
    -------
    int
        The number.

    Raises
    ------
    InputError
        Naming ``name``.
    """
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if not (math.isfinite(number) and number == int(number)):
        raise InputError(f"{name} must be a whole number, got {value!r}", parameters=(name,))
    number = int(number)
    if number < minimum and number not in also:
        allowed = " or ".join([str(a) for a in also] + [f">= {minimum}"])
        raise InputError(f"{name} must be {allowed}{what}, got {number}", parameters=(name,))
    return number


def fraction(name: str, value, what: str = "") -> float:
    """``value`` as a float strictly between 0 and 1.

    Parameters
    ----------
    name : str
        The parameter's name, for the message.
    value : object
        The value given.
    what : str, optional
        Appended to the message.

    Returns
    -------
    float
        The fraction.

    Raises
    ------
    InputError
        Naming ``name``.
    """
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if not 0.0 < number < 1.0:
        raise InputError(f"{name} must be a fraction between 0 and 1 (both excluded){what}, got {value!r}",
                         parameters=(name,))
    return number


def whole_numbers(name: str, values, minimum: int) -> np.ndarray:
    """``values`` (a number or a sequence) as whole numbers >= ``minimum``; others are refused,
    not truncated.

    Parameters
    ----------
    name : str
        The parameter's name, for the message.
    values : number or sequence of numbers
        The values given.
    minimum : int
        The smallest value allowed.

    Returns
    -------
    ndarray of int64
        The numbers, in the shape given (0-d for one number).

    Raises
    ------
    InputError
        Naming ``name``.
    """
    try:
        numbers = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        numbers = np.array([np.nan])
    if numbers.ndim > 1 or numbers.size == 0 or not np.all(np.isfinite(numbers) & (numbers == np.round(numbers))
                                                           & (numbers >= minimum)):
        what = "a whole number" if np.ndim(values) == 0 else "whole numbers"
        raise InputError(f"{name} must be {what} >= {minimum}, got {values!r}", parameters=(name,))
    return numbers.astype(np.int64)


def counts(name: str, values, minimum: int, n: int = 3) -> tuple[int, ...]:
    """Exactly ``n`` whole numbers >= ``minimum``.

    Parameters
    ----------
    name : str
        The parameter's name, for the message.
    values : sequence of numbers
        The values given.
    minimum : int
        The smallest value allowed.
    n : int, default 3
        How many values there must be.

    Returns
    -------
    tuple of int
        The ``n`` numbers.

    Raises
    ------
    InputError
        Naming ``name``.
    """
    try:
        numbers = whole_numbers(name, values, minimum)
    except InputError:
        numbers = None
    if numbers is None or numbers.ndim != 1 or numbers.size != n:
        shown = tuple(values) if isinstance(values, (list, tuple, np.ndarray)) else values
        raise InputError(f"{name} must be {n} whole numbers >= {minimum}, got {shown!r}", parameters=(name,))
    return tuple(int(c) for c in numbers)


def real_array(value, name: str, parameter: str) -> np.ndarray:
    """``value`` as a new float array, refused unless it holds real numbers (text, ragged rows and
    complex values are refused: numpy would drop the imaginary part).

    Parameters
    ----------
    value : array_like
        The value given.
    name : str
        What it is, for the message (``"q (shape (N, 3))"``).
    parameter : str
        The parameter's name.

    Returns
    -------
    ndarray of float
        A new array.

    Raises
    ------
    InputError
        Naming ``parameter``.
    """
    try:
        raw = np.asarray(value)
        complex_ = np.iscomplexobj(raw)
        array = None if complex_ else np.array(raw, dtype=float)
    except (TypeError, ValueError) as err:
        raise InputError(f"{name} must be real numbers: {err}", parameters=(parameter,)) from None
    if complex_:
        raise InputError(f"{name} must be real numbers, got complex values", parameters=(parameter,))
    return array


def one_point(q) -> bool:
    """Whether NC positions are one point (one dimension) rather than rows of points; ragged
    input is left to the machine's check of ``q``.

    Parameters
    ----------
    q : array_like
        NC positions.

    Returns
    -------
    bool
        True for one point.
    """
    try:
        return np.ndim(q) == 1
    except ValueError:
        return False
