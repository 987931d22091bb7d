"""Exceptions of volerr_pin.

Every exception raised for bad user input is a :class:`VolerrError` and, where the
input itself was wrong, also a :class:`ValueError`, so callers can catch either.
Messages name the culprit: file and line, the spec key, the parameter or the array.
"""

from __future__ import annotations


class VolerrError(Exception):
    """Base class of all errors raised by volerr_pin."""


class SpecError(VolerrError, ValueError):
    """A machine description (error spec or its references) is invalid."""


class URDFError(SpecError):
    """A URDF file is malformed or does not describe a usable machine."""


class InputError(VolerrError, ValueError):
    """An argument of a public function is invalid (shape, NaN, out of travel...)."""
