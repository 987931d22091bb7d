"""Foundations every layer stands on: the product's errors (:mod:`~volerr_pin.base.errors`), units and their
conversions (:mod:`~volerr_pin.base.units`), checks of values a user gives (:mod:`~volerr_pin.base.checks`), and files written
as databases write them (:mod:`~volerr_pin.base.safeio`)."""
