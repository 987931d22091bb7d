"""The instruments :func:`volerr_pin.studies.plan.plan` knows, by name."""

from __future__ import annotations

from ...base import InputError
from ._ballbar import BALLBAR
from ._interferometer import INTERFEROMETER
from ._probe import PROBE
from ._protocol import Instrument
from ._tracker import TRACKER

__all__ = ["INSTRUMENTS", "instrument", "register_instrument"]

#: instrument name -> instrument
INSTRUMENTS: dict[str, Instrument] = {TRACKER.name: TRACKER, INTERFEROMETER.name: INTERFEROMETER, PROBE.name: PROBE,
                                      BALLBAR.name: BALLBAR}


def register_instrument(kind: Instrument) -> None:
    """Make an instrument known by its name.

    Parameters
    ----------
    kind : Instrument
        The instrument (see :class:`~volerr_pin.studies.plan.Instrument`).

    Raises
    ------
    InputError
        If it does not follow the protocol or its name is taken.
    """
    if not isinstance(kind, Instrument):
        raise InputError(f"{kind!r} is not an instrument (see volerr_pin.studies.plan.Instrument)")
    if kind.name in INSTRUMENTS:
        raise InputError(f"an instrument named {kind.name!r} is registered already", parameters=("instrument",))
    INSTRUMENTS[kind.name] = kind


def instrument(name: str) -> Instrument:
    """The instrument called ``name``.

    Parameters
    ----------
    name : str
        Its name ("tracker", "interferometer", "probe", "ballbar").

    Returns
    -------
    Instrument
        The instrument.

    Raises
    ------
    InputError
        If no instrument has that name.
    """
    if name not in INSTRUMENTS:
        raise InputError(f"instrument {name!r} is not known; known: {', '.join(sorted(INSTRUMENTS))}",
                         parameters=("instrument",))
    return INSTRUMENTS[name]
