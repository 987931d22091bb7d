"""Plan a measurement campaign: which poses identify what matters, in the least machine time.

Parts, private modules: the few extra measurements that separate what a diagnosis could not
tell apart (:func:`after_diagnosis`); :func:`plan` (choose, predict, compare); predicted and
simulated uncertainties; the NC program that visits the poses and its time (:func:`nc_program`,
:func:`time_estimate`, for instruments that measure at stops); the weighted design of candidate
units and the D-optimal choice; the instruments by name (:data:`INSTRUMENTS`,
:func:`instrument`, :func:`register_instrument`), one module per instrument (tracker, probe,
interferometer, ballbar); candidate poses (Sobol', grid, random); :class:`Instrument` and
:class:`Setup`.
"""

from ._campaign import Plan, free_coefficients, make_setup, plan, visiting_order
from ._protocol import Instrument, Setup
from ._registry import INSTRUMENTS, instrument, register_instrument
from ._after import after_diagnosis
from ._ballbar import Ballbar
from ._interferometer import Interferometer
from ._nc import StopsProgram, check_axes, nc_program, time_estimate
from ._probe import Probe
from ._tracker import Tracker

__all__ = ["Ballbar", "Interferometer", "Probe", "StopsProgram", "Tracker", "after_diagnosis", "check_axes",
           "free_coefficients", "Instrument", "instrument", "INSTRUMENTS", "make_setup", "nc_program", "Plan", "plan",
           "register_instrument", "Setup", "time_estimate", "visiting_order"]
