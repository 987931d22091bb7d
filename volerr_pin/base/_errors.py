"""Exceptions of volerr_pin.

Every exception raised for bad user input is a :class:`VolerrError` and, where the
input itself was wrong, also a :class:`ValueError`, so callers can catch either.
Messages name the culprit: file and line, the spec key, the parameter or the array.
Errors about a function's parameters name them as Python spells them (``holdout``,
``pass_through``) and list them in :attr:`VolerrError.parameters`, so an interface built on
the library (the ``volerr`` command line) can say them in its own words (``--holdout``).
"""

from __future__ import annotations


class VolerrError(Exception):
    """Base class of all errors raised by volerr_pin.

    Parameters
    ----------
    message : str
        What is wrong and where.
    parameters : tuple of str, optional
        Names of the function parameters (or API names such as ``Machine.with_state``) the
        message mentions, spelled as in the message; the first mention of each is the
        parameter.
    """

    def __init__(self, message: str = "", *, parameters: tuple[str, ...] = ()):
        super().__init__(message)
        self.parameters = tuple(parameters)


class SpecError(VolerrError, ValueError):
    """A machine description (error spec or its references) is invalid."""


class URDFError(SpecError):
    """A URDF file is malformed or does not describe a usable machine."""


class InputError(VolerrError, ValueError):
    """An argument of a public function is invalid (shape, NaN, out of travel...)."""
