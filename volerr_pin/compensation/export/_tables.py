"""Tables that change axis set-points: what per-axis, cross, plane and direction-dependent
compensations have in common.

A :class:`Table` adds to the set-point of one axis (its *output*) a value read at the
commanded positions of one or two axes (its *inputs*): linearly interpolated between nodes
(bilinearly over a plane), or held in steps (Fanuc's sections), the end values held outside
the nodes. A directional table holds one set of values for each direction the first input
moves in; a one-way table (Siemens' ``_DIRECTION`` = +1 or -1) applies only while it moves that
way. Values are always the *correction added to the commanded position*, SI, whatever the
file says (error or correction, um or 0.1 um): each format converts at its files.

:class:`SetpointTables` is the compensation a controller applies with such tables: the sum
of the tables' corrections, linear in their values, which is what the fit works on.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from ...base import InputError
from ...model import Machine, component_values
from .._points import MachineInputs
from ._protocol import Compensation

__all__ = ["SetpointTables", "Table", "fixed", "interpolation_weights", "quantised"]


def interpolation_weights(nodes: np.ndarray, x: np.ndarray, step: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Which nodes a table reads at ``x`` and with what weights.

    Linear: the two nodes around ``x`` with weights (1 - t, t); outside the nodes the end
    node with weight 1 (end values held), as LinuxCNC's comp table (sentinel entries at
    -/+ infinity with zero slope) and every other controller here do. Step: the node at or
    below ``x`` (the first node below the table).

    Parameters
    ----------
    nodes : ndarray, shape (n,)
        Strictly increasing node positions [m, rad].
    x : ndarray, shape (N,)
        Positions read [m, rad].
    step : bool, default False
        Piecewise constant instead of linear.

    Returns
    -------
    index : ndarray of int, shape (N, 2)
        Node indices.
    weight : ndarray, shape (N, 2)
        Their weights (summing to 1).
    """
    nodes = np.asarray(nodes, dtype=float)
    x = np.asarray(x, dtype=float)
    n = len(nodes)
    if n == 1:
        return np.zeros((len(x), 2), dtype=int), np.column_stack([np.ones(len(x)), np.zeros(len(x))])
    i = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, n - 2)
    if step:
        k = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, n - 1)
        return np.column_stack([k, k]), np.column_stack([np.ones(len(x)), np.zeros(len(x))])
    t = np.clip((x - nodes[i]) / (nodes[i + 1] - nodes[i]), 0.0, 1.0)
    return np.column_stack([i, i + 1]), np.column_stack([1.0 - t, t])


@dataclass(frozen=True, eq=False)
class Table:
    """One compensation table: a correction of the output axis' set-point read at the
    commanded positions of the input axes.

    Attributes
    ----------
    output : int
        Index (into ``machine.axes``) of the axis whose set-point it changes.
    inputs : tuple of int
        Indices of the axes whose commanded positions it reads (one, or two for a plane).
    nodes : tuple of ndarray
        Node positions of each input, strictly increasing [m, rad].
    values : ndarray
        Corrections added to the set-point at the nodes [m, rad]; shape ``(2, n1[, n2])`` for a
        directional table (positive, negative motion of the first input), else ``(n1[, n2])``.
        For a plane the first node index is the first input's.
    directional : bool
        One set of values per direction of motion of the first input.
    only : int
        +1 or -1: the table applies only while the first input moves that way; 0: always.
    step : bool
        Piecewise constant (held from each node to the next) instead of linear.
    free : ndarray of bool
        Which values the fit may choose (same shape as ``values``); the others stay as given
        (Fanuc's zero at the reference position).
    tied : bool
        A directional table whose two directions hold the same values (the file has both
        columns, the machine no reversal error to tell them apart): the fit chooses one set.
    label : str
        What the table is, for reports (e.g. ``"Z(Y)"``: Z corrected as a function of Y).
    """

    output: int
    inputs: tuple[int, ...]
    nodes: tuple[np.ndarray, ...]
    values: np.ndarray
    directional: bool = False
    only: int = 0
    step: bool = False
    free: np.ndarray | None = None
    tied: bool = False
    label: str = ""

    def __post_init__(self):
        nodes = tuple(np.asarray(n, dtype=float) for n in self.nodes)
        object.__setattr__(self, "nodes", nodes)
        shape = ((2,) if self.directional else ()) + tuple(len(n) for n in nodes)
        values = np.asarray(self.values, dtype=float)
        if values.shape != shape:
            raise InputError(f"table {self.label}: values have shape {values.shape}, expected {shape}")
        object.__setattr__(self, "values", values)
        free = np.ones(shape, dtype=bool) if self.free is None else np.asarray(self.free, dtype=bool).copy()
        if self.tied:
            if not self.directional:
                raise InputError(f"table {self.label}: only a directional table can tie its directions")
            free[1] = False
            values = values.copy()
            values[1] = values[0]
            object.__setattr__(self, "values", values)
        object.__setattr__(self, "free", free)
        for k, n in enumerate(nodes):
            if len(n) < 1 or np.any(np.diff(n) <= 0):
                raise InputError(f"table {self.label}: nodes of input {k} do not increase strictly")

    @property
    def size(self) -> int:
        """Number of values the fit chooses (int)."""
        return int(self.free.sum())

    def with_values(self, values: np.ndarray) -> "Table":
        """A copy with other values (the full array, same shape).

        Parameters
        ----------
        values : ndarray
            The values [m, rad].

        Returns
        -------
        Table
            The copy.
        """
        return replace(self, values=np.asarray(values, dtype=float))

    def _weights(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N, k) flat indices into one direction's grid and their weights."""
        idx0, w0 = interpolation_weights(self.nodes[0], q[:, self.inputs[0]], self.step)
        if len(self.inputs) == 1:
            return idx0, w0
        idx1, w1 = interpolation_weights(self.nodes[1], q[:, self.inputs[1]], self.step)
        n1 = len(self.nodes[1])
        flat = (idx0[:, :, None] * n1 + idx1[:, None, :]).reshape(len(q), -1)
        return flat, (w0[:, :, None] * w1[:, None, :]).reshape(len(q), -1)

    def basis(self, q: np.ndarray, directions: np.ndarray) -> sp.csr_matrix:
        """The correction at each point as a linear map of the table's values.

        Parameters
        ----------
        q : ndarray, shape (N, n_axes)
            Commanded positions [m, rad].
        directions : ndarray, shape (N, n_axes)
            +1 / -1 motion directions.

        Returns
        -------
        scipy.sparse.csr_matrix, shape (N, values.size)
            Row i: the weights of the values (all of them, flattened in C order) in the
            correction of the output axis at point i.
        """
        n = len(q)
        flat, w = self._weights(q)
        grid = int(np.prod([len(k) for k in self.nodes]))
        d = directions[:, self.inputs[0]]
        if self.directional and not self.tied:
            flat = flat + np.where(d > 0, 0, grid)[:, None]
        if self.only:
            w = w * (d == self.only)[:, None]
        rows = np.repeat(np.arange(n), flat.shape[1])
        return sp.csr_matrix((w.ravel(), (rows, flat.ravel())), shape=(n, self.values.size))

    def correction(self, q: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """The table's correction of its output axis at each point.

        Parameters
        ----------
        q : ndarray, shape (N, n_axes)
            Commanded positions [m, rad].
        directions : ndarray, shape (N, n_axes)
            +1 / -1 motion directions.

        Returns
        -------
        ndarray, shape (N,)
            Correction added to the output axis' set-point [m, rad].
        """
        return self.basis(q, directions) @ self.values.ravel()


@dataclass(frozen=True, eq=False)
class SetpointTables(Compensation):
    """A controller's axis compensation: the sum of its tables' set-point corrections.

    Attributes
    ----------
    tables : tuple of Table
        The tables, in the order the files list them.
    n_axes : int
        Number of machine axes.
    notes : tuple of str
        Facts about the layout for the report (e.g. which master each cross table uses).
    kind : str
        The kind of tables, as the format names it (``"joint"``, ``"ssfk"``, ...).

    Notes
    -----
    The methods of :class:`~volerr_pin.compensation.export.Compensation` (documented there) do
    here:

    - ``values``: the values the fit chooses, all tables concatenated (ndarray of shape (P,),
      SI).
    - ``with_values``: a copy with other free values (as :attr:`values` orders them).
    - ``basis``: d correction / d values: the correction of every axis at every point as a
      linear map of the free values (exact: tables are linear in their values).
    - ``correction``: the set-point corrections the controller adds at each commanded position.
    - ``naive``: the tables filled by sampling the component errors at their nodes, as a
      commissioning engineer would from single-axis measurements: a table correcting axis ``s`` as
      a function of axis ``m`` holds minus the component error along ``s`` of axis ``m`` (``-EXX``
      for X's own table, ``-EZY`` for Z as a function of Y; minus the sum over both masters of a
      plane), the other axes at mid travel; directional and one-way tables take the component in
      their direction (a one-way table only the part that changes with the direction). Where the
      format fixes some values (Fanuc's zero at the reference position), the whole table is
      shifted to meet them, as the measured errors would be taken relative to that point.
    - ``contents``: everything the files say about the tables, values included: for comparing
      what was written with what was read back.
    - ``axis_nodes``: the node positions each axis' tables read it at (the first table with that
      axis as its first input), None for an axis no table reads.
    - ``describe``: one line per table: ``"Z(Y)"`` with its nodes, direction and range of
      values.
    """

    tables: tuple[Table, ...]
    n_axes: int
    notes: tuple[str, ...] = field(default=())
    kind: str = ""

    @property
    def values(self) -> np.ndarray:
        parts = [t.values[t.free] for t in self.tables]
        return np.concatenate(parts) if parts else np.zeros(0)

    def with_values(self, values: np.ndarray) -> "SetpointTables":
        values = np.asarray(values, dtype=float)
        out, start = [], 0
        for t in self.tables:
            full = t.values.copy()
            full[t.free] = values[start:start + t.size]
            start += t.size
            out.append(t.with_values(full))
        return replace(self, tables=tuple(out))

    def basis(self, q: np.ndarray, directions: np.ndarray, tool: np.ndarray) -> sp.csr_matrix:
        n = len(q)
        blocks = []
        for t in self.tables:
            b = t.basis(q, directions)[:, np.flatnonzero(t.free.ravel())].tocoo()
            blocks.append(sp.csr_matrix((b.data, (b.row * self.n_axes + t.output, b.col)),
                                        shape=(n * self.n_axes, t.size)))
        if not blocks:
            return sp.csr_matrix((n * self.n_axes, 0))
        return sp.hstack(blocks, format="csr")

    def correction(self, q: np.ndarray, directions: np.ndarray, tool: np.ndarray) -> np.ndarray:
        out = np.zeros((len(q), self.n_axes))
        for t in self.tables:
            out[:, t.output] += t.correction(q, directions)
        return out

    def naive(self, machine: Machine) -> "SetpointTables":
        out = []
        for t in self.tables:
            values = _naive_values(machine, t)
            fixed = ~t.free
            if t.tied:
                fixed[1] = False
            if fixed.any():                  # values fixed by the format (Fanuc's zero at the reference)
                values = values - np.mean(values[fixed] - t.values[fixed])
            out.append(t.with_values(np.where(t.free, values, t.values)))
        return replace(self, tables=tuple(out))

    def contents(self) -> tuple:
        return tuple((t.output, t.inputs, t.directional, t.only, t.step, t.nodes, t.values) for t in self.tables)

    def axis_nodes(self) -> list[np.ndarray | None]:
        out: list[np.ndarray | None] = [None] * self.n_axes
        for t in self.tables:
            for k, j in enumerate(t.inputs):
                if out[j] is None:
                    out[j] = t.nodes[k]
        return out

    def describe(self, machine: Machine) -> list[str]:
        lines = []
        for t in self.tables:
            nodes = " x ".join(str(len(n)) for n in t.nodes)
            if t.directional:
                kind = " per direction" if not np.array_equal(t.values[0], t.values[1]) else ", both directions alike"
            else:
                kind = f" (only moving {'+' if t.only > 0 else '-'})" if t.only else ""
            unit, scale = ("um", 1e6) if machine.axis_kinds[t.output] == "linear" else ("arcsec", 206264.80624709636)
            lines.append(f"{t.label}: {nodes} nodes{kind}, corrections {fixed(t.values.min() * scale, 3, True)} .. "
                         f"{fixed(t.values.max() * scale, 3, True)} {unit}")
        return lines


def _axis_letter(name: str) -> str | None:
    return name if name in ("X", "Y", "Z", "A", "B", "C") else None


def _component(inputs: MachineInputs, direction: str | None, axis: str, q: np.ndarray, sign: float | None
               ) -> np.ndarray:
    """Component error E<direction><axis> at ``q`` [m, rad] (zero where the machine has none),
    with every axis moving ``sign`` (None: the mean of the two directions)."""
    model = inputs.model
    name = f"E{direction}{axis}" if direction else None
    if name not in model.component_names:
        return np.zeros(len(q))
    column = model.component_names.index(name)

    def values(directions):
        return component_values(model, q, inputs.theta, inputs.covariates(len(q), directions))[:, column]

    if sign is None and "directions" in model.covariates_used:
        return 0.5 * (values(np.ones(q.shape)) + values(-np.ones(q.shape)))
    return values(None if sign is None else np.full(q.shape, float(sign)))


def _naive_values(machine: Machine, table: Table) -> np.ndarray:
    """Minus the component errors of the table's inputs along its output axis, at the nodes."""
    inputs = MachineInputs(machine)
    direction = _axis_letter(machine.axes[table.output])
    grids = np.meshgrid(*table.nodes, indexing="ij")
    shape = grids[0].shape
    q = np.tile(machine.mid_travel, (grids[0].size, 1))
    for k, j in enumerate(table.inputs):
        q[:, j] = grids[k].ravel()

    def at(sign):
        total = np.zeros(len(q))
        for j in table.inputs:
            total += _component(inputs, direction, machine.axes[j], q, sign)
        return -total.reshape(shape)

    if table.directional:
        return np.stack([at(+1), at(-1)])
    if table.only:
        return at(table.only) - at(None)
    return at(None)


def quantised(values: np.ndarray, unit: float) -> np.ndarray:
    """``values`` rounded to whole multiples of ``unit`` (half away from zero, as a file
    written with that many digits holds them).

    Parameters
    ----------
    values : ndarray
        Values [SI].
    unit : float
        The format's unit [SI].

    Returns
    -------
    ndarray
        The rounded values [SI].
    """
    counts = np.asarray(values, dtype=float) / unit
    return np.sign(counts) * np.floor(np.abs(counts) + 0.5) * unit


def fixed(value: float, digits: int, plus: bool = False) -> str:
    """``value`` with ``digits`` decimals, never ``-0.000`` (a rounded zero is written unsigned,
    or ``+0.000`` with ``plus``).

    Parameters
    ----------
    value : float
        The number.
    digits : int
        Decimals.
    plus : bool, default False
        Always write the sign.

    Returns
    -------
    str
        The text.
    """
    value = float(value)
    if round(value, digits) == 0.0:
        value = 0.0
    return f"{value:+.{digits}f}" if plus else f"{value:.{digits}f}"
