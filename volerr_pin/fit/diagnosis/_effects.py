"""The catalogue of effects a diagnosis looks for, as plug-ins.

Each kind of effect is a class: the candidates it offers (through every site and direction, or
on an axis' own motion), the prefix of its coefficients in a written spec, how its label
reads, and the properties the loop, the report and the CLI ask about - whether its period comes
from a periodogram or from the revolution, whether its accepted terms in one direction make one
finding over time. The loop never asks for an effect by name: it looks the kind up in
:data:`EFFECTS` (:func:`effect_kind`). A new effect is a subclass registered with
:func:`register`; the geometric components (positioning, straightness, angular, squareness,
location) are the model's own and answer with :class:`Geometric`.

Candidates are offered in the registry's order, site by site and axis by axis (the order
decides ties between candidates that explain the residual equally well).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..identify import Observations
from ...model import Model, component_name
from ._results import Candidate

__all__ = ["EFFECTS", "FULL_TURN_GAP", "MIN_PERIODS", "SAMPLED_GAP", "ROTARY_ORDERS", "Backlash", "EffectKind", "ForceDeflection", "Geometric", "Offer",
           "PeriodicPitch", "PeriodicRotary", "ThermalDrift", "ThermalExpansion", "direction_of", "effect_kind",
           "largest_gap", "register", "rotary_orders"]

#: a rotary axis' periodic error is tried with these numbers of periods per revolution
ROTARY_ORDERS = (1, 2, 3, 4, 6, 8)
#: periods of a periodic error inside the measured travel (over part of a turn, for a rotary axis)
MIN_PERIODS = 4
#: a rotary axis' data cover a full turn for an error of period P when no gap between its
#: sampled angles, around the circle, is wider than this share of P: samples at most a quarter
#: period apart (twice Nyquist's rate) pin the error's phase on both sides of every gap, so
#: its closing on itself over the turn is seen
FULL_TURN_GAP = 0.25
#: over part of a turn, no gap between sampled angles inside the measured arc may be wider than
#: this share of the period (Nyquist: a wider gap can hide a whole half-wave)
SAMPLED_GAP = 0.5


def largest_gap(angles: np.ndarray, rank: int = 1) -> float:
    """The widest arc of the circle that holds no sampled angle [rad] (or the ``rank``-th widest).

    The angles are taken around the circle (modulo one turn), so -179.6 and 179.8 deg are 0.6
    deg apart: a turn sampled from -179.6 to 179.8 deg has a gap of 0.6 deg, not 360 - 359.4.

    Parameters
    ----------
    angles : ndarray, shape (N,)
        Sampled angles of a rotary axis [rad].
    rank : int, default 1
        1 for the widest gap, 2 for the next (over part of a turn: the widest inside the
        measured arc), and so on.

    Returns
    -------
    float
        The gap [rad]: 2 pi with no angle (0 when there are fewer gaps than ``rank``); the
        widest is 2 pi less the measured arc over part of a turn.
    """
    a = np.sort(np.mod(np.asarray(angles, dtype=float), 2 * np.pi))
    if a.size == 0:
        return 2 * np.pi if rank == 1 else 0.0
    gaps = np.sort(np.diff(a, append=a[0] + 2 * np.pi))
    return float(gaps[-rank]) if rank <= gaps.size else 0.0


def rotary_orders(angles: np.ndarray) -> tuple[int, ...]:
    """The periods per revolution (of :data:`ROTARY_ORDERS`) a rotary axis' sampled angles
    can tell from its own smooth geometry.

    Over a full turn (no gap wider than :data:`FULL_TURN_GAP` of the period, around the
    circle) an error once per revolution closes on itself, which no smooth function of the
    angle does: it is offered. Over more than a turn every order is (whether it repeats from
    one turn to the next is checked before it is accepted). Otherwise an order needs
    :data:`MIN_PERIODS` periods in the measured arc (the turn less the largest gap, or the span)
    and no gap inside it wider than :data:`SAMPLED_GAP` of the period: over one turn, 2 or 3
    periods are shapes the axis' own off-spec geometry takes as well (smooth shapes through 7
    values over a table's turn were named 2, 3 and 4 times per revolution when every order was
    offered), and eight indexed positions 45 deg apart cannot tell 6 per revolution from 2, nor
    see 8 per revolution at all.

    Parameters
    ----------
    angles : ndarray, shape (N,)
        Sampled angles of the axis [rad].

    Returns
    -------
    tuple of int
        The orders, ascending.
    """
    angles = np.asarray(angles, dtype=float)
    if angles.size == 0:
        return ()
    gap, inside = largest_gap(angles), largest_gap(angles, 2)
    arc = max(float(np.ptp(angles)), 2 * np.pi - gap)

    def seen(n):
        period = 2 * np.pi / n
        if n == 1 and gap <= FULL_TURN_GAP * period:
            return True
        if n > 1 and float(np.ptp(angles)) > 2 * np.pi * (1 + 1e-9) and gap <= FULL_TURN_GAP * period:
            return True   # more than a turn: the repeat from one turn to the next is checked
        return arc >= MIN_PERIODS * period * (1 - 1e-9) and inside <= SAMPLED_GAP * period

    return tuple(n for n in ROTARY_ORDERS if seen(n))


def direction_of(letter: str) -> str:
    """The report's direction of a component letter: "x", "y" or "z" (rotations: about that axis).

    Parameters
    ----------
    letter : str
        "X", "Y", "Z", "A", "B" or "C".

    Returns
    -------
    str
        "x", "y" or "z".
    """
    return letter.lower() if letter in "XYZ" else "xyz"["ABC".index(letter)]


@dataclass(frozen=True)
class Offer:
    """What a round's data let candidates be built on.

    Attributes
    ----------
    model : Model
        The present model.
    obs : Observations
        The observations.
    own : dict of str to str
        The error direction letter of each axis' own motion
        (:func:`~volerr_pin.fit.diagnosis.axis_directions`).
    timed : bool
        The data carry times that vary.
    sensors : list of str
        The temperature sensors whose readings vary.
    force_axes : list of int
        The force components (0, 1, 2 for x, y, z) that vary.
    """

    model: Model
    obs: Observations
    own: dict
    timed: bool
    sensors: list
    force_axes: list

    @classmethod
    def of(cls, model: Model, obs: Observations, own: dict) -> "Offer":
        """The offer of these data.

        Parameters
        ----------
        model : Model
            The present model.
        obs : Observations
            The observations.
        own : dict of str to str
            Each axis' own direction letter.

        Returns
        -------
        Offer
        """
        cov = obs.covariates
        forces = cov.get("forces")
        return cls(model, obs, own, "t" in cov and np.ptp(cov["t"]) > 0,
                   [s for s, v in (cov.get("temperatures") or {}).items() if np.ptp(v) > 0],
                   [i for i in range(3) if forces is not None and np.ptp(forces[:, i]) > 0])

    def reference_degC(self, sensor: str) -> float:
        """A sensor's mean reading, the reference of a term it drives."""
        return float(np.mean(self.obs.covariates["temperatures"][sensor]))

    def reverses(self, j: int) -> bool:
        """Whether axis ``j`` is approached from both sides in the data."""
        directions = self.obs.covariates.get("directions")
        return directions is not None and len(np.unique(directions[:, j])) == 2


class EffectKind:
    """One kind of effect: its candidates, its coefficients' prefix, its label and its properties.

    Attributes
    ----------
    name : str
        Its catalogue name, the ``name`` of its candidates and findings.
    prefix : str or None
        The prefix of its coefficients in a written spec; None for the model's own geometric
        terms (prefix "geom" beside other terms, none on a component of their own).
    periodogram : bool
        Its period is the strongest peak of a periodogram of the residual along the axis, searched
        before the candidate is fitted (a p-value corrected for the periods searched).
    per_revolution : bool
        It repeats a whole number of times per revolution of a rotary axis: its period is given,
        not searched; it must repeat from one turn to the next; once accepted its order is not
        offered again and its period is held at the revolution's from the final fit on.
    over_time : bool
        A drift over the run: its accepted terms in one direction (time and temperature sensors,
        accepted round by round) are one finding, a multi-driver model with a lag and a check over
        time (:class:`~volerr_pin.fit.diagnosis.ThermalModel`).
    """

    name: str = ""
    prefix: str | None = None
    periodogram: bool = False
    per_revolution: bool = False
    over_time: bool = False

    def through_site(self, offer: Offer, site: str, letter: str) -> list[Candidate]:
        """Candidates of a position-independent translation along ``letter`` through ``site``
        (an axis or a body).

        Parameters
        ----------
        offer : Offer
            What the round's data let candidates be built on.
        site : str
            The axis or body the translation goes through.
        letter : str
            The direction of the translation, "X", "Y" or "Z".

        Returns
        -------
        list of Candidate
            None by default.
        """
        return []

    def on_axis(self, offer: Offer, j: int) -> list[Candidate]:
        """Candidates on axis ``j``'s own motion (its positioning component).

        Parameters
        ----------
        offer : Offer
            What the round's data let candidates be built on.
        j : int
            The axis' index in the model's axes.

        Returns
        -------
        list of Candidate
            None by default.
        """
        return []

    def describe(self, cand: Candidate) -> str:
        """The candidate's label, e.g. "backlash on X in x driven by dir_X (EXX)".

        Parameters
        ----------
        cand : Candidate
            A candidate of this kind.

        Returns
        -------
        str
        """
        return cand.describe()

    def parameter_note(self, name: str) -> str:
        """What the text report adds after one of its coefficients (e.g. that it is held).

        Parameters
        ----------
        name : str
            The coefficient.

        Returns
        -------
        str
            Empty by default.
        """
        return ""

    @property
    def period_given(self) -> bool:
        """Its non-linear coefficient (a period) is set before the fit, not searched on a grid."""
        return self.periodogram or self.per_revolution


#: catalogue name -> its kind, in the order candidates are offered
EFFECTS: dict[str, EffectKind] = {}


def register(kind: type[EffectKind]) -> type[EffectKind]:
    """Register an effect kind (a class decorator): its candidates are offered from then on.

    Parameters
    ----------
    kind : type
        A subclass of :class:`EffectKind` with a ``name`` not registered yet.

    Returns
    -------
    type
        ``kind``.
    """
    if not kind.name or kind.name in EFFECTS:
        raise ValueError(f"an effect kind needs a name of its own, got {kind.name!r}")
    EFFECTS[kind.name] = kind()
    return kind


class Geometric(EffectKind):
    """A geometric component of the model itself (missing from the spec, or raised)."""

    def __init__(self, name: str = "geometric"):
        self.name = name


def effect_kind(name: str) -> EffectKind:
    """The kind of a candidate or finding by its catalogue name.

    Parameters
    ----------
    name : str
        The catalogue name.

    Returns
    -------
    EffectKind
        The registered kind; :class:`Geometric` for a geometric component's name.
    """
    kind = EFFECTS.get(name)
    return kind if kind is not None else Geometric(name)


@register
class ThermalDrift(EffectKind):
    """A translation that drifts with time (first-order lag) or with a temperature sensor."""

    name, prefix, over_time = "thermal_drift", "drift", True

    def through_site(self, offer, site, letter):
        comp = component_name(letter, site)
        out = []
        if offer.timed:
            out.append(Candidate(self.name, site, letter.lower(), comp,
                                 {"kind": self.name, "driver": "time", "amplitudes_um": [0.0],
                                  "time_constants_min": [60.0]}, "t"))
        for s in offer.sensors:
            out.append(Candidate(self.name, site, letter.lower(), comp,
                                 {"kind": self.name, "driver": "temperature", "sensors": [s],
                                  "coefficients_um_per_K": [0.0], "reference_degC": offer.reference_degC(s)},
                                 f"T_{s}"))
        return out


@register
class ForceDeflection(EffectKind):
    """A translation proportional to a measured force (a compliance)."""

    name, prefix = "force_deflection", "load"

    def through_site(self, offer, site, letter):
        comp = component_name(letter, site)
        return [Candidate(self.name, site, letter.lower(), comp,
                          {"kind": self.name, "force": "xyz"[i], "compliance_um_per_N": [0.0]}, f"F{'xyz'[i]}")
                for i in offer.force_axes]


@register
class Backlash(EffectKind):
    """A step on reversal of an axis approached from both sides."""

    name, prefix = "backlash", "reversal"

    def on_axis(self, offer, j):
        machine = offer.model
        axis, letter = machine.axes[j], offer.own[machine.axes[j]]
        if not offer.reverses(j):
            return []
        unit = "um" if machine.axis_kinds[j] == "linear" else "arcsec"
        return [Candidate(self.name, axis, direction_of(letter), component_name(letter, axis),
                          {"kind": self.name, f"reversal_{unit}": 0.0}, f"dir_{axis}")]


@register
class PeriodicRotary(EffectKind):
    """An error of a rotary axis that repeats n times per revolution (:data:`ROTARY_ORDERS`)."""

    name, prefix, per_revolution = "periodic_rotary", "rotary", True

    def on_axis(self, offer, j):
        machine = offer.model
        if machine.axis_kinds[j] == "linear":
            return []
        axis, letter = machine.axes[j], offer.own[machine.axes[j]]
        # the orders its sampled angles can tell from its own smooth geometry (rotary_orders)
        return [Candidate(self.name, axis, direction_of(letter), component_name(letter, axis),
                          {"kind": "periodic_pitch", "period_deg": 360.0 / n, "sine_arcsec": [0.0],
                           "cosine_arcsec": [0.0], "origin_deg": 0.0}, f"q_{axis}")
                for n in rotary_orders(offer.obs.q[:, j])]

    @staticmethod
    def order(cand: Candidate) -> int:
        """Its number of periods per revolution."""
        return round(360.0 / cand.table["period_deg"])

    def describe(self, cand):
        n = self.order(cand)
        times = "once" if n == 1 else f"{n} times"
        return f"{self.name} on {cand.axis} about {cand.direction}, {times} per revolution ({cand.component})"

    def parameter_note(self, name):
        return " (held: the revolution's)" if name.endswith(".period") else ""


@register
class ThermalExpansion(EffectKind):
    """A strain of a linear axis' scale, driven by a temperature sensor or by time."""

    name, prefix = "thermal_expansion", "expansion"

    def on_axis(self, offer, j):
        machine = offer.model
        if machine.axis_kinds[j] != "linear":
            return []
        axis, letter = machine.axes[j], offer.own[machine.axes[j]]
        comp, origin = component_name(letter, axis), float(machine.travel[j][0] * 1e3)
        out = [Candidate(self.name, axis, letter.lower(), comp,
                         {"kind": self.name, "driver": "temperature", "sensor": s,
                          "coefficient_ppm_per_K": 0.0, "reference_degC": offer.reference_degC(s),
                          "origin_mm": origin}, f"T_{s}") for s in offer.sensors]
        if offer.timed:
            out.append(Candidate(self.name, axis, letter.lower(), comp,
                                 {"kind": self.name, "driver": "time", "strains_ppm": [0.0],
                                  "time_constants_min": [60.0], "origin_mm": origin}, "t"))
        return out


@register
class PeriodicPitch(EffectKind):
    """A ball screw's pitch error: a sine along a linear axis, its period from a periodogram."""

    name, prefix, periodogram = "periodic_pitch", "pitch", True

    def on_axis(self, offer, j):
        machine = offer.model
        if machine.axis_kinds[j] != "linear":
            return []
        axis, letter = machine.axes[j], offer.own[machine.axes[j]]
        return [Candidate(self.name, axis, letter.lower(), component_name(letter, axis),
                          {"kind": self.name, "period_mm": 0.0, "sine_um": [0.0], "cosine_um": [0.0],
                           "origin_mm": float(machine.travel[j][0] * 1e3)}, f"q_{axis}")]
