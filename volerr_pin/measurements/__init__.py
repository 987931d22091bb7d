"""Measurements: one module per kind of instrument, one shared table reader, and
:func:`read_any` above them.

- :mod:`~volerr_pin.measurements.table`: the comma-separated table every file is read as,
  with its header-comment metadata (file, line and column in every error);
- :mod:`~volerr_pin.measurements.columns`: positions and covariate columns several kinds share;
- :mod:`~volerr_pin.measurements.protocol`: what a measurement is (it turns itself into
  observations: rows, weights, nuisance terms, poses) and what a kind of file is;
- the kinds: :mod:`~volerr_pin.measurements.points` (deviations point by point),
  :mod:`~volerr_pin.measurements.runs` (positioning and component runs along one axis, ISO
  230-2), :mod:`~volerr_pin.measurements.tracker` (laser-tracker target coordinates),
  :mod:`~volerr_pin.measurements.ballbar` (circular tests, ISO 230-4), and
  :mod:`~volerr_pin.measurements.series` (sensor time series for thermal models: read, not
  observations of the machine);
- :mod:`~volerr_pin.measurements.registry`: the kinds :func:`read_any` tells apart by the header.

Every layout, column and unit: docs/measurements.md.
"""

from .ballbar import BallbarRun, check_circle, evaluate_circular, is_ballbar_file, read_ballbar
from .columns import DEVIATION_UNITS, DEVIATIONS, header_columns, positions_and_covariates
from .points import PointMeasurements, read_points
from .protocol import Measurement, MeasurementKind, NuisanceTerm, ObservationBlock, ObservationOptions
from .registry import KINDS, read_any, register_kind
from .runs import MAX_CYCLE, Runs, is_run_file, read_runs, run_table
from .series import SeriesData, read_series
from .table import DIRECTION_WORDS, MeasurementError, Table, axis_values, read_table
from .tracker import TrackerMeasurements, is_tracker_file, read_tracker

__all__ = ["DEVIATIONS", "DEVIATION_UNITS", "DIRECTION_WORDS", "KINDS", "MAX_CYCLE", "BallbarRun", "Measurement",
           "MeasurementError", "MeasurementKind", "NuisanceTerm", "ObservationBlock", "ObservationOptions",
           "PointMeasurements", "Runs", "SeriesData", "Table", "TrackerMeasurements", "axis_values", "check_circle",
           "evaluate_circular", "header_columns", "is_ballbar_file", "is_run_file", "is_tracker_file",
           "positions_and_covariates", "read_any", "read_ballbar", "read_points", "read_runs", "read_series",
           "read_table", "read_tracker", "register_kind", "run_table"]
