"""Compensation: points, paths and the programming modes of NC programs.

Point compensation (seed 002's recursion and Newton) is :mod:`.points`. Modules:
:mod:`.arcs` (desired arcs, circles through compensated points), :mod:`.programming`
(program coordinates to axis positions: :mod:`.axes_mode`, :mod:`.tool_tip`),
:mod:`.solver` (the residual measure and the batch solver of compensated points),
:mod:`.smoothness` (the bounds that size the sampling), :mod:`.moves` (batches of moves and
pieces), :mod:`.lines` and :mod:`.splitter` (splitting straight moves and arcs), :mod:`.path`
(:class:`PathCompensator`).
"""

from importlib import import_module as _import_module

#: names imported from their module when first used (PEP 562): these load the machine model
#: (Pinocchio, SciPy, Numba), which the command line's parser, reading only the controllers'
#: names from :mod:`.export`, would otherwise pay for at every start
_LAZY = {"Arc": ".arcs", "arc_from_center": ".arcs", "ARC": ".moves", "LINE": ".moves", "POINT": ".moves",
         "MoveBatch": ".moves", "PieceSet": ".moves", "BatchResult": ".path", "PathCompensation": ".path",
         "PathCompensator": ".path", "Piece": ".path", "PointCompensation": ".points",
         "compensate_points": ".points", "evaluate_compensation": ".points", "PROGRAMMINGS": ".programming",
         "Programming": ".programming", "programming_for": ".programming"}

__all__ = ["ARC", "Arc", "BatchResult", "LINE", "MoveBatch", "POINT", "PROGRAMMINGS", "PathCompensation",
           "PathCompensator", "Piece", "PieceSet", "PointCompensation", "Programming", "arc_from_center",
           "compensate_points", "evaluate_compensation", "programming_for"]


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(_import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
