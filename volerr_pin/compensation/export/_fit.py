"""Table values that leave the smallest error, by least squares through the model.

Sampling each component error at the nodes (:meth:`Compensation.naive`) ignores how the
errors combine at the tool: angular errors times their Abbe offsets, errors of one axis seen
along another, the tool length. The fit instead chooses every value at once so that the
simulated residual (:func:`volerr_pin.compensation.export._simulate.residuals`) over the zone's points is
smallest in the least-squares sense:

    minimise  sum_i |p_actual(q_i + c_i(v)) - p_nominal(q_i)|^2 + lambda |v - v_naive|^2

The residual is linear in the corrections to first order, and the corrections are linear in
the values ``v`` (exactly for tables, to first order for a controller's model), so each step
is one sparse linear least-squares problem with the exact tool-point Jacobian of the actual
machine, built and factorised once (the design changes with the values only by products of
errors); two or three steps on the exact residual reach the machine's non-linearity at the
nanometre level. The tiny ridge ``lambda`` (1e-9 of the largest diagonal of the normal
matrix) only settles values no point can tell apart (the same constant in two tables of one
axis), towards the naive ones; it moves determined values by far less than a nanometre. The
points come at least eight per value (:func:`volerr_pin.compensation.export.export_tables`), so every node
is well inside the data.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg

from ...model import Machine
from ...base import require_memory
from .._points import MachineInputs
from ._protocol import Compensation
from ._simulate import residuals, tip_jacobian
from ._zone import Points

__all__ = ["RIDGE", "fit"]

#: ridge towards the naive values, relative to the largest diagonal of the normal matrix
RIDGE = 1e-9
#: above this many values the normal equations are solved sparse
DENSE_LIMIT = 3000


def _design(inputs: MachineInputs, compensation: Compensation, points: Points, setpoints: np.ndarray
            ) -> sp.csr_matrix:
    """(3N, P): d residual / d values = J_tip(setpoints) @ d correction / d values."""
    n, n_axes = points.q.shape
    J = tip_jacobian(inputs, setpoints, points)                                   # (N, 3, n_axes)
    rows = np.repeat(np.arange(3 * n), n_axes)
    cols = (np.arange(n)[:, None, None] * n_axes + np.arange(n_axes)[None, None, :]).repeat(3, axis=1).ravel()
    blockdiag = sp.csr_matrix((J.ravel(), (rows, cols)), shape=(3 * n, n * n_axes))
    return (blockdiag @ compensation.basis(points.q, points.directions, points.tool)).tocsr()


def _factor(normal: sp.spmatrix):
    """A solver of ``normal x = b`` (Cholesky when dense enough and positive, else LU)."""
    if normal.shape[0] <= DENSE_LIMIT:
        dense = normal.toarray()
        try:
            chol = scipy.linalg.cho_factor(dense)
            return lambda rhs: scipy.linalg.cho_solve(chol, rhs)
        except np.linalg.LinAlgError:
            lu = scipy.linalg.lu_factor(dense)
            return lambda rhs: scipy.linalg.lu_solve(lu, rhs)
    lu = scipy.sparse.linalg.splu(normal.tocsc())
    return lu.solve


def fit(machine: Machine, compensation: Compensation, points: Points, *, iterations: int = 6,
        tol: float = 1e-11) -> Compensation:
    """The values of ``compensation`` that make the simulated residual over ``points``
    smallest (see the module docstring).

    Parameters
    ----------
    machine : Machine
        The machine (its state included).
    compensation : Compensation
        The layout (tables or model) whose values are chosen; its current values are ignored.
    points : Points
        Commanded positions, motion directions and tools the residual is summed over.
    iterations : int, default 6
        Steps at most.
    tol : float, default 1e-11
        Stop when a step changes no value by more than this [m, rad].

    Returns
    -------
    Compensation
        The same layout with the fitted values.
    """
    prior = compensation.naive(machine)
    v_prior = prior.values
    if v_prior.size == 0:
        return prior
    n_axes = points.q.shape[1]
    require_memory(len(points) * (3 * n_axes + 3) * 8 * max(8, v_prior.size // 50) + 8.0 * v_prior.size ** 2,
                   f"fitting {v_prior.size} table values over {len(points)} points", ("points", "nodes"))
    inputs = MachineInputs(machine)
    current = prior
    factor = None
    for _ in range(iterations):
        v = current.values
        r = residuals(inputs, current, points).ravel()
        if factor is None:
            # the design changes with the values only by products of errors (1e-4 relative): it is
            # built and factorised once, and the steps iterate on the exact residual (chord method)
            setpoints = points.q + current.correction(points.q, points.directions, points.tool)
            A = _design(inputs, current, points, setpoints)
            normal = (A.T @ A).tocsr()
            ridge = RIDGE * max(float(normal.diagonal().max()), 1e-300)
            factor = _factor(normal + ridge * sp.identity(v.size, format="csr"))
        step = factor(-(A.T @ r) - ridge * (v - v_prior))
        current = current.with_values(v + step)
        if np.abs(step).max() < tol:
            break
    return current
