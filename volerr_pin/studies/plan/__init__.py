"""Plan a measurement campaign: which poses identify what matters, in the least machine time.

Parts, each importing only those listed after it:

- :mod:`~volerr_pin.studies.plan.after`: the few extra measurements that separate what a diagnosis
  could not tell apart;
- :mod:`~volerr_pin.studies.plan.campaign`: :func:`plan` (choose, predict, compare);
- :mod:`~volerr_pin.studies.plan.assess`: predicted and simulated uncertainties;
- :mod:`~volerr_pin.studies.plan.nc`: the NC program that visits the poses, and its time
  (:class:`~volerr_pin.studies.plan.nc.StopsProgram`, for instruments that measure at stops);
- :mod:`~volerr_pin.studies.plan.design`: the weighted design of candidate units, D-optimal choice;
- :mod:`~volerr_pin.studies.plan.registry`: the instruments by name;
- :mod:`~volerr_pin.studies.plan.tracker`, :mod:`~volerr_pin.studies.plan.probe`,
  :mod:`~volerr_pin.studies.plan.interferometer`, :mod:`~volerr_pin.studies.plan.ballbar`: one module per
  instrument;
- :mod:`~volerr_pin.studies.plan.poses`: candidate poses (Sobol', grid, random);
- :mod:`~volerr_pin.studies.plan.protocol`: :class:`Instrument` and :class:`Setup`.
"""

from .campaign import Plan, free_coefficients, make_setup, plan, visiting_order
from .protocol import Instrument, Setup
from .registry import INSTRUMENTS, instrument, register_instrument

__all__ = ["INSTRUMENTS", "Instrument", "Plan", "Setup", "free_coefficients", "instrument", "make_setup", "plan",
           "register_instrument", "visiting_order"]
