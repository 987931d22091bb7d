"""The programming modes by name: how the coordinates of a program are read (each mode a
subclass of :class:`~volerr_pin.compensation.Programming`)."""

from __future__ import annotations

from ..base import InputError
from ..model import Machine
from ._axes_mode import AxisProgramming
from ._programming import Programming
from ._tool_tip import ToolTipProgramming

__all__ = ["PROGRAMMINGS", "programming_for"]


#: the programming modes by name
PROGRAMMINGS: dict = {AxisProgramming.name: AxisProgramming, ToolTipProgramming.name: ToolTipProgramming}


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
    kind = PROGRAMMINGS.get(name)
    if kind is None:
        raise InputError(f"programming must be one of {', '.join(sorted(PROGRAMMINGS))}, got {name!r}",
                         parameters=("programming",))
    return kind(machine)
