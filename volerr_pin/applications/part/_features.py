"""The features of a part as a CMM reports them: a full circle (roundness, diameter and centre,
ISO 12181-1), a straight side (straightness, ISO 12780) and a pair of sides (squareness or
parallelism, ISO 1101); and, for ranking the error sources, the profile each source gives a
feature to first order (the profile the feature's value is the range of).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._cmm import RoundFeature

__all__ = ["blocks_text", "CircleFeature", "LineFeature", "PairFeature"]


def blocks_text(blocks: list[int]) -> str:
    """A feature's block lines for a table: all of up to four, else the first and the last.

    Parameters
    ----------
    blocks : list of int
        The line numbers of the feature's blocks, in order.

    Returns
    -------
    str
        ``"12,14,16"``, or ``"12..40"`` for more than four.
    """
    return ",".join(map(str, blocks)) if len(blocks) <= 4 else f"{blocks[0]}..{blocks[-1]}"


def _without(values: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """``values`` less their least-squares fit on the columns of ``basis``."""
    coefficients, *_ = np.linalg.lstsq(basis, values, rcond=None)
    return values - basis @ coefficients


@dataclass(frozen=True, kw_only=True)
class CircleFeature(RoundFeature):
    """A full circle of the program, as a CMM reports it (the fields of
    :class:`~volerr_pin.applications.part.RoundFeature`, in the contour plane, and these).

    Attributes
    ----------
    radius, circularity_um, diameter_error_um, centre_error_um, fitted_centre, angle, radial_um, q, covariates
        As in :class:`~volerr_pin.applications.part.RoundFeature`, in the contour plane.
    lines : tuple of int
        The blocks it comes from (of the reference program, when one is given).
    plane : tuple of int
        The workpiece-frame coordinates of its plane (0, 1: xy).
    centre : ndarray, shape (2,)
        Nominal centre in the plane [m].
    """

    lines: tuple[int, ...]
    plane: tuple[int, int]
    centre: np.ndarray

    def to_dict(self) -> dict:
        """The feature in the report's terms (ISO name, um).

        Returns
        -------
        dict
            JSON-ready: ``kind`` ("circle"), ``name``, ``blocks``, ``plane`` ("xy" ...),
            ``centre_mm``, ``diameter_mm``, ``circularity_um``, ``diameter_error_um`` and
            ``centre_error_um``.
        """
        return {"kind": "circle", "name": "roundness, diameter and centre of a circle (ISO 12181-1, least squares)",
                "blocks": list(self.lines), "plane": "xyz"[self.plane[0]] + "xyz"[self.plane[1]],
                "centre_mm": (self.centre * 1e3).tolist(), "diameter_mm": 2e3 * self.radius,
                "circularity_um": self.circularity_um, "diameter_error_um": self.diameter_error_um,
                "centre_error_um": self.centre_error_um}

    def profiles(self, parts: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Each source's radial deviation (in-plane errors ``parts`` at the measured points)
        less its least-squares circle, to first order.

        Parameters
        ----------
        parts : dict of str to ndarray, shape (M, 2)
            Per error source (component), its error of the tool point in the plane at the
            measured points [m].

        Returns
        -------
        dict of str to ndarray, shape (M,)
            Per source, in the order of ``parts``, its profile [m].
        """
        radial = np.c_[np.cos(self.angle), np.sin(self.angle)]
        profiles = self.less_circle(np.stack([np.sum(p * radial, axis=1) for p in parts.values()], axis=1))
        return dict(zip(parts, profiles.T))


@dataclass(frozen=True)
class LineFeature:
    """A straight side of the program (a cutting line in the contour plane), as a CMM reports it.

    Attributes
    ----------
    lines : tuple of int
        The block it comes from (of the reference program, when one is given).
    plane : tuple of int
        The workpiece-frame coordinates of the contour plane.
    start, end : ndarray, shape (2,)
        Nominal ends in the plane [m].
    straightness_um : float
        ISO 12780: the range of the side's deviation about its least-squares line [um].
    contour : int
        Index of the contour (a run of cutting moves between rapids) it belongs to.
    measured : ndarray, shape (M, 2)
        The measured points in the plane [m].
    q : ndarray, shape (M, n_axes)
        Their axis positions [m, rad].
    covariates : dict
        Their covariates the path sets (the axes' directions, for a machine that reads them).
    """

    lines: tuple[int, ...]
    plane: tuple[int, int]
    start: np.ndarray
    end: np.ndarray
    straightness_um: float
    contour: int
    measured: np.ndarray
    q: np.ndarray
    covariates: dict = field(default_factory=dict)

    @property
    def length(self) -> float:
        """Nominal length of the side [m]."""
        return float(np.linalg.norm(self.end - self.start))

    @property
    def direction(self) -> np.ndarray:
        """Unit direction from the nominal start to the end, shape (2,), in the plane."""
        return (self.end - self.start) / self.length

    @property
    def across(self) -> np.ndarray:
        """Unit normal of the side in the plane, :attr:`direction` turned +90 degrees, shape (2,)."""
        return np.array([-self.direction[1], self.direction[0]])

    def along(self) -> np.ndarray:
        """Each measured point's distance from the nominal start along the side [m].

        Returns
        -------
        ndarray, shape (M,)
            The measured points' coordinates along :attr:`direction` from :attr:`start` [m].
        """
        return (self.measured - self.start) @ self.direction

    def to_dict(self) -> dict:
        """The feature in the report's terms (ISO name, um).

        Returns
        -------
        dict
            JSON-ready: ``kind`` ("straightness"), ``name``, ``blocks``, ``plane``, ``start_mm``,
            ``end_mm``, ``length_mm`` and ``straightness_um``.
        """
        return {"kind": "straightness", "name": "straightness of a side (ISO 12780, least squares)",
                "blocks": list(self.lines), "plane": "xyz"[self.plane[0]] + "xyz"[self.plane[1]],
                "start_mm": (self.start * 1e3).tolist(), "end_mm": (self.end * 1e3).tolist(),
                "length_mm": self.length * 1e3, "straightness_um": self.straightness_um}

    def profiles(self, parts: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Each source's deviation across the side less its least-squares line, to first order.

        Parameters
        ----------
        parts : dict of str to ndarray, shape (M, 2)
            Per error source (component), its error of the tool point in the plane at the
            measured points [m].

        Returns
        -------
        dict of str to ndarray, shape (M,)
            Per source, in the order of ``parts``, its profile [m].
        """
        along = self.along()
        basis = np.c_[np.ones_like(along), along]
        return dict(zip(parts, _without(np.stack([p @ self.across for p in parts.values()], axis=1), basis).T))


@dataclass(frozen=True)
class PairFeature:
    """Squareness or parallelism of one side to another of the same contour (ISO 1101).

    The datum is the first side's least-squares line; the value is the width of the zone,
    perpendicular to (squareness) or parallel to (parallelism) the datum, that holds every
    measured point of the second side [um].

    Attributes
    ----------
    kind : str
        "squareness" or "parallelism".
    datum, toleranced : LineFeature
        The two sides.
    value_um : float
        The zone's width [um].
    """

    kind: str
    datum: LineFeature
    toleranced: LineFeature
    value_um: float

    @property
    def lines(self) -> tuple[int, ...]:
        """The blocks of the two sides, the datum's first."""
        return self.datum.lines + self.toleranced.lines

    def to_dict(self) -> dict:
        """The feature in the report's terms (ISO name, um).

        Returns
        -------
        dict
            JSON-ready: ``kind``, ``name``, ``blocks``, ``datum_line`` (the datum side's block)
            and ``<kind>_um`` (the zone's width).
        """
        return {"kind": self.kind, "name": f"{self.kind} of a side to a datum side (ISO 1101)",
                "blocks": list(self.lines), "datum_line": self.datum.lines[0], f"{self.kind}_um": self.value_um}
