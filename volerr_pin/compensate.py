"""Point and path compensation under the name of earlier releases: the names now live in
:mod:`volerr_pin.compensation` (points in :mod:`volerr_pin.compensation.points`); importing
them from here still works for one release and warns."""

import warnings

from .compensation.arcs import ARC_QUARTER_BYTES, Arc, arc_from_center
from .compensation.path import MAX_DEPTH, PathCompensation, PathCompensator, Piece
from .compensation.points import (COMPENSATION_BYTES, PointCompensation, compensate_points, evaluate_compensation,
                                  has_rotary, skew, solve_damped)

__all__ = ["ARC_QUARTER_BYTES", "Arc", "COMPENSATION_BYTES", "MAX_DEPTH", "PathCompensation", "PathCompensator",
           "Piece", "PointCompensation", "arc_from_center", "compensate_points", "evaluate_compensation", "has_rotary",
           "skew", "solve_damped"]

warnings.warn("volerr_pin.compensate is volerr_pin.compensation now; the old name goes in the next release",
              DeprecationWarning, stacklevel=2)
