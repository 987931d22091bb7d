"""Compensation: points, paths and the programming modes of NC programs.

Point compensation (seed 002's recursion and Newton) is :mod:`.points`. Modules:
:mod:`.arcs` (desired arcs, circles through compensated points), :mod:`.programming`
(program coordinates to axis positions: :mod:`.axes_mode`, :mod:`.tool_tip`),
:mod:`.solver` (the residual measure and the batch solver of compensated points),
:mod:`.smoothness` (the bounds that size the sampling), :mod:`.moves` (batches of moves and
pieces), :mod:`.lines` and :mod:`.splitter` (splitting straight moves and arcs), :mod:`.path`
(:class:`PathCompensator`).
"""

from .arcs import Arc, arc_from_center
from .moves import ARC, LINE, POINT, MoveBatch, PieceSet
from .path import BatchResult, PathCompensation, PathCompensator, Piece
from .points import PointCompensation, compensate_points, evaluate_compensation
from .programming import PROGRAMMINGS, Programming, programming_for

__all__ = ["ARC", "Arc", "BatchResult", "LINE", "MoveBatch", "POINT", "PROGRAMMINGS", "PathCompensation",
           "PathCompensator", "Piece", "PieceSet", "PointCompensation", "Programming", "arc_from_center",
           "compensate_points", "evaluate_compensation", "programming_for"]
