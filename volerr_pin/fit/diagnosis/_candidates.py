"""Candidates: everything a model could be missing, on every axis, direction and sensor the data
allow - the catalogue effects (``thermal_drift``, ``thermal_expansion``, ``backlash``,
``force_deflection``, ``periodic_pitch``, ``periodic_rotary``), the geometric components the spec leaves out
(``positioning``, ``straightness``, ``angular``, ``squareness``, ``location``) and the
spec's own components one step richer (a polynomial 1, 2 or 4 degrees higher, a table with a
node between every two).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ...base import ANGLE, LENGTH, InputError
from ..identify import FitPoints, Observations, by_halves
from ...model import (GEOMETRIC, Constant, Context, Covariates, Machine, Model, Polynomial, TermSpec, axis_jacobian,
                      component_name, error_joint_sensitivity, parse_component_name)
from ._effects import EFFECTS, Offer, PeriodicRotary, direction_of, effect_kind
from ._results import Candidate, Role

__all__ = ["LETTERS", "MAX_DEGREE", "MAX_NODES", "PITCH_PERIOD_MM", "RAISE_BY", "Offered", "adequacy_candidates",
           "axis_directions", "build_candidates", "display_unit", "form_of", "geometric_name", "geometric_term",
           "legendre", "offer", "raised_term", "smoother_term"]

LETTERS = "XYZABC"
PITCH_PERIOD_MM = (1.0, 50.0)   # ball-screw leads
MAX_DEGREE = 12                 # a polynomial component is not raised beyond this degree
MAX_NODES = 65                  # nor a table beyond this many nodes
RAISE_BY = (1, 2, 4)            # degrees a polynomial may gain in one round


# ----------------------------------------------------------------------------- candidates
def axis_directions(machine: Machine) -> dict[str, str]:
    """The error direction letter of each axis' own motion in the axis' own frame (X for an x
    slide, B for a table turning about its own y), whatever the other axes' positions.

    An axis' component errors act in its own frame, so its own motion is the component whose
    effect at the tool moves as the axis does: the error joint ``E<d><axis>`` whose
    translation (linear axes) or rotation (rotary axes) at the tool is parallel to the axis'
    own column of the Jacobian. Both turn with the other axes, so the answer does not depend
    on where they stand (a B table carried by an A cradle at -10 deg is still about B's own y).

    Parameters
    ----------
    machine : Machine
        The machine.

    Returns
    -------
    dict of str to str
        Axis -> letter, for the axes that move along (or about) one direction of their own frame.
    """
    q = machine.mid_travel[None, :]
    J = axis_jacobian(machine.model, q, nominal=True)[0]
    E = error_joint_sensitivity(machine.model, q, first_order=True)[0]
    joints = list(machine.error_joints)
    out = {}
    for j, (axis, kind) in enumerate(zip(machine.axes, machine.axis_kinds)):
        part = slice(0, 3) if kind == "linear" else slice(3, 6)
        v = J[part, j]
        norm_v = np.linalg.norm(v)
        if norm_v == 0:
            continue
        for d in ("XYZ" if kind == "linear" else "ABC"):
            name = component_name(d, axis)
            if name not in joints:
                continue
            e = E[part, joints.index(name)]
            norm_e = np.linalg.norm(e)
            if norm_e > 0 and abs(float(e @ v)) > 0.999 * norm_e * norm_v:
                out[axis] = d
                break
    return out


def geometric_name(direction: str, owner: str, location: bool, own: str | None, linear: bool) -> str:
    """The catalogue name of a geometric component.

    Parameters
    ----------
    direction : str
        Its error direction letter.
    owner : str
        The axis it belongs to.
    location : bool
        A location (constant) error.
    own : str or None
        The direction of the axis' own motion (:func:`axis_directions`).
    linear : bool
        The axis is linear.

    Returns
    -------
    str
        "positioning", "straightness", "angular", "squareness" or "location".
    """
    if location:
        return "squareness" if (direction in "ABC" and linear) else "location"
    if direction in "ABC":
        return "angular"
    return "positioning" if direction == own else "straightness"


def build_candidates(machine: Machine, obs: Observations) -> list[Candidate]:
    """Every catalogue effect the data's covariates allow, on every axis and direction.

    Parameters
    ----------
    machine : Machine
        The present model.
    obs : Observations
        The observations (their covariates say which effects can be seen).

    Returns
    -------
    list of Candidate
        Effects, missing geometric components, then raised components, each labelled.
    """
    own = axis_directions(machine)
    offer = Offer.of(machine.model, obs, own)
    kinds = list(EFFECTS.values())
    out: list[Candidate] = []

    # position-independent translations (a drift, a deflection), through every site
    for site in [a for a in machine.axes] + [b.name for b in machine.spec.bodies]:
        for d in "XYZ":
            for kind in kinds:
                out += kind.through_site(offer, site, d)
    # effects on an axis' own motion (its positioning component)
    for j, axis in enumerate(machine.axes):
        if axis in own:
            for kind in kinds:
                out += kind.on_axis(offer, j)
    # geometric terms the spec leaves out
    present = set(machine.components)
    for j, (axis, kind) in enumerate(zip(machine.axes, machine.axis_kinds)):
        for d in LETTERS:
            comp = component_name(d, axis)
            if comp not in present:
                name = geometric_name(d, axis, False, own.get(axis), kind == "linear")
                # degrees: positioning 5 (interferometer tables bend), straightness 3, angular 2
                degree = 5 if name == "positioning" else 3 if d in "XYZ" else 2
                out.append(Candidate(name, axis, direction_of(d), comp, None, f"q_{axis}", kind=Role.MISSING,
                                     term=legendre(d, tuple(machine.travel[j]), np.zeros(degree + 1))))
        for d in ("ABC" if kind == "linear" else LETTERS):
            comp = component_name(d, axis, True)
            if comp not in present:
                name = geometric_name(d, axis, True, own.get(axis), kind == "linear")
                unit, scale = display_unit(d)
                out.append(Candidate(name, axis, direction_of(d), comp, None, kind=Role.MISSING,
                                     term=TermSpec("", Constant(unit, scale), np.zeros(1))))
    out += adequacy_candidates(machine, own)
    for c in out:
        c.label = effect_kind(c.name).describe(c)
    return out


@dataclass
class Offered:
    """What a round offers: the candidates, the first-order sensitivity of the error to every
    error joint at the points (with the error joints of the location errors offered, at zero),
    and, for each component a periodic error is offered on, its table one step richer between
    its nodes (to ask whether a period is the table's interpolation).

    Attributes
    ----------
    model : Model
        The present model.
    candidates : list of Candidate
        The candidates, in the order the effect kinds offer them.
    E : ndarray, shape (N, 6, n_error_joints)
        d error / d error joint at the observations' points, first order.
    joints : list of str
        The error joints, in the order of ``E``.
    smoother : dict of str to tuple or None
        Component -> (:func:`smoother_term`'s term, in words), or None.
    """

    model: Model
    candidates: list
    E: np.ndarray
    joints: list
    smoother: dict


def offer(machine: Machine, obs: Observations, accepted_orders: set, raises_only: bool) -> Offered:
    """The round's offer (:class:`Offered`): every candidate the data allow
    (:func:`build_candidates`) but a per-revolution error of an order already accepted on its
    component (a second term beside the first would only share it), and only raises once the
    diagnosis has found as many effects as it may.

    Parameters
    ----------
    machine : Machine
        The present model.
    obs : Observations
        The observations.
    accepted_orders : set of tuple of (str, int)
        (component, periods per revolution) of the per-revolution errors accepted so far.
    raises_only : bool
        Offer only raises of the present components.

    Returns
    -------
    Offered
        The offer.
    """
    candidates = [c for c in build_candidates(machine, obs) if not (
        effect_kind(c.name).per_revolution and (c.component, PeriodicRotary.order(c)) in accepted_orders)]
    if raises_only:
        candidates = [c for c in candidates if c.kind == Role.RAISE]
    missing = sorted({c.component for c in candidates if c.component not in machine.error_joints},
                     key=[c.component for c in candidates].index)
    probe = machine
    if missing:
        spec = machine.spec
        for component in missing:
            spec = spec.with_terms(component, TermSpec("probe", Constant(*display_unit(component[1])), np.zeros(1)))
        probe = machine.with_spec(spec)
    model = probe.model
    E = by_halves(FitPoints.of(model, obs, machine.state),
                  lambda q, cov: error_joint_sensitivity(model, q, cov=cov, first_order=True))
    smoother = {c.component: smoother_term(machine, c.component) for c in candidates
                if c.kind == Role.EFFECT and effect_kind(c.name).periodogram}
    return Offered(machine.model, candidates, E, list(probe.error_joints), smoother)


def geometric_term(machine: Machine, component: str):
    """The component's geometric term (constant, polynomial, table).

    Parameters
    ----------
    machine : Machine
        The machine.
    component : str
        A component error of its spec.

    Returns
    -------
    tuple of (int, TermSpec)
        The term's index among the component's terms and the term; (None, None) when it has
        none.

    Raises
    ------
    InputError
        Naming ``component``, when the spec has no such component.
    """
    comp = next((c for c in machine.spec.components if c.name == component), None)
    if comp is None:
        raise InputError(f"component: {component!r} is not an error term of {machine.name}", parameters=("component",))
    for i, tspec in enumerate(comp.terms):
        if tspec.term.kind in GEOMETRIC:
            return i, tspec
    return None, None


def display_unit(direction: str) -> tuple[str, float]:
    """The unit a geometric term of an error in ``direction`` is written in: um (X, Y, Z) or
    arcsec (A, B, C), and its SI value.

    Parameters
    ----------
    direction : str
        The error direction letter.

    Returns
    -------
    tuple of (str, float)
        The unit and its SI value.
    """
    return ("um", LENGTH["um"]) if direction in "XYZ" else ("arcsec", ANGLE["arcsec"])


def legendre(direction: str, travel: tuple[float, float], coefficients: np.ndarray, prefix: str = "") -> TermSpec:
    """A Legendre polynomial over an axis' travel, in the unit of ``direction``'s errors.

    Parameters
    ----------
    direction : str
        The error direction letter.
    travel : tuple of float
        The axis' travel [m, rad].
    coefficients : ndarray, shape (degree + 1,)
        SI values.
    prefix : str, default ""
        The coefficients' prefix.

    Returns
    -------
    TermSpec
        The term.
    """
    unit, scale = display_unit(direction)
    return TermSpec(prefix, Polynomial(len(coefficients) - 1, "legendre", "travel", travel, unit, scale),
                    np.asarray(coefficients, dtype=float))


def smoother_term(machine: Machine, component: str) -> tuple[TermSpec, str] | None:
    """The component's table one step richer between its nodes, zero-valued, for asking whether
    a period along the axis is the table's interpolation.

    Between its nodes a table leaves the residual of a smooth function that repeats at the node
    spacing and its harmonics: the kinks of linear interpolation put it at every harmonic, a
    cubic spline's is far smaller and at the spacing. A linear table's becomes a cubic spline
    through the same nodes (with the linear table beside it, that space takes the smooth
    function's bumps between the nodes at every harmonic); a spline's gains a node between
    every two (its residual falls sixteen-fold). Neither takes a sinusoid whose period is below
    twice the new node spacing: a ball screw's error survives both.

    Parameters
    ----------
    machine : Machine
        The model.
    component : str
        The component a periodic error would be added to.

    Returns
    -------
    tuple of (TermSpec, str) or None
        The term and what it is, in words; None when the component has no table or (a
        spline) its nodes are at :data:`MAX_NODES` already.
    """
    if component not in machine.components:
        return None
    _, tspec = geometric_term(machine, component)
    if tspec is None or tspec.term.kind != "table":
        return None
    if tspec.term.interpolation == "linear":
        term = replace(tspec.term, interpolation="cubic")
        return TermSpec("", term, np.zeros(term.size)), "a cubic spline through its nodes"
    raised = raised_term(machine, component)
    if raised is None:
        return None
    return replace(raised[1], prefix=""), "a node between every two"


def raised_term(machine: Machine, component: str, values: np.ndarray | None = None, by: int = 1):
    """The component's geometric term richer, and its forms (from, to).

    A constant becomes a Legendre polynomial of degree ``by``, a polynomial gains ``by``
    degrees (two are offered because an odd or even part alone may be what is missing),
    a table gains a node between every two (the coarser function space is inside the finer
    one, so the base fit is reproduced exactly; ``by`` is ignored). With ``values`` (the
    term's coefficients, SI) the richer term starts from the present function; else it is
    zero-valued.

    Parameters
    ----------
    machine : Machine
        The machine.
    component : str
        A component error of its spec.
    values : ndarray, optional
        The term's coefficients (SI), to start from the present function.
    by : int, default 1
        Degrees to add (tables: only 1).

    Returns
    -------
    tuple of (int, TermSpec, tuple of str) or None
        The term's index among the component's, the richer term (with the present one's
        prefix) and the forms (from, to); None when the term would pass :data:`MAX_DEGREE` /
        :data:`MAX_NODES` or there is no geometric term.
    """
    index, tspec = geometric_term(machine, component)
    if tspec is None:
        return None
    term = tspec.term
    zero = np.zeros(term.size) if values is None else np.asarray(values, float)
    if term.kind in ("constant", "legendre", "monomial"):
        degree = 0 if term.kind == "constant" else term.degree
        if degree + by > MAX_DEGREE:
            return None
        coefficients = np.r_[zero, np.zeros(by)]
        if term.kind == "constant":
            owner = parse_component_name(component)[2]
            richer = Polynomial(by, "legendre", "travel", tuple(machine.travel[machine.axes.index(owner)]),
                                term.unit, term.unit_scale)
        else:
            richer = replace(term, degree=degree + by)
        change = ("constant" if term.kind == "constant" else f"degree {degree}", f"degree {degree + by}")
    elif by != 1:
        return None
    else:
        nodes = term.nodes
        if 2 * len(nodes) - 1 > MAX_NODES:
            return None
        fine = np.sort(np.r_[nodes, 0.5 * (nodes[1:] + nodes[:-1])])
        richer = replace(term, nodes=fine)
        coefficients = term.value(zero, Context(fine, None, Covariates(len(fine))))
        change = (f"table of {len(nodes)} nodes", f"{len(fine)} nodes")
    return index, TermSpec(tspec.prefix, richer, coefficients), change


def adequacy_candidates(machine: Machine, own: dict[str, str]) -> list[Candidate]:
    """Every component error of an axis with its geometric term one step richer.

    Parameters
    ----------
    machine : Machine
        The present model.
    own : dict of str to str
        The direction of each axis' own motion (:func:`axis_directions`).

    Returns
    -------
    list of Candidate
        One "raise" candidate per component and step (:data:`RAISE_BY`).
    """
    out = []
    for comp in machine.spec.components:
        direction, location, owner = parse_component_name(comp.name)
        if location or owner not in machine.axes:
            continue
        j = machine.axes.index(owner)
        if not np.all(np.isfinite(machine.travel[j])):
            continue  # a polynomial over the travel needs a finite travel
        _, present = geometric_term(machine, comp.name)
        for by in RAISE_BY:
            raised = raised_term(machine, comp.name, None if present is None else present.coefficients, by=by)
            if raised is None:
                continue
            _, term, change = raised
            name = geometric_name(direction, owner, False, own.get(owner), machine.axis_kinds[j] == "linear")
            out.append(Candidate(name, owner, direction_of(direction), comp.name, None, f"q_{owner}",
                                 kind=Role.RAISE, change=change, by=by,
                                 term=replace(term, coefficients=np.zeros(term.term.size)), start=term.coefficients))
    return out


def form_of(machine: Machine, component: str) -> str:
    """The form of a component's geometric term in words.

    Parameters
    ----------
    machine : Machine
        The machine.
    component : str
        A component with a geometric term.

    Returns
    -------
    str
        "constant", "degree 3" or "table of 9 nodes".
    """
    _, tspec = geometric_term(machine, component)
    term = tspec.term
    if term.kind == "table":
        return f"table of {len(term.nodes)} nodes"
    return "constant" if term.kind == "constant" else f"degree {term.degree}"
