"""Measurements: one private module per kind of instrument, one shared table reader, and
:func:`read_any` above them.

- the comma-separated table every file is read as (:func:`read_table`, :class:`Table`), with
  its header-comment metadata (file, line and column in every error);
- positions and covariate columns several kinds share (:func:`positions_and_covariates`);
- what a measurement is (:class:`Measurement`: it turns itself into observations, an
  :class:`ObservationBlock` of rows, weights, nuisance terms and poses) and what a kind of
  file is (:class:`MeasurementKind`);
- the kinds: deviations point by point (:class:`PointMeasurements`), positioning and component
  runs along one axis, ISO 230-2 (:class:`Runs`), laser-tracker target coordinates
  (:class:`TrackerMeasurements`), circular tests, ISO 230-4 (:class:`BallbarRun`), and sensor
  time series for thermal models (:class:`SeriesData`: read, not observations of the machine);
- the kinds :func:`read_any` tells apart by the header (:data:`KINDS`, :func:`register_kind`);
- simulated campaigns with fixed seeds, for examples and tests (:func:`campaign`,
  :func:`heldout_set`, :func:`tracker_campaign`, :func:`ballbar_run`).

Every layout, column and unit: docs/measurements.md.
"""

from ._ballbar import BallbarRun, check_circle, evaluate_circular, is_ballbar_file, radial_about, read_ballbar
from ._columns import DEVIATION_UNITS, DEVIATIONS, header_columns, positions_and_covariates
from ._points import PointMeasurements, read_points
from ._protocol import Measurement, MeasurementKind, NuisanceTerm, ObservationBlock, ObservationOptions
from ._registry import KINDS, read_any, register_kind
from ._runs import MAX_CYCLE, Runs, is_run_file, read_runs, run_table
from ._series import SeriesData, read_series
from ._table import DIRECTION_WORDS, MeasurementError, Table, axis_values, read_table
from ._tracker import TrackerMeasurements, is_tracker_file, read_tracker, register
from ._simulate import (ballbar_run, campaign, heldout_set, off_model_geometry, tracker_campaign, write_ballbar,
                        write_points, write_tracker)

__all__ = ["axis_values", "ballbar_run", "BallbarRun", "campaign", "check_circle", "DEVIATION_UNITS", "DEVIATIONS",
           "DIRECTION_WORDS", "evaluate_circular", "header_columns", "heldout_set", "is_ballbar_file", "is_run_file",
           "is_tracker_file", "KINDS", "MAX_CYCLE", "Measurement", "MeasurementError", "MeasurementKind",
           "NuisanceTerm", "ObservationBlock", "ObservationOptions", "off_model_geometry", "PointMeasurements",
           "positions_and_covariates", "radial_about", "read_any", "read_points", "read_ballbar", "read_runs",
           "read_series", "read_table", "read_tracker", "register", "register_kind", "run_table", "Runs", "SeriesData",
           "Table", "tracker_campaign", "TrackerMeasurements", "write_ballbar", "write_points", "write_tracker"]
