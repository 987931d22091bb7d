"""What a tolerance means: each component error drawn as the shape ISO 230-1 gives it, less
what setting a work offset removes.

A tolerance on a component error bounds the quantity the standard defines for it, not a
constant offset:

============================  ============================  =====================================
component                     drawn as                      left out (what the value excludes)
============================  ============================  =====================================
positioning (``EXX``)         ``a P1(u) + b P2(u)``         the offset (a work offset sets it)
straightness (``EYX``)        ``a P2(u) + b P3(u)``         offset and slope (the reference line)
angular (``EAX``, ``EBX``)    ``a P1(u) + b P2(u)``         the offset (the axis' orientation,
                                                            which the squareness tolerances hold)
axial (``EZC``), angular      harmonics 1 and 2 of the      the mean (the axis' zero and the
positioning (``ECC``)         angle                         work offset)
radial (``EXC``), tilt        harmonics 2 and 3 of the      the mean and the once-per-revolution
(``EAC``)                     angle                         part (the centring, ISO 230-7)
location (``EC0Y``, ...)      one constant                  nothing
a body's error (``EXT``)      one constant                  nothing
============================  ============================  =====================================

``P_k`` are Legendre polynomials over the axis' travel (``u`` in [-1, 1]); a rotary axis'
shape is a linear table with nodes at most :data:`NODE_STEP` apart (its range is exactly
that of its nodes). The mix (``a : b``) and the phases are drawn uniformly; the shape is then
scaled so that its range over the travel (largest minus smallest value: the positioning error
E of ISO 230-2, the straightness deviation of ISO 230-1) is ``|xi| t``, ``xi`` the tolerance's
standard variable (uniform on [-1, 1] or standard normal). A uniform tolerance of ``t`` thus
never exceeds ``t`` as the standard measures it.

What a work offset removes is left out twice: every shape above is free of its mean over the
travel, and a component whose effect is the same translation at every point of the study
(a constant of a body at the end of the chain, such as a lathe turret's offsets) is not drawn
at all: setting the work or tool offset takes it out whole. The second is asked of the data
(the component's sensitivities at the study's points), not of its name.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model import Machine, check_covariates, parse_component_name, replace_terms, sensitivity
from ._distributions import Distribution
from ._montecarlo import ThetaSource

__all__ = ["LEFT_OUT", "NODE_STEP", "Shape", "ShapedSource", "legendre_range", "shape_machine", "shapes_of",
           "work_offset_components"]

#: the largest spacing of a rotary shape's table nodes [rad]
NODE_STEP = math.radians(10.0)
#: uniform numbers a shape takes per draw besides its magnitude (mix and two phases)
SHAPE_INPUTS = 3
#: points whose sensitivities :func:`work_offset_components` holds at a time
SENSITIVITY_BLOCK = 512
#: why a component is left out of a study
LEFT_OUT = "a work offset removes what it does, the same translation at every point"

_ROTATION_OF = {"A": "X", "B": "Y", "C": "Z"}


@dataclass(frozen=True)
class Shape:
    """How one component error is drawn.

    Attributes
    ----------
    component : str
        Component name.
    name : str
        What the tolerance bounds: ``"positioning"``, ``"straightness"``, ``"angular"``,
        ``"axial"``, ``"radial"``, ``"tilt"``, ``"angular positioning"``, ``"location"``
        or ``"constant"``.
    excluded : str
        What the shape leaves out, in words ("" for none).
    family : str
        ``"constant"``, ``"legendre"`` or ``"harmonic"``.
    orders : tuple of int
        The two Legendre degrees or harmonics mixed (empty for a constant).
    nodes : ndarray or None
        A harmonic shape's table nodes [rad]; None otherwise.
    angular : bool
        True for an angle (arcsec), False for a length (um).
    """

    component: str
    name: str
    excluded: str
    family: str
    orders: tuple[int, ...] = ()
    nodes: np.ndarray | None = None
    angular: bool = False

    @property
    def inputs(self) -> int:
        """Uniform numbers the shape takes per draw besides its magnitude (int)."""
        return {"constant": 0, "legendre": 1, "harmonic": 3}[self.family]

    @property
    def basis(self) -> str:
        """The shape's functions, in words (str)."""
        if self.family == "constant":
            return "one constant"
        if self.family == "legendre":
            return "Legendre P{} and P{} over the travel".format(*self.orders)
        return "harmonics {} and {} of the angle (linear table, {} nodes)".format(*self.orders, len(self.nodes))

    def table(self) -> dict:
        """The component's spec table in the study's machine, all coefficients zero (dict)."""
        unit = "arcsec" if self.angular else "um"
        if self.family == "constant":
            return {"kind": "constant", f"value_{unit}": 0.0}
        if self.family == "legendre":
            return {"kind": "legendre", f"coefficients_{unit}": [0.0] * (max(self.orders) + 1)}
        return {"kind": "table", "interpolation": "linear", "positions_deg": [float(np.degrees(x)) for x in self.nodes],
                f"values_{unit}": [0.0] * len(self.nodes)}

    @property
    def size(self) -> int:
        """Coefficients of the component's term (int)."""
        if self.family == "constant":
            return 1
        return max(self.orders) + 1 if self.family == "legendre" else len(self.nodes)

    def unit(self, v: np.ndarray) -> np.ndarray:
        """Coefficient vectors of shapes whose range over the travel is 1.

        Parameters
        ----------
        v : ndarray, shape (n, SHAPE_INPUTS)
            Uniform numbers in [0, 1): the mix, then two phases (unused by some families).

        Returns
        -------
        ndarray, shape (n, size)
            The term's coefficients, per unit of tolerance [SI per SI].
        """
        n = len(v)
        if self.family == "constant":
            return np.ones((n, 1))
        if self.family == "legendre":
            a, b = self.orders
            mix = np.pi * v[:, 0]
            out = np.zeros((n, self.size))
            out[:, a], out[:, b] = np.cos(mix), np.sin(mix)
            return out / legendre_range(out)[:, None]
        ha, hb = self.orders
        mix = 0.5 * np.pi * v[:, 0]
        x = self.nodes[None, :]
        g = (np.cos(mix)[:, None] * np.cos(ha * x + 2 * np.pi * v[:, 1:2])
             + np.sin(mix)[:, None] * np.cos(hb * x + 2 * np.pi * v[:, 2:3]))
        g -= _trapezoid_mean(g, self.nodes)[:, None]
        spread = g.max(axis=1) - g.min(axis=1)
        return g / np.maximum(spread, 1e-300)[:, None]


def _trapezoid_mean(g: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The mean over ``x`` of the piecewise-linear functions with values ``g`` (rows) at ``x``."""
    if len(x) < 2:
        return g[:, 0] * 0.0
    w = np.zeros(len(x))
    d = np.diff(x)
    w[:-1] += d / 2
    w[1:] += d / 2
    return g @ w / (x[-1] - x[0])


def legendre_range(c: np.ndarray) -> np.ndarray:
    """Largest minus smallest value over ``u`` in [-1, 1] of Legendre series up to degree 3.

    Exact: the extremes are at the ends or where the derivative (a quadratic) vanishes.

    Parameters
    ----------
    c : ndarray, shape (n, k), k <= 4
        Coefficients of ``P_0 .. P_{k-1}``.

    Returns
    -------
    ndarray, shape (n,)
        The ranges.
    """
    c = np.pad(np.asarray(c, dtype=float), ((0, 0), (0, 4 - np.shape(c)[1])))
    power = np.array([np.pad(r, (0, 4 - len(r))) for r in map(np.polynomial.legendre.leg2poly, np.eye(4))])
    p = c @ power                                                  # (n, 4): p0 + p1 u + p2 u^2 + p3 u^3
    A, B, C = 3 * p[:, 3], 2 * p[:, 2], p[:, 1]                    # derivative A u^2 + B u + C
    cand = np.full((len(c), 4), -1.0)
    cand[:, 1] = 1.0
    disc = B * B - 4 * A * C
    quad = np.abs(A) > 1e-300
    root = np.sqrt(np.where(quad & (disc >= 0), disc, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        r1 = np.where(quad, (-B + root) / (2 * A), np.where(np.abs(B) > 1e-300, -C / B, -1.0))
        r2 = np.where(quad, (-B - root) / (2 * A), -1.0)
    ok = ~quad | (disc >= 0)
    cand[:, 2] = np.where(ok & (np.abs(r1) <= 1), r1, -1.0)
    cand[:, 3] = np.where(ok & (np.abs(r2) <= 1), r2, -1.0)
    values = p[:, :1] + p[:, 1:2] * cand + p[:, 2:3] * cand**2 + p[:, 3:4] * cand**3
    return values.max(axis=1) - values.min(axis=1)


def _nodes(lower: float, upper: float) -> np.ndarray:
    """Table nodes over a rotary travel, at most :data:`NODE_STEP` apart."""
    count = max(2, int(math.ceil((upper - lower) / NODE_STEP - 1e-9)) + 1)
    return np.linspace(lower, upper, count)


def shapes_of(machine: Machine) -> tuple[Shape, ...]:
    """The shape of every component error of a machine, in its component order.

    The direction an axis moves in (or turns about) is asked of its kinematics
    (:func:`~volerr_pin.fit.diagnosis.axis_directions`): a slide along its own x
    has ``EXX`` as its positioning, a table turning about its own z has ``ECC`` as its
    angular positioning and ``EZC`` as its axial motion, whatever the axes are named.

    Parameters
    ----------
    machine : Machine
        The machine.

    Returns
    -------
    tuple of Shape
        One per component.
    """
    from ..fit.diagnosis import axis_directions

    own = axis_directions(machine)
    kinds = dict(zip(machine.axes, machine.axis_kinds))
    travel = dict(zip(machine.axes, np.asarray(machine.travel, dtype=float)))
    out = []
    for name in machine.components:
        direction, location, owner = parse_component_name(name)
        angular = direction in "ABC"
        kind = kinds.get(owner)
        if location:
            out.append(Shape(name, "location", "", "constant", angular=angular))
        elif kind is None or owner not in own or not np.all(np.isfinite(travel[owner])):
            out.append(Shape(name, "constant", "", "constant", angular=angular))
        elif kind == "linear":
            if angular:
                out.append(Shape(name, "angular", "the offset (the axis' orientation, which the squareness "
                                 "tolerances hold)", "legendre", (1, 2), angular=True))
            elif direction == own[owner]:
                out.append(Shape(name, "positioning", "the offset (a work offset sets it)", "legendre", (1, 2)))
            else:
                out.append(Shape(name, "straightness", "offset and slope (the reference straight line)",
                                 "legendre", (2, 3)))
        else:
            axis_letter = own[owner]
            nodes = _nodes(*travel[owner])
            if angular and direction == axis_letter:
                out.append(Shape(name, "angular positioning", "the mean (the axis' zero, set with the work offset)",
                                 "harmonic", (1, 2), nodes, True))
            elif angular:
                out.append(Shape(name, "tilt", "the mean and the once-per-revolution part (the artefact's "
                                 "alignment, ISO 230-7)", "harmonic", (2, 3), nodes, True))
            elif direction == _ROTATION_OF[axis_letter]:
                out.append(Shape(name, "axial", "the mean (a work offset)", "harmonic", (1, 2), nodes))
            else:
                out.append(Shape(name, "radial", "the mean and the once-per-revolution part (the centring, "
                                 "ISO 230-7)", "harmonic", (2, 3), nodes))
    return tuple(out)


def shape_machine(machine: Machine, shapes: tuple[Shape, ...]) -> tuple[Machine, tuple[np.ndarray, ...]]:
    """The machine with every component's terms replaced by its shape's, all zero.

    Parameters
    ----------
    machine : Machine
        The machine (its state is kept).
    shapes : tuple of Shape
        One per component (:func:`shapes_of`).

    Returns
    -------
    machine : Machine
        The new machine.
    columns : tuple of ndarray of int
        Per component, its coefficients in the new machine's theta (in the term's order).
    """
    shaped = replace_terms(machine, {s.component: s.table() for s in shapes})
    owner = np.array([n.split(".", 1)[0] for n in shaped.parameter_names])
    return shaped, tuple(np.flatnonzero(owner == s.component) for s in shapes)


def work_offset_components(machine: Machine, columns, q: np.ndarray, shapes) -> list[int]:
    """The constant components whose effect is the same translation at every point of ``q``.

    Parameters
    ----------
    machine : Machine
        The study's machine (:func:`shape_machine`).
    columns : sequence of ndarray of int
        Each component's coefficients.
    q : ndarray, shape (N, n_axes)
        The study's points [m, rad], checked (:attr:`Points.q
        <volerr_pin.studies._montecarlo.Points.q>`).
    shapes : sequence of Shape
        One per component.

    Returns
    -------
    list of int
        Their positions in the component order.
    """
    constant = [k for k, s in enumerate(shapes) if s.family == "constant"]
    if not constant or len(q) < 2:
        return []
    cols = [int(columns[k][0]) for k in constant]
    model, theta = machine.model, machine.theta
    cov = check_covariates(model, len(q), None, machine.state)
    first = None
    size = np.zeros(len(cols))
    spread = np.zeros(len(cols))
    for start in range(0, len(q), SENSITIVITY_BLOCK):   # the sensitivities of a block at a time
        rows = slice(start, start + SENSITIVITY_BLOCK)
        S = sensitivity(model, q[rows], theta, cov.take(rows), first_order=True)[:, :3, cols]
        if first is None:
            first = S[:1]
        size = np.maximum(size, np.abs(S).max(axis=(0, 1)))
        spread = np.maximum(spread, np.abs(S - first).max(axis=(0, 1)))
    return [k for k, a, b in zip(constant, size, spread) if a > 0 and b <= 1e-9 * a]


@dataclass(frozen=True)
class ShapedSource(ThetaSource):
    """Draws of a tolerance study: every component's shape, scaled within its tolerance.

    Each draw takes ``1 + SHAPE_INPUTS`` uniform numbers per component from its chunk's
    stream: the magnitude's (through the distribution's inverse CDF) and the shape's.

    Attributes
    ----------
    shapes : tuple of Shape
        One per component.
    columns : tuple of ndarray of int
        Each component's coefficients in theta.
    tolerance : ndarray, shape (n_components,)
        Tolerances [m or rad]; 0 keeps a component at zero.
    distributions : tuple of Distribution
        One per component.
    parameters : int
        Length P of theta.
    seed : int
        The study's seed.

    Notes
    -----
    The methods of :class:`~volerr_pin.studies._montecarlo.ThetaSource` (documented there) do
    here:

    - ``rows``: coefficient vectors of chunk ``chunk`` (ThetaSource).
    """

    shapes: tuple[Shape, ...]
    columns: tuple[np.ndarray, ...]
    tolerance: np.ndarray
    distributions: tuple[Distribution, ...]
    parameters: int
    seed: int

    def owner(self) -> np.ndarray:
        """The component each coefficient belongs to (-1 for none), shape (P,)."""
        out = np.full(self.parameters, -1)
        for k, cols in enumerate(self.columns):
            out[cols] = k
        return out

    def standard(self, chunk: int, start: int, stop: int) -> np.ndarray:
        """Per unit of tolerance, the coefficients of the draws of chunk ``chunk``.

        Parameters
        ----------
        chunk : int
            Chunk index.
        start, stop : int
            Sample range of the chunk.

        Returns
        -------
        ndarray, shape (stop - start, P)
            ``xi`` times the unit shape, per component (dimensionless).
        """
        from ._engine import chunk_rng

        n, width = stop - start, 1 + SHAPE_INPUTS
        u = chunk_rng(self.seed, chunk).random((n, width * len(self.shapes)))
        out = np.zeros((n, self.parameters))
        for k, (shape, dist, cols) in enumerate(zip(self.shapes, self.distributions, self.columns)):
            xi = dist.standard(u[:, width * k])
            out[:, cols] = xi[:, None] * shape.unit(u[:, width * k + 1:width * (k + 1)])
        return out

    def scale(self, tolerance=None) -> np.ndarray:
        """Each coefficient's tolerance (that of its component), shape (P,)."""
        t = self.tolerance if tolerance is None else np.asarray(tolerance, dtype=float)
        owner = self.owner()
        return np.where(owner >= 0, t[np.maximum(owner, 0)], 0.0)

    def rows(self, chunk: int, start: int, stop: int) -> np.ndarray:
        return self.standard(chunk, start, stop) * self.scale()

    def with_tolerance(self, tolerance, seed: int | None = None) -> "ShapedSource":
        """The same shapes with other tolerances (and seed).

        Parameters
        ----------
        tolerance : array_like, shape (n_components,)
            Tolerances [m or rad].
        seed : int, optional
            Seed (default: unchanged).

        Returns
        -------
        ShapedSource
        """
        return ShapedSource(self.shapes, self.columns, np.asarray(tolerance, dtype=float), self.distributions,
                            self.parameters, self.seed if seed is None else seed)

    def design_rows(self, X: np.ndarray, active) -> np.ndarray:
        """Coefficient vectors of a design whose inputs are, per active component, its
        magnitude [m or rad] followed by its shape's uniform numbers.

        Parameters
        ----------
        X : ndarray, shape (runs, inputs)
            The design (the order of :meth:`design_problem`).
        active : sequence of int
            The components the design varies.

        Returns
        -------
        ndarray, shape (runs, P)
            Coefficient vectors [SI].
        """
        rows = np.zeros((len(X), self.parameters))
        at = 0
        for k in active:
            shape = self.shapes[k]
            v = np.zeros((len(X), SHAPE_INPUTS))
            v[:, :shape.inputs] = X[:, at + 1:at + 1 + shape.inputs]
            rows[:, self.columns[k]] = X[:, at:at + 1] * shape.unit(v)
            at += 1 + shape.inputs
        return rows

    def design_problem(self, active, names) -> dict:
        """SALib's problem for :meth:`design_rows`: one group per component.

        Parameters
        ----------
        active : sequence of int
            The components to vary.
        names : sequence of str
            Their names.

        Returns
        -------
        dict
            ``num_vars``, ``names``, ``bounds``, ``dists`` and ``groups``.
        """
        problem = {"names": [], "bounds": [], "dists": [], "groups": []}
        for k, name in zip(active, names):
            dist_name, bound = self.distributions[k].salib(float(self.tolerance[k]))
            problem["names"].append(name)
            problem["dists"].append(dist_name)
            problem["bounds"].append(bound)
            problem["groups"].append(name)
            for j in range(self.shapes[k].inputs):
                problem["names"].append(f"{name}.shape{j}")
                problem["dists"].append("unif")
                problem["bounds"].append([0.0, 1.0])
                problem["groups"].append(name)
        problem["num_vars"] = len(problem["names"])
        return problem
