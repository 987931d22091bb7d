"""The registry of controller formats, by the name the command line and the API use.

A new format is one module with a class following
:class:`~volerr_pin.compensation.export.ControllerFormat` and one line here.
"""

from __future__ import annotations

from ...base import InputError
from ._fanuc import Fanuc
from ._heidenhain import Heidenhain
from ._isg import ISG
from ._linuxcnc import LinuxCNC
from ._protocol import ControllerFormat
from ._siemens import Siemens840D

__all__ = ["CONTROLLERS", "controller_format"]

#: name -> format, in the order help texts list them
CONTROLLERS: dict[str, ControllerFormat] = {f.name: f for f in (LinuxCNC(), ISG(), Siemens840D(), Heidenhain(),
                                                                 Fanuc())}


def controller_format(name: str) -> ControllerFormat:
    """The format registered under ``name``.

    Parameters
    ----------
    name : str
        ``linuxcnc``, ``isg``, ``siemens-840d``, ``heidenhain`` or ``fanuc``.

    Returns
    -------
    ControllerFormat
        The format.

    Raises
    ------
    InputError
        Naming ``controller``, for an unknown name.
    """
    try:
        return CONTROLLERS[name]
    except KeyError:
        raise InputError(f"controller: unknown controller {name!r} (known: {', '.join(CONTROLLERS)})",
                         parameters=("controller",)) from None
