"""Fitting the model to measurements: identification (:mod:`~volerr_pin.fit.identify`), what the data can
tell apart (:func:`analyse`, :func:`tool_identifiability`), which error sources matter
(:func:`rank`), and the diagnosis of what the model misses (:mod:`~volerr_pin.fit.diagnosis`)."""

from ._identifiability import Analysis, analyse
from ._ranking import rank, read_tolerances, tolerance_key, tool_identifiability

__all__ = ["analyse", "Analysis", "rank", "read_tolerances", "tolerance_key", "tool_identifiability"]
