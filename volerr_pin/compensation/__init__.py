"""Compensation: points, paths and the programming modes of NC programs.

Points are compensated by seed 002's recursion or by Newton (:func:`compensate_points`,
:func:`evaluate_compensation`); paths by splitting their moves until the compensated path is
within the tolerance (:class:`PathCompensator`), over batches of moves (:class:`MoveBatch`) and
desired arcs (:class:`Arc`). A program's coordinates are read in a programming mode
(:class:`Programming`, found by name with :func:`programming_for`: axis positions or the tool
tip). Error maps and compensation tables: :class:`ErrorMap`, :func:`axis_tables`,
:func:`compensation_table`. NC programs are :mod:`~volerr_pin.compensation.gcode`, controller
tables :mod:`~volerr_pin.compensation.export`.
"""

from ..base import lazy_exports

#: names imported from their module when first used (PEP 562): these load the machine model
#: (Pinocchio, SciPy, Numba), which the command line's parser, reading only the controllers'
#: names from :mod:`.export`, would otherwise pay for at every start
_NAMES = {
    "_arcs": ("Arc", "arc_from_center", "RADIUS_SLACK", "arc_extent", "sweep_of", "sweeps"),
    "_moves": ("ARC", "LINE", "POINT", "MoveBatch", "PieceSet", "Skipped"),
    "_path": ("BatchResult", "PathCompensation", "PathCompensator", "Piece"),
    "_points": ("PointCompensation", "compensate_points", "evaluate_compensation", "MachineInputs"),
    "_modes": ("PROGRAMMINGS", "programming_for"),
    "_programming": ("Programming",),
    "_errormap": ("ErrorMap", "axis_tables", "compensation_table"),
}
__getattr__, __dir__, __all__ = lazy_exports(__name__, _NAMES)
