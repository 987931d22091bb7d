"""The design of a planned campaign: the weighted sensitivities identify will have, unit by
unit, and the D-optimal choice of units.

For every candidate unit, the instrument's own measurement objects give the observation
rows (:mod:`volerr_pin.measurements`); their sensitivities are identify's
(:func:`volerr_pin.fit.identify.predict_observations`, first-order model as identify's
identifiability analysis uses), divided by the rows' standard deviations. A nuisance term
that acts on the rows of one unit only (a run's zero, a circle's set-up) is projected out of
that unit's rows: the Schur complement, exactly what a joint fit leaves for the other
columns. A nuisance term shared by several units (a tracker's placement) stays a column, so
the information matrix ``M = D^T D`` of a selection is the one identify's fit has, and its
inverse the covariance of the estimates at the stated noise.

The choice of units maximises ``log det M`` over the columns the whole candidate pool can
identify (D-optimal), or minimises ``trace(W M^-1)``, the mean predicted variance of the
volumetric error over points of the zone (I-optimal, ``W`` the zone's sensitivities'
second moment), columns scaled to unit mean square per unit (D-optimality is unchanged by the
scaling; it keeps the regularisation ``eps I`` neutral): a greedy forward selection by the
matrix determinant lemma, ``log det(M + X_u^T X_u) = log det M + log det(I + X_u M^-1 X_u^T)``,
(for I, the Sherman-Morrison-Woodbury drop of the trace), then Fedorov exchange passes (Fedorov 1972, *Theory of Optimal Experiments*; the
"modified Fedorov" exchange of Cook and Nachtsheim 1980, *Technometrics* 22(3)) that swap a
chosen unit for a candidate while ``det M`` grows. Written here rather than taken from a
library: the design packages for Python (pyDOE3, dexpy) build designs for polynomial
response-surface models over a box, not for blocks of rows of a given sensitivity matrix.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...base import InputError, require_memory
from ...fit import Analysis, analyse
from ...fit.identify import rows_of, stack_blocks, typical_sizes
from ...measurements import ObservationOptions
from ...model import check_covariates, check_parameters, sensitivity

__all__ = ["UnitDesign", "d_optimal", "information", "unit_design"]


@dataclass(frozen=True)
class UnitDesign:
    """The weighted design of candidate units.

    Attributes
    ----------
    rows : ndarray, shape (R, g + F)
        Weighted sensitivities [1 / SI unit of each column]: the ``g`` shared nuisance columns,
        then the ``F`` free coefficients; unit-own nuisance terms projected out; rows grouped
        by unit.
    starts : ndarray of int, shape (n_units + 1,)
        Unit ``u`` owns rows ``starts[u]:starts[u + 1]``.
    names : list of str
        Column names (nuisance names, then coefficient names).
    n_global : int
        Number ``g`` of shared nuisance columns.
    free : ndarray of int, shape (F,)
        Coefficient indices (into the machine's theta) of the other columns.
    typical : ndarray, shape (g + F,)
        Typical size of each column's coefficient (identify's zero test).
    """

    rows: np.ndarray
    starts: np.ndarray
    names: list
    n_global: int
    free: np.ndarray
    typical: np.ndarray

    @property
    def n_units(self) -> int:
        """Number of units (int)."""
        return len(self.starts) - 1

    def take(self, units: np.ndarray) -> np.ndarray:
        """The rows of some units, stacked.

        Parameters
        ----------
        units : ndarray of int
            Unit indices.

        Returns
        -------
        ndarray, shape (rows, g + F)
            Their rows.
        """
        idx = np.concatenate([np.arange(self.starts[u], self.starts[u + 1]) for u in units] or [np.zeros(0, int)])
        return self.rows[idx]

    def analyse(self, units: np.ndarray | None = None, rtol: float = 1e-9) -> Analysis:
        """Identifiability of the columns from some units (default all), as identify finds it.

        Parameters
        ----------
        units : ndarray of int, optional
            The units (default: every candidate).
        rtol : float, default 1e-9
            Relative tolerance of the tests (:func:`~volerr_pin.fit.analyse`).

        Returns
        -------
        Analysis
            Kept and dependent columns and the groups.
        """
        A = self.rows if units is None else self.take(units)
        return analyse(A, self.names, protected=self.n_global, rtol=rtol, what="the planned measurements",
                       typical=self.typical)


def unit_design(machine, instrument, setup, units: list, free: np.ndarray) -> UnitDesign:
    """The weighted design of ``units`` (see the module docstring).

    Parameters
    ----------
    machine : Machine
        The machine.
    instrument : Instrument
        The instrument (:class:`~volerr_pin.studies.plan.Instrument`).
    setup : Setup
        Zone, noise, targets, station.
    units : list
        The instrument's units.
    free : ndarray of int, shape (F,)
        Coefficients to identify (indices into the machine's theta).

    Returns
    -------
    UnitDesign
        Rows grouped by unit.

    Raises
    ------
    InputError
        If there are no units, or the design would not fit in the free memory.
    """
    if not len(units):
        raise InputError("no candidate measurements: the zone, the targets or the tracker's line of sight "
                         "leave none", parameters=("zone",))
    measurements, unit_of_point = instrument.measurements(machine, setup, units)
    sigma_um = setup.sigma * 1e6
    blocks = [m.observations(machine, ObservationOptions(sigma_um, sigma_um)) for m in measurements]
    n_rows = sum(len(b.point) for b in blocks)
    firsts = np.cumsum([0] + [len(b.q) for b in blocks])
    n_shared = sum(len(b.nuisance_terms) for b, f in zip(blocks, firsts)
                   if len(np.unique(_units_of(b, f, np.asarray(unit_of_point)))) > 1)
    require_memory(8.0 * n_rows * (n_shared + len(free) + 6) * 3,
                   f"the design of {len(units)} candidate {instrument.unit}s", ("candidates",))
    columns = check_parameters(machine.model, free)
    parts, first = [], 0
    for chunk in _chunks(blocks):   # blocks share no nuisance column: a chunk's nuisance matrix stays small
        parts.append(_chunk_design(machine, chunk, columns, np.asarray(unit_of_point), first))
        first += sum(len(b.q) for b in chunk)
    n_global = sum(p[1].shape[1] for p in parts)
    D = np.zeros((n_rows, n_global + len(free)))
    row_unit = np.concatenate([p[2] for p in parts])
    r = c = 0
    for A, G, _, _ in parts:
        D[r:r + len(A), c:c + G.shape[1]] = G
        D[r:r + len(A), n_global:] = A
        r, c = r + len(A), c + G.shape[1]
    order = np.argsort(row_unit, kind="stable")
    counts = np.bincount(row_unit, minlength=len(units))
    starts = np.concatenate([[0], np.cumsum(counts)])
    names = [n for p in parts for n in p[3]] + [machine.parameter_names[k] for k in free]
    return UnitDesign(D[order], starts, names, n_global, np.asarray(free, dtype=int),
                      typical_sizes(machine, machine.theta, free, n_global))


def _units_of(block, first: int, unit_of_point: np.ndarray) -> np.ndarray:
    """The unit of every row of a block whose points start at ``first`` in the stacked points."""
    return unit_of_point[np.asarray(block.point, dtype=int) + first]


def _chunks(blocks: list, rows: int = 20000) -> list[list]:
    """Consecutive blocks in groups of about ``rows`` rows (one block at least)."""
    out, current, size = [], [], 0
    for b in blocks:
        if current and size + len(b.point) > rows:
            out.append(current)
            current, size = [], 0
        current.append(b)
        size += len(b.point)
    return out + ([current] if current else [])


def _chunk_design(machine, blocks: list, free: np.ndarray, unit_of_point: np.ndarray, first: int):
    """Weighted sensitivities of some blocks (their positions checked where the measurements
    were made), each unit's own nuisance terms projected out; ``free`` checked indices.

    Returns ``(A, G, row_unit, names)``: the coefficients' rows (rows, F), the shared nuisance
    columns (rows, g), the unit of each row and the shared columns' names."""
    obs = stack_blocks(blocks, machine)
    model = machine.model
    cov = check_covariates(model, obs.n_points, obs.covariates, machine.state)
    S = sensitivity(model, obs.q, machine.theta, cov, columns=free, first_order=True)
    _, A = rows_of(obs.w, obs.point, np.zeros((obs.n_points, 6)), S)
    A = A / obs.sigma[:, None]
    N = obs.nuisance / obs.sigma[:, None]
    row_unit = unit_of_point[obs.point + first]
    owners = [np.unique(row_unit[N[:, c] != 0]) for c in range(N.shape[1])]
    local = np.array([len(o) <= 1 for o in owners], dtype=bool)
    D = np.hstack([N[:, ~local], A])
    N_local = N[:, local]
    for u in np.unique(row_unit):
        s = np.flatnonzero(row_unit == u)
        cols = np.flatnonzero(np.any(N_local[s] != 0, axis=0))
        if cols.size:
            Q, _ = np.linalg.qr(N_local[s][:, cols])
            raw = np.linalg.norm(D[s], axis=0)
            Ds = D[s] - Q @ (Q.T @ D[s])
            # what the nuisance absorbs whole is zero, not rounding noise that the
            # identifiability tests (relative to the median effect) would take for an effect
            Ds[:, np.linalg.norm(Ds, axis=0) <= 1e-10 * raw] = 0.0
            D[s] = Ds
    g = int(np.sum(~local))
    return D[:, g:], D[:, :g], row_unit, [n for n, keep in zip(obs.nuisance_names, ~local) if keep]


def information(design: UnitDesign, units: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """The information matrix ``D^T D`` of some units over some columns.

    Parameters
    ----------
    design : UnitDesign
        The candidates' design.
    units : ndarray of int
        The chosen units (repeats count twice).
    columns : ndarray of int
        Columns of the design.

    Returns
    -------
    ndarray, shape (len(columns), len(columns))
        ``D^T D`` [1 / (SI unit of column a x SI unit of column b)].
    """
    X = design.take(units)[:, columns]
    return X.T @ X


def _gains(X: np.ndarray, groups: list, Minv: np.ndarray, n_units: int, W: np.ndarray | None) -> np.ndarray:
    """The gain of adding each unit to a design of information ``M``, units of equal row count
    at once: D, ``log det(I + X_u Minv X_u^T)``; I (``W`` given), the drop of
    ``trace(W M^-1)``, ``trace((I + X_u Minv X_u^T)^-1 X_u Minv W Minv X_u^T)``."""
    Y = X @ Minv
    Z = None if W is None else Y @ W
    out = np.empty(n_units)
    for units, rows in groups:
        Xu, Yu = X[rows], Y[rows]                       # (n, r, p)
        B = np.einsum("urp,usp->urs", Yu, Xu) + np.eye(rows.shape[1])
        if Z is None:
            sign, logdet = np.linalg.slogdet(B)
            out[units] = np.where(sign > 0, logdet, -np.inf)
        else:
            C = np.einsum("urp,usp->urs", Yu, Z[rows])
            out[units] = np.trace(np.linalg.solve(B, C), axis1=1, axis2=2)
    return out


def d_optimal(design: UnitDesign, columns: np.ndarray, budget: int, *, eps: float = 1e-6, passes: int = 4,
              start: np.ndarray | None = None, zone: np.ndarray | None = None) -> np.ndarray:
    """``budget`` distinct units maximising ``log det`` of the information over ``columns``
    (D-optimal), or with ``zone`` minimising the mean predicted variance of the volumetric
    error over the zone, ``trace(W M^-1)`` (I-optimal); greedy forward selection, then
    Fedorov exchange passes (see the module docstring).

    Parameters
    ----------
    design : UnitDesign
        The candidates' design.
    columns : ndarray of int
        The columns of the criterion (the identifiable ones).
    budget : int
        Number of units to choose (at most the number of candidates).
    eps : float, default 1e-6
        Regularisation of the information before it has full rank (columns scaled to unit
        mean square per unit).
    passes : int, default 4
        Largest number of exchange passes (they stop when a pass improves nothing).
    start : ndarray of int, optional
        Units measured already: their information is counted, they are not chosen again.
    zone : ndarray, shape (Z, 3, len(columns)), optional
        Sensitivities of dx, dy, dz at points of the zone to the columns (zero for nuisance
        columns) [m per SI unit]: the criterion becomes I-optimal.

    Returns
    -------
    ndarray of int, shape (budget,)
        The chosen units, in the order chosen.

    Raises
    ------
    InputError
        If ``budget`` exceeds the candidates left.
    """
    n = design.n_units
    start = np.zeros(0, int) if start is None else np.asarray(start, dtype=int)
    if budget > n - len(np.unique(start)):
        raise InputError(f"budget {budget} exceeds the {n - len(np.unique(start))} candidate measurements "
                         "available (widen the zone or ask for more candidates)", parameters=("budget", "candidates"))
    X = design.rows[:, columns]
    norms = np.linalg.norm(X, axis=0)
    scale = np.where(norms > 0, norms, 1.0) / np.sqrt(n)
    X = X / scale
    W = None
    if zone is not None:   # the zone's weight in the scaled coefficients
        Sz = np.asarray(zone, dtype=float).reshape(-1, len(columns)) / scale
        W = Sz.T @ Sz / len(Sz)
        W /= np.trace(W) / len(columns)
    sizes = np.diff(design.starts)
    groups = []
    for r in np.unique(sizes):
        units = np.flatnonzero(sizes == r)
        groups.append((units, design.starts[units][:, None] + np.arange(r)[None, :]))
    p = X.shape[1]

    def info(u):
        Xu = X[design.starts[u]:design.starts[u + 1]]
        return Xu.T @ Xu

    base = eps * np.eye(p) + sum((info(u) for u in start), np.zeros((p, p)))
    available = np.ones(n, dtype=bool)
    available[start] = False
    chosen: list[int] = []
    M = base.copy()
    for _ in range(budget):
        g = _gains(X, groups, np.linalg.inv(M), n, W)
        g[~available] = -np.inf
        j = int(np.argmax(g))
        chosen.append(j)
        available[j] = False
        M += info(j)
    for _ in range(passes):
        improved = False
        for pos in range(budget):
            i = chosen[pos]
            M_without = M - info(i)
            g = _gains(X, groups, np.linalg.inv(M_without), n, W)
            own = g[i]
            g[~available] = -np.inf
            j = int(np.argmax(g))
            if g[j] > own + 1e-9 * max(1.0, abs(own)):
                chosen[pos] = j
                available[i], available[j] = True, False
                M = M_without + info(j)
                improved = True
        if not improved:
            break
    return np.array(chosen, dtype=int)
