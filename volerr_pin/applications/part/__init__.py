"""The part a program cuts: the tool's deviation from the programmed path, and the features a
CMM reports of it, with the error sources that decide each (:func:`predict`).

The path is read by the NC reader ``compensate`` uses (:func:`volerr_pin.compensation.gcode.interpret`:
every mode it follows, every refusal it makes), once, as one batch of moves, and sampled along
each cutting move (lines and arcs; rapids cut nothing). At each sample the model gives the
tool point's error ``e`` (actual minus nominal, in the workpiece frame). What the cut surface
keeps is the part of ``e`` normal to the path: the part along the path only shifts when the
tool passes, so

    d = e - (e . t) t,

with ``t`` the unit tangent of the nominal tool path. Where the tool point does not move (a
rotary axis turning about it) there is no path direction, and the whole error is kept.

The samples are refined until the deviation, interpolated linearly between neighbours, is
within ``tolerance`` of the model at every midpoint (a stated sampling tolerance, checked, not
assumed).

The path sets what the machine's state cannot: for a machine whose errors depend on the axes'
directions (backlash), each axis' direction at each sample is the sign of its commanded motion
into the sample, kept while the axis stands still, rapids included, as a controller takes it;
the state's ``directions`` only say how the axes arrived before the program.

The work is split by concern, each in a private module of this package:

- the program's cutting moves on the machine (:class:`CuttingPath`: positions, tool points,
  errors, the axes' directions);
- the deviation along the path (:func:`deviation_along`) and the cut sampled evenly
  (:func:`cut_of`);
- circles, sides and pairs as a CMM reports them, with least-squares circles and lines
  (:func:`fit_circle`, :func:`fit_line`, :func:`measure_round`);
- finding them in a program and measuring them on the cut (:func:`measure`,
  :func:`contour_plane`); the cone frustum of NAS 979 a five-axis machine cuts with the tool's
  flank (:func:`find_cones`, :func:`measure_cones`) and its test piece
  (:func:`cone_frustum_test_piece`);
- the error sources of a feature (:func:`feature_ranking`);
- the contouring test piece (:func:`contouring_test_piece`);
- the prediction that ties them (:func:`predict`, :class:`PartPrediction`).

Conventions: positions in m, deviations in um in the reports; programs in axes or tool-tip
programming, as ``compensate`` reads them.
"""

from ._cmm import RoundFeature, fit_circle, fit_line, measure_round
from ._cone import Cone, ConeSection, cone_frustum_test_piece, find_cones, measure_cones, section_heights
from ._features import CircleFeature, LineFeature, PairFeature, blocks_text
from ._measure import Features, contour_plane, measure
from ._path import CuttingPath, normal_part
from ._predict import NOT_PREDICTED_SHARE, PartPrediction, predict
from ._ranking import feature_ranking
from ._sampling import Cut, PathDeviation, cut_of, deviation_along
from ._testpiece import SMALLEST_SIDE, contouring_test_piece

__all__ = ["predict", "PartPrediction", "NOT_PREDICTED_SHARE", "blocks_text", "CuttingPath", "normal_part", "deviation_along", "PathDeviation",
           "cut_of", "Cut", "measure", "Features", "contour_plane", "CircleFeature", "LineFeature", "PairFeature",
           "feature_ranking", "fit_circle", "fit_line", "RoundFeature", "measure_round", "find_cones", "measure_cones",
           "Cone", "ConeSection", "section_heights", "cone_frustum_test_piece", "contouring_test_piece",
           "SMALLEST_SIDE"]
