"""Compensation tables that controllers load, proven by simulating how each controller
applies them.

``export_tables(machine, "linuxcnc", "comp/")`` lays out the tables a controller holds,
chooses their values by least squares through the model over a working zone, writes the
files the controller loads, reads them back by the controller's own rules, and reports the
error the machine would have left once they are in place (max and RMS), beside the
uncompensated error, tables filled by sampling the component errors at their nodes, and the
model's exact point compensation.

Modules: :mod:`~volerr_pin.compensation.export.protocol` (the two protocols), :mod:`~.registry` (formats
by name), :mod:`~.zone` (zone, points, motion directions), :mod:`~.tables` (set-point
tables), :mod:`~.simulate`, :mod:`~.fit`, :mod:`~.run` (one export), and one module per
format.
"""

from .protocol import Compensation, ControllerFormat
from .registry import CONTROLLERS, controller_format
from .run import ExportResult, export_tables, layout_files, write_export
from .zone import Points, Zone, parse_zone

__all__ = ["CONTROLLERS", "Compensation", "ControllerFormat", "ExportResult", "Points", "Zone", "controller_format",
           "export_tables", "layout_files", "parse_zone", "write_export"]
