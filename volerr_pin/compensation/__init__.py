"""Compensation: points, paths and the programming modes of NC programs.

Point compensation (seed 002's recursion and Newton) is :mod:`.points`. Modules:
:mod:`.arcs` (desired arcs, circles through compensated points), :mod:`.programming`
(program coordinates to axis positions: :mod:`.axes_mode`, :mod:`.tool_tip`),
:mod:`.solver` (the residual measure and the batch solver of compensated points),
:mod:`.smoothness` (the bounds that size the sampling), :mod:`.moves` (batches of moves and
pieces), :mod:`.lines` and :mod:`.splitter` (splitting straight moves and arcs), :mod:`.path`
(:class:`PathCompensator`).
"""

from ..base import lazy_exports

#: names imported from their module when first used (PEP 562): these load the machine model
#: (Pinocchio, SciPy, Numba), which the command line's parser, reading only the controllers'
#: names from :mod:`.export`, would otherwise pay for at every start
_NAMES = {
    "_arcs": ("Arc", "arc_from_center", "RADIUS_SLACK", "arc_extent", "sweep_of", "sweeps"),
    "_moves": ("ARC", "POINT", "MoveBatch", "PieceSet"),
    "_path": ("BatchResult", "PathCompensation", "PathCompensator", "Piece"),
    "_points": ("PointCompensation", "compensate_points", "evaluate_compensation", "MachineInputs"),
    "_programming": ("PROGRAMMINGS", "Programming", "programming_for"),
    "_errormap": ("ErrorMap", "axis_tables", "compensation_table"),
}
__getattr__, __dir__, __all__ = lazy_exports(__name__, _NAMES)
