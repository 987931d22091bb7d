"""Error terms: functions of an axis position and covariates with named coefficients.

A component error (EXX, EC0Y, ...) is the sum of its terms. A term gives its value, its
derivative with respect to its coefficients (:meth:`Term.jacobian`) and with respect to the
axis position (:meth:`Term.position_slope`). The geometric terms here are linear in their
coefficients, ``value = basis(context) @ coefficients``; the effect terms of
:mod:`volerr_pin.model._effects` (thermal, load, reversal, periodic) may have non-linear ones
(time constants, periods), listed in :attr:`Term.nonlinear`. Coefficients are SI (m or rad
for the error; positions in m or rad). A term writes itself back in the engineering units
it was read in (:meth:`Term.to_spec`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Mapping

import numpy as np
from numpy.polynomial import legendre
from scipy.interpolate import CubicSpline, make_interp_spline

from ..base import ANGLE, LENGTH, PLAUSIBLE, TIME, InputError, SpecError, require_memory, scale
from ._speckeys import TermSite, text

#: peak memory of reading a table of n nodes, per n^2 (measured 96 bytes at 1,000 and 2,000 nodes;
#: the estimate of 40 had a 7,000-node cubic table take 4.8 GB where 1.96 GB was allowed for)
TABLE_BYTES_PER_NODE_PAIR = 100.0

#: SI value of the numerator of a coefficient's display unit (``um`` of ``um/K``, ``ppm`` of a strain)
_NUMERATOR_SCALE = {**LENGTH, **ANGLE, **TIME, "ppm": 1e-6}


def _limit_of(unit: str) -> str:
    numerator = unit.partition("/")[0]
    if numerator in TIME:
        return "time"
    return "error_angle" if numerator in ANGLE else "error_length"

#: the most coefficients of a polynomial term: beyond, a table describes an error better (and a
#: degree of thousands, a few characters in a spec, would take the memory of the evaluation)
MAX_COEFFICIENTS = 50


@dataclass(frozen=True)
class Covariates:
    """Per-point covariates, already checked and in SI (see ``Machine.volumetric_error``).

    Attributes
    ----------
    n : int
        Number of points.
    t : (N,) array or None
        Time [s].
    temperatures : mapping of str to (N,) arrays
        Temperatures [degC] by sensor name.
    forces : (N, 3) array or None
        Process force at the tool [N].
    directions : (N, n_axes) array or None
        Approach direction of each axis, +1 or -1.
    series : (N,) array or None
        The time series each point belongs to (a file of its own); None: one series.
    history : TemperatureHistory or None
        The whole measured temperature record the points are taken from, for lagged
        temperatures (a subset of the points still reads the record, not just itself); None:
        the points themselves are the record.
    """

    n: int
    t: np.ndarray | None = None
    temperatures: Mapping[str, np.ndarray] = field(default_factory=dict)
    forces: np.ndarray | None = None
    directions: np.ndarray | None = None
    series: np.ndarray | None = None
    history: "TemperatureHistory | None" = None

    def take(self, rows) -> "Covariates":
        """The covariates of some of the points (the history stays whole).

        Parameters
        ----------
        rows : slice, ndarray of int or ndarray of bool
            The points.

        Returns
        -------
        Covariates
            Their covariates.
        """
        if isinstance(rows, slice):
            n = len(range(*rows.indices(self.n)))
        else:
            rows = np.asarray(rows)
            n = int(rows.sum()) if rows.dtype == bool else len(rows)
        cut = lambda a: None if a is None else a[rows]   # noqa: E731
        return Covariates(n, cut(self.t), {k: v[rows] for k, v in self.temperatures.items()},
                          cut(self.forces), cut(self.directions), cut(self.series), self.history)


@dataclass(frozen=True)
class TemperatureHistory:
    """A measured temperature record: every sample's time, series and temperatures (SI).

    Lagged temperatures are read from it, each point along its own series, so that any
    subset of the points (a cross-validation fold, a chunk) reads the same values as all of
    them. Covariates carry it whole under the key ``history``.

    Attributes
    ----------
    t : ndarray, shape (M,)
        Times [s].
    series : ndarray, shape (M,)
        The series (file) of each sample.
    temperatures : mapping of str to ndarray, shape (M,)
        Temperatures [degC] by sensor.
    """

    t: np.ndarray
    series: np.ndarray
    temperatures: Mapping[str, np.ndarray]


@dataclass(frozen=True)
class Context:
    """What a term may look at when it is evaluated.

    ``position`` is the NC position of the axis owning the component (m or rad), None for
    components of bodies without an axis; ``travel`` its (lower, upper) range.

    Attributes
    ----------
    position : ndarray, shape (N,), or None
        NC position of the owning axis at each point [m or rad]; None for a body without an axis.
    travel : tuple of (float, float) or None
        The axis' travel (lower, upper) [m or rad]; None for a body without an axis.
    covariates : Covariates
        The points' covariates (time, temperatures, forces, directions), SI.
    axis_index : int or None
        Index of the owning axis among the model's axes (its column of ``q`` and of
        ``covariates.directions``); None for a body without an axis.
    component : str
        Name of the component error being evaluated (for messages).
    """

    position: np.ndarray | None
    travel: tuple[float, float] | None
    covariates: Covariates
    axis_index: int | None = None
    component: str = ""

    @property
    def n(self) -> int:
        """Number of points N."""
        return self.covariates.n


class Term:
    """Base class: a function of the context with named coefficients."""

    kind: str = ""
    local_names: tuple[str, ...] = ()
    nonlinear: tuple[str, ...] = ()   # coefficients the value is not linear in
    covariates: tuple[str, ...] = ()  # the covariates its value reads (t, temperatures, ...)

    @property
    def size(self) -> int:
        """Number of coefficients (``len(local_names)``)."""
        return len(self.local_names)

    def value(self, coefficients: np.ndarray, ctx: Context) -> np.ndarray:
        """(N,) value of the term, SI.

        Parameters
        ----------
        coefficients : ndarray, shape (size,)
            The term's coefficients (SI).
        ctx : Context
            The points: axis position, travel and covariates.

        Returns
        -------
        ndarray, shape (N,)
            The value at each point [m or rad, as the component error].
        """
        raise NotImplementedError

    def jacobian(self, coefficients: np.ndarray, ctx: Context) -> np.ndarray:
        """(N, P) derivative of the value with respect to the coefficients.

        Parameters
        ----------
        coefficients : ndarray, shape (size,)
            The term's coefficients (SI).
        ctx : Context
            The points: axis position, travel and covariates.

        Returns
        -------
        ndarray, shape (N, size)
            d value / d coefficient at each point (SI), columns in the order of :attr:`local_names`.
        """
        raise NotImplementedError

    def position_slope(self, coefficients: np.ndarray, ctx: Context) -> np.ndarray:
        """(N,) derivative of the value with respect to the axis position.

        Parameters
        ----------
        coefficients : ndarray, shape (size,)
            The term's coefficients (SI).
        ctx : Context
            The points: axis position, travel and covariates.

        Returns
        -------
        ndarray, shape (N,)
            d value / d position at each point (SI); by default zeros, for a term that does not
            depend on the position.
        """
        return np.zeros(ctx.n)

    def search_grid(self, name: str, coefficients: np.ndarray, covariates: Covariates) -> np.ndarray:
        """Candidate values of a non-linear coefficient for a grid search before a fit.

        Parameters
        ----------
        name : str
            The coefficient's local name (one of :attr:`nonlinear`).
        coefficients : ndarray, shape (size,)
            The term's current coefficients (SI).
        covariates : Covariates
            The covariates of the points to be fitted.

        Returns
        -------
        ndarray, shape (G,)
            Candidate values in the coefficient's SI unit; by default empty (no grid).
        """
        return np.array([])

    def coefficient_units(self) -> list[tuple[float, str]]:
        """(SI per display unit, display unit) of each coefficient, as the spec writes it.

        Returns
        -------
        list of (float, str)
            One pair per coefficient, in the order of :attr:`local_names`; by default the
            term's ``unit_scale`` and ``unit`` for every coefficient.
        """
        return [(self.unit_scale, self.unit)] * self.size

    def coefficient_limits(self) -> list[str]:
        """The plausibility limit (a key of :data:`volerr_pin.base.PLAUSIBLE`) of each
        coefficient, read from its display unit's numerator: an error for a length or angle
        (and a length or angle per kelvin, newton or position), a time for a time constant.

        Returns
        -------
        list of str
            One key of :data:`~volerr_pin.base.PLAUSIBLE` per coefficient ("error_length",
            "error_angle" or "time").
        """
        return [_limit_of(unit) for _, unit in self.coefficient_units()]

    def coefficient_bounds(self) -> np.ndarray:
        """(size, 2) lowest and highest plausible SI value of each coefficient: the spec's
        rule, a value in its display unit times its numerator's unit within the limit of
        :meth:`coefficient_limits` (1 m, 1 rad, 1e10 s; 1 m per kelvin).

        Returns
        -------
        ndarray, shape (size, 2)
            (lowest, highest) SI value of each coefficient.
        """
        out = np.empty((self.size, 2))
        for k, ((si_per_unit, unit), limit) in enumerate(zip(self.coefficient_units(), self.coefficient_limits())):
            numerator = unit.partition("/")[0]
            out[k] = np.array(PLAUSIBLE[limit]) * si_per_unit / _NUMERATOR_SCALE[numerator]
        return out

    def lag_requests(self) -> tuple[tuple[str, float], ...]:
        """(sensor, lag [s]) pairs whose delayed temperatures the term reads.

        Returns
        -------
        tuple of (str, float)
            The sensor names and lags [s]; by default empty (no lagged temperature).
        """
        return ()

    def temperature_sensors(self) -> tuple[str, ...]:
        """Names of the temperature sensors the term reads.

        Returns
        -------
        tuple of str
            The sensor names; by default empty (no temperature).
        """
        return ()

    def to_spec(self, coefficients: np.ndarray) -> dict:
        """The term as a spec table, in the units it was read in.

        Parameters
        ----------
        coefficients : ndarray, shape (size,)
            The term's coefficients (SI).

        Returns
        -------
        dict
            The spec table (``kind`` and the kind's keys, units in the key names), the inverse
            of :meth:`from_spec`.
        """
        raise NotImplementedError

    #: stems of the keys of its spec table besides "kind" and "prefix" (units are suffixes)
    keys: frozenset[str] = frozenset()
    #: whether the term can only be an error of an axis' own motion
    axis_only: bool = False
    #: whether the term can only be a length error of a linear axis
    linear_length_only: bool = False

    @classmethod
    def from_spec(cls, table: dict, site: TermSite) -> tuple["Term", np.ndarray]:
        """Read the term from its spec table (the inverse of :meth:`to_spec`).

        Parameters
        ----------
        table : dict
            The term's table, keys checked against :attr:`keys` already.
        site : TermSite
            Where the table is and what it is an error of (for units and messages).

        Returns
        -------
        term : Term
        coefficients : ndarray, shape (size,)
            The coefficients in SI.
        """
        raise NotImplementedError


class LinearTerm(Term):
    """A term linear in its coefficients: subclasses define :meth:`basis` (and
    :meth:`basis_derivative` when the basis depends on the axis position).

    Notes
    -----
    The methods of :class:`~volerr_pin.model.Term` (documented there) do here:

    - ``value``: the value, ``basis(ctx) @ coefficients``.
    - ``jacobian``: the derivative with respect to the coefficients: the basis itself.
    - ``position_slope``: the derivative with respect to the axis position,
      ``basis_derivative(ctx) @ coefficients``.
    """

    def basis(self, ctx: Context) -> np.ndarray:
        """(N, P) matrix with ``value = basis @ coefficients``.

        Parameters
        ----------
        ctx : Context
            The points: axis position, travel and covariates.

        Returns
        -------
        ndarray, shape (N, size)
            The basis functions at the points.
        """
        raise NotImplementedError

    def basis_derivative(self, ctx: Context) -> np.ndarray:
        """(N, P) derivative of :meth:`basis` with respect to the axis position.

        Parameters
        ----------
        ctx : Context
            The points: axis position, travel and covariates.

        Returns
        -------
        ndarray, shape (N, size)
            d basis / d position [1/m or 1/rad]; by default zeros, for a basis that does not depend on
            the position.
        """
        return np.zeros((ctx.n, self.size))

    def value(self, coefficients, ctx):
        return self.basis(ctx) @ coefficients

    def jacobian(self, coefficients, ctx):
        return self.basis(ctx)

    def position_slope(self, coefficients, ctx):
        return self.basis_derivative(ctx) @ coefficients


def _check_position(term: Term, ctx: Context, where: str) -> np.ndarray:
    if ctx.position is None:
        raise SpecError(f"{where}: a {term.kind} term needs an axis position, but its "
                        "component belongs to a body without an axis")
    return ctx.position


@dataclass(frozen=True, eq=False)
class Constant(LinearTerm):
    """A constant error; one coefficient ``c0``.

    Attributes
    ----------
    unit : str
        The display unit of the value in the spec (``um``, ``arcsec``).
    unit_scale : float
        SI per display unit.

    Notes
    -----
    The methods of :class:`~volerr_pin.model.Term` (documented there) do here:

    - ``basis``: a column of ones.
    - ``basis_derivative``: a column of zeros: a constant does not depend on the position.
    - ``to_spec``: the spec table: ``kind = "constant"`` and ``value_<unit>``.
    - ``from_spec``: read a constant from its spec table (``value_<unit>``, one number).
    """

    unit: str
    unit_scale: float
    kind = "constant"
    local_names = ("c0",)

    def basis(self, ctx):
        return np.ones((ctx.n, 1))

    def basis_derivative(self, ctx):
        return np.zeros((ctx.n, 1))

    def to_spec(self, coefficients):
        return {"kind": "constant", f"value_{self.unit}": float(coefficients[0] / self.unit_scale)}

    keys = frozenset({"value"})

    @classmethod
    def from_spec(cls, table, site):
        value, unit, factor, key = site.value(table, "value", count=1)
        if isinstance(table[key], (list, tuple)):
            raise SpecError(f"{site.where}.{key}: a constant takes one number, not a list")
        return cls(unit, factor), value


@dataclass(frozen=True, eq=False)
class Polynomial(LinearTerm):
    """Polynomial in the axis position.

    ``basis`` is "legendre" (P_k(u)) or "monomial" (u**k); ``over`` is "travel"
    (u = 2 (q - lower) / (upper - lower) - 1, in [-1, 1] over the travel) or, for
    monomials, "position" (u = q in ``position_unit``). Coefficients c0..cN.

    Attributes
    ----------
    degree : int
        The highest power N (degree + 1 coefficients).
    family : str
        "legendre" or "monomial" (the spec's ``kind``).
    over : str
        "travel" (u normalised to [-1, 1] over the travel) or "position" (u = q in
        ``position_unit``, monomials only).
    travel : tuple of (float, float) or None
        The axis' travel (lower, upper) [m or rad] that u is normalised over.
    unit : str
        The display unit of the error in the spec (``um``, ``arcsec``).
    unit_scale : float
        SI per display unit.
    position_unit : str or None
        The unit of u over the position (``mm``, ``deg``); None over the travel.
    position_scale : float
        SI per ``position_unit`` (1.0 over the travel).

    Notes
    -----
    The methods of :class:`~volerr_pin.model.Term` (documented there) do here:

    - ``basis``: the Vandermonde matrix of u: ``P_k(u)`` (Legendre) or ``u**k`` (monomial), k =
      0 ... degree.
    - ``basis_derivative``: the derivative of :meth:`basis` with respect to the axis position
      (``d/du`` times ``du/dq``).
    - ``coefficient_units``: (SI per display unit, display unit) of each coefficient: the
      error's unit over the travel; over the position, ``c_k`` in ``unit/position_unit^k``.
    - ``to_spec``: the spec table: ``kind``, ``over`` (monomials), ``position_unit`` (over the
      position) and ``coefficients_<unit>`` (per ``position_unit**k`` over the position).
    - ``from_spec``: read a polynomial from its spec table (``coefficients_<unit>``, ``over``,
      ``position_unit``); at most :data:`MAX_COEFFICIENTS` coefficients.
    """

    degree: int
    family: str
    over: str
    travel: tuple[float, float] | None
    unit: str
    unit_scale: float
    position_unit: str | None = None
    position_scale: float = 1.0

    @property
    def kind(self):  # type: ignore[override]
        """The term's kind: its family, "legendre" or "monomial"."""
        return self.family

    @property
    def local_names(self):  # type: ignore[override]
        """Names of the coefficients, ``c0`` ... ``c<degree>``."""
        return tuple(f"c{k}" for k in range(self.degree + 1))

    def _u(self, ctx):
        q = _check_position(self, ctx, self.family)
        if self.over == "travel":
            lo, hi = self.travel
            return (2.0 * q - lo - hi) / (hi - lo), 2.0 / (hi - lo)
        return q, 1.0

    def basis(self, ctx):
        u, _ = self._u(ctx)
        if self.family == "legendre":
            return legendre.legvander(u, self.degree)
        return np.vander(u, self.degree + 1, increasing=True)

    def basis_derivative(self, ctx):
        u, du_dq = self._u(ctx)
        out = np.zeros((u.size, self.degree + 1))
        if self.family == "legendre":
            for k in range(1, self.degree + 1):
                coef = np.zeros(k + 1)
                coef[k] = 1.0
                out[:, k] = legendre.legval(u, legendre.legder(coef))
        else:
            for k in range(1, self.degree + 1):
                out[:, k] = k * u ** (k - 1)
        return out * du_dq

    def coefficient_units(self):
        if self.over != "position":
            return [(self.unit_scale, self.unit)] * self.size
        return [(self.unit_scale / self.position_scale ** k,
                 self.unit if k == 0 else f"{self.unit}/{self.position_unit}" + (f"^{k}" if k > 1 else ""))
                for k in range(self.degree + 1)]

    def to_spec(self, coefficients):
        table = {"kind": self.family}
        if self.family == "monomial":
            table["over"] = self.over
        coefficients = np.asarray(coefficients, float) / self.unit_scale
        if self.over == "position":
            table["position_unit"] = self.position_unit
            # stored SI per metre**k; written per position_unit**k
            coefficients = coefficients * self.position_scale ** np.arange(self.degree + 1)
        table[f"coefficients_{self.unit}"] = [float(c) for c in coefficients]
        return table

    keys = frozenset({"coefficients", "over", "position_unit"})

    @classmethod
    def from_spec(cls, table, site):
        family, where, travel = table["kind"], site.where, site.travel
        _needs_position(site, family)
        si, unit, factor, key = site.value(table, "coefficients")
        if si.size == 0:
            raise SpecError(f"{where}.{key}: needs at least one coefficient")
        if si.size > MAX_COEFFICIENTS:
            raise SpecError(f"{where}.{key}: {si.size} coefficients; a polynomial takes at most {MAX_COEFFICIENTS} "
                            "(use a table for finer detail)")
        over = text(table, "over", where, default="travel")
        if family == "legendre" and over != "travel":
            raise SpecError(f"{where}: legendre polynomials are defined over the travel only")
        if over not in ("travel", "position"):
            raise SpecError(f"{where}.over: must be 'travel' or 'position', got {over!r}")
        if over == "travel" and (travel is None or not np.all(np.isfinite(travel))):
            raise SpecError(f"{where}: a polynomial over the travel needs a bounded travel")
        position_unit, position_scale = None, 1.0
        if over != "position" and "position_unit" in table:
            raise SpecError(f"{where}.position_unit: only a monomial over = 'position' has one")
        if over == "position":
            position_unit = text(table, "position_unit", where,
                                 default="mm" if site.position_quantity == "length" else "deg")
            position_scale = scale(position_unit, site.position_quantity, f"{where}.position_unit")
            si = si / position_scale ** np.arange(si.size)
        return cls(si.size - 1, family, over, travel, unit, factor, position_unit, position_scale), si


#: a cubic table's spline may reach at most this many times the largest |value| at its nodes
#: between them (its Lebesgue constant: about 2 on even nodes, 6 with spacings of 1:4; nodes
#: 0.01 mm apart among 50 mm steps give 1,900, and once swung a 0-9 um table to -80 ... +90 um)
MAX_SWING = 10.0


def spline_swing(nodes: np.ndarray, boundary: str) -> tuple[float, int]:
    """How far a cubic spline through given nodes can swing beyond its node values: the largest
    sum of the absolute values of its cardinal functions between the nodes (its Lebesgue
    constant), sampled at eight points per interval, and the interval where it is largest.

    Parameters
    ----------
    nodes : ndarray, shape (n,)
        Strictly increasing positions.
    boundary : str
        "not-a-knot" or "natural".

    Returns
    -------
    tuple of (float, int)
        The factor, and the index of the interval (between nodes k and k + 1).
    """
    n = len(nodes)
    spline = CubicSpline(nodes, np.eye(n), bc_type=boundary)
    worst, where = 0.0, 0
    step = max(1, 2_000_000 // (8 * n * n))   # intervals per evaluation: about 2e6 numbers at once
    for k0 in range(0, n - 1, step):
        k1 = min(n - 1, k0 + step)
        u = np.linspace(0.0, 1.0, 8, endpoint=False)
        x = (nodes[k0:k1, None] + u * np.diff(nodes)[k0:k1, None]).ravel()
        sums = np.abs(spline(x)).sum(axis=1).reshape(k1 - k0, 8).max(axis=1)
        k = int(np.argmax(sums))
        if sums[k] > worst:
            worst, where = float(sums[k]), k0 + k
    return worst, where


@dataclass(frozen=True, eq=False)
class Table(LinearTerm):
    """Values at target positions (as a laser interferometer measures them), interpolated.

    ``interpolation`` is "linear" or "cubic" (a cubic spline, ``boundary`` "not-a-knot" or
    "natural"). Coefficients n0..nK are the values at the nodes. Outside the node range
    the end pieces are extended, which only happens where extrapolation was asked for.

    Attributes
    ----------
    nodes : ndarray, shape (K,)
        The target positions, strictly increasing [m or rad].
    interpolation : str
        "linear" or "cubic".
    boundary : str
        The cubic spline's end condition, "not-a-knot" or "natural".
    unit : str
        The display unit of the values in the spec (``um``, ``arcsec``).
    unit_scale : float
        SI per display unit.
    position_unit : str
        The display unit of the positions in the spec (``mm``, ``deg``).
    position_scale : float
        SI per ``position_unit``.

    Notes
    -----
    The methods of :class:`~volerr_pin.model.Term` (documented there) do here:

    - ``basis``: the interpolation's cardinal functions (one per node) at the axis positions.
    - ``basis_derivative``: the derivative of :meth:`basis` with respect to the axis position.
    - ``to_spec``: the spec table: ``interpolation``, ``positions_<unit>``, ``values_<unit>``
      and, for a cubic table, ``boundary``.
    - ``from_spec``: read a table from its spec table, checking its nodes (strictly increasing,
      covering the travel unless ``extrapolate``), its memory and, for a cubic one, the spline's
      swing (at most :data:`MAX_SWING`).
    """

    nodes: np.ndarray
    interpolation: str
    boundary: str
    unit: str
    unit_scale: float
    position_unit: str
    position_scale: float
    kind = "table"

    @property
    def local_names(self):  # type: ignore[override]
        """Names of the coefficients, ``n0`` ... ``n<K-1>``: the values at the nodes."""
        return tuple(f"n{k}" for k in range(len(self.nodes)))

    @cached_property
    def _spline(self):
        eye = np.eye(len(self.nodes))
        if self.interpolation == "linear":
            return make_interp_spline(self.nodes, eye, k=1)
        return CubicSpline(self.nodes, eye, bc_type=self.boundary, extrapolate=True)

    def basis(self, ctx):
        return self._spline(_check_position(self, ctx, "table"))

    def basis_derivative(self, ctx):
        return self._spline.derivative()(_check_position(self, ctx, "table"))

    def to_spec(self, coefficients):
        table = {
            "kind": "table",
            "interpolation": self.interpolation,
            f"positions_{self.position_unit}": [float(x / self.position_scale) for x in self.nodes],
            f"values_{self.unit}": [float(c / self.unit_scale) for c in coefficients],
        }
        if self.interpolation == "cubic":
            table["boundary"] = self.boundary
        return table

    keys = frozenset({"positions", "values", "interpolation", "boundary", "extrapolate"})

    @classmethod
    def from_spec(cls, table, site):
        where, travel = site.where, site.travel
        _needs_position(site, "table")
        nodes, punit, pscale, pkey = site.value(table, "positions", site.position_quantity)
        values, unit, factor, _ = site.value(table, "values")
        interpolation = text(table, "interpolation", where, default="cubic")
        if interpolation not in ("linear", "cubic"):
            raise SpecError(f"{where}.interpolation: must be 'linear' or 'cubic', got {interpolation!r}")
        minimum = 2 if interpolation == "linear" else 4
        if nodes.size < minimum:
            raise SpecError(f"{where}.{pkey}: {interpolation} interpolation needs at "
                            f"least {minimum} positions, got {nodes.size}")
        if values.size != nodes.size:
            raise SpecError(f"{where}: {nodes.size} positions but {values.size} values")
        try:  # the splines of every node's unit vector and their swing check: 96 n^2 bytes measured at its peak
            require_memory(TABLE_BYTES_PER_NODE_PAIR * nodes.size**2, f"{where}.{pkey}: a table of {nodes.size:,} positions")
        except InputError as err:
            raise SpecError(str(err)) from None
        if np.any(np.diff(nodes) <= 0):
            k = int(np.flatnonzero(np.diff(nodes) <= 0)[0])
            raise SpecError(f"{where}.{pkey}: positions must be strictly increasing, got {nodes[k] / pscale:g} "
                            f"then {nodes[k + 1] / pscale:g} {punit} (entries {k + 1} and {k + 2})")
        if interpolation == "linear" and "boundary" in table:
            raise SpecError(f"{where}.boundary: only a cubic table has a boundary condition")
        boundary = text(table, "boundary", where, default="not-a-knot")
        if boundary not in ("not-a-knot", "natural"):
            raise SpecError(f"{where}.boundary: must be 'not-a-knot' or 'natural', got {boundary!r}")
        if interpolation == "cubic":
            swing, k = spline_swing(nodes, boundary)
            if swing > MAX_SWING:
                gaps = np.diff(nodes)
                c = int(np.argmin(gaps))
                raise SpecError(
                    f"{where}.{pkey}: the cubic spline through the values swings to {swing:.3g} times their largest "
                    f"size between {nodes[k] / pscale:g} and {nodes[k + 1] / pscale:g} {punit}, more than "
                    f"{MAX_SWING:g}: its nodes {nodes[c] / pscale:g} and {nodes[c + 1] / pscale:g} {punit} (entries "
                    f"{c + 1} and {c + 2}) are {gaps[c] / pscale:.4g} {punit} apart against a median spacing of "
                    f"{float(np.median(gaps)) / pscale:.4g} {punit}; merge nodes that close or give "
                    "interpolation = 'linear'")
        extrapolate = table.get("extrapolate", False)
        if not isinstance(extrapolate, bool):
            raise SpecError(f"{where}.extrapolate: must be true or false")
        if travel is not None and not extrapolate:
            tol = 1e-9 * max(1.0, abs(travel[1] - travel[0]))
            if nodes[0] > travel[0] + tol or nodes[-1] < travel[1] - tol:
                raise SpecError(
                    f"{where}: the table covers {nodes[0] / pscale:g}..{nodes[-1] / pscale:g} {punit} but the "
                    f"travel is {travel[0] / pscale:g}..{travel[1] / pscale:g} {punit}; extend it or set "
                    "extrapolate = true")
        return cls(nodes, interpolation, boundary, unit, factor, punit, pscale), values


def _needs_position(site: TermSite, kind: str) -> None:
    if site.position_quantity is None:
        raise SpecError(f"{site.where}: a {kind} term needs an axis position, but this component "
                        "belongs to a body without an axis (use kind = 'constant')")
