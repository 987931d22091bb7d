"""Foundations every layer stands on: the product's errors (:class:`VolerrError` and its kinds),
units and their conversions (:data:`LENGTH`, :func:`scale`, :func:`within` ...), the checks of
values a user gives (:func:`positive`, :func:`real_array` ...), and files written as databases
write them (:func:`transaction`, :func:`write_text`, :func:`check_outputs`, :func:`read_text`)."""

from ._checks import (counts, feed_rate, fraction, integer, measurement_sigma, one_point, positive, real_array, sensible,
                      whole_numbers)
from ._errors import InputError, SpecError, URDFError, VolerrError
from ._exports import lazy_exports
from ._safeio import (COMMIT_CHECKS, Transaction, check_output_folder, check_outputs, read_json, read_text, replacing,
                      require_memory, same_file, transaction, write_text)
from ._units import (ANGLE, ARCSEC, ARCSEC_PER_RAD, AXIS_UNIT, DEG, INCH, LENGTH, MM, PLAUSIBLE, TEMPERATURE,
                     TEMPERATURE_LIKE, TIME, UM, UM_PER_M, URAD_PER_RAD, axis_scale, axis_scales, axis_values_to_si,
                     describe_range, parse_axis_values, parse_number, scale, shown, split_key, within)

__all__ = ["ANGLE", "COMMIT_CHECKS", "ARCSEC", "ARCSEC_PER_RAD", "axis_scale", "axis_scales", "AXIS_UNIT",
           "axis_values_to_si", "check_output_folder", "check_outputs", "counts", "DEG", "describe_range", "feed_rate", "fraction",
           "INCH", "InputError", "integer", "lazy_exports", "LENGTH", "measurement_sigma", "MM", "one_point",
           "parse_axis_values", "parse_number", "PLAUSIBLE", "positive", "read_json", "read_text", "real_array",
           "replacing", "require_memory", "same_file", "scale", "sensible", "shown", "SpecError", "split_key",
           "TEMPERATURE", "TEMPERATURE_LIKE", "TIME", "Transaction", "transaction", "UM", "UM_PER_M", "URAD_PER_RAD",
           "URDFError", "VolerrError", "whole_numbers", "within", "write_text"]
