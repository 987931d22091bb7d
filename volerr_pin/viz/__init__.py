"""Pictures: Rerun recordings (:func:`record_field`, :func:`record_diagnosis` ...) and static matplotlib figures
(:func:`field_slice_png`, :func:`diagnosis_png` ...).

The rest of the library computes without them: modelling, identification, diagnosis and
compensation never import Rerun or matplotlib, so importing them costs nothing until a
picture is asked for; the names below load the part that draws them when first used.
"""

from ..base import lazy_exports

#: part -> the public names it defines
_NAMES = {
    "_export": ("export_png", "record_export"),
    "_plots": ("ballbar_png", "compensation_png", "diagnosis_png", "field_slice_png", "gear_png", "iso230_png",
               "part_png", "picture_format", "ranking_png", "save", "thermal_fit_png"),
    "_recording": ("eye_on", "log_field", "log_machine", "log_time_series", "new_recording", "opened_paused",
                   "record_diagnosis", "record_field", "record_gear", "record_part", "streaming", "whole_range"),
    "_studies": ("max_error_png", "record_uncertainty", "uncertainty_png"),
}
__getattr__, __dir__, __all__ = lazy_exports(__name__, _NAMES)
