"""Compensation tables that controllers load, proven by simulating how each controller
applies them.

``export_tables(machine, "linuxcnc", "comp/")`` lays out the tables a controller holds,
chooses their values by least squares through the model over a working zone, writes the
files the controller loads, reads them back by the controller's own rules, and reports the
error the machine would have left once they are in place (max and RMS), beside the
uncompensated error, tables filled by sampling the component errors at their nodes, and the
model's exact point compensation.

Parts, private modules: the two protocols (:class:`ControllerFormat`, :class:`Compensation`),
the formats by name (:data:`CONTROLLERS`, :func:`controller_format`), the zone and its points
(:class:`Zone`, :func:`parse_zone`), set-point tables, the controller's simulation, the least
squares through the model (:func:`fit`), one export (:func:`export_tables`), and one module per
format.
"""

from ._protocol import Compensation, ControllerFormat
from ._registry import CONTROLLERS, controller_format
from ._run import FIT_POINTS_PER_VALUE, ExportResult, export_tables, layout_files, write_export
from ._zone import Points, Zone, parse_zone
from ._fit import fit
from ._simulate import tool_tips

__all__ = ["Compensation", "controller_format", "ControllerFormat", "CONTROLLERS", "export_tables",
           "ExportResult", "fit", "FIT_POINTS_PER_VALUE", "layout_files",
           "parse_zone", "Points", "tool_tips",
           "write_export", "Zone"]
