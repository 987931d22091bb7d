"""How fast the residual along a compensated piece can bend: the bound that sizes the sampling.

Along a piece whose ends are compensated, the residual ``g(s)`` (the difference of actual and
desired pose, :meth:`~.solver.PoseMetric.difference`, as a function of the fraction ``s`` of
the piece) is nearly zero at both ends. Between samples ``1/(n+1)`` apart it cannot exceed
the sampled values by more than ``M / (8 (n+1)^2)``, where ``M`` bounds ``|g''|``. For a
straight piece of weighted length ``L`` in program coordinates

    M = (K + C D) L^2 + C' L V

where ``K`` [1/m] bounds the curvature of the error itself; ``D`` [m] is the larger weighted
compensation at the piece's ends (how far the commands are from the desired points) and
``V`` [m] how much the compensation changes from one end to the other. The nominal machine's
own curvature turns them into a bend: ``C`` [1/m^2] and ``C'`` [1/m] are zero on a Cartesian
machine; on a rotary head a compensation of the tool axis swings the tool tip along the move,
and near a singular pose the compensation changes fast. An arc also turns the error field's
slope ``S`` through its curvature: ``M`` gains ``3 S r theta^2`` (radius ``r``, sweep
``theta``). The constants are measured on the machine, in the programming mode, before
anything is compensated, on short probe pieces (two lengths, random places and directions)
compensated as a program's pieces are (to 1e-12 m, so that the point tolerance does not count
as curvature):

- ``K``: the largest ``8 |e(1/2) - (e(0) + e(1)) / 2| / L^2`` of the uncompensated error ``e``;
- ``C``, ``C'``: the smallest pair (linear programming, weighted by the median probe) with which
  ``C D + C' V / L`` covers every probe's excess of the compensated bend over the error's;
- ``S``: the largest change of the uncompensated error per unit length;

each times :data:`SAFETY`. Short features (a table's nodes, a lead screw's period) are seen
by the shorter probes; they raise ``K``, and every piece is then sampled (or split) finely
enough to see them. Near a singular pose of a rotary head the compensations (and ``D``) grow,
and so does the sampling. Weighted length: linear coordinates in metres, a rotary
coordinate's radian counts as far as it moves the tool (point, or tool axis times ``lever``).
"""

from __future__ import annotations

import math

import numpy as np

from ._programming import Programming
from ._solver import PointSolver, PoseMetric

__all__ = ["SAFETY", "Smoothness"]

#: factor on the measured curvature and slope
SAFETY = 3.0
#: probe lengths, as fractions of the weighted diagonal of the travel
PROBE_LENGTHS = (0.003, 0.03)


class Smoothness:
    """The curvature and slope bounds of one machine state and programming mode.

    Parameters
    ----------
    metric : PoseMetric
        Poses and residual measure.
    programming : Programming
        How program coordinates map to axis positions.
    method : str
        Point compensation method (as the pieces are compensated).
    probes : int, default 1024
        Probe pieces per length.
    seed : int, default 0
        Seed of the probe places and directions.

    Attributes
    ----------
    weights : ndarray, shape (n_axes,)
        Weight of each program coordinate in lengths: 1 for linear ones, the largest tool motion
        per radian for rotary ones [m per unit].
    curvature : float
        ``K`` [1/m].
    coupling : float
        ``C`` [1/m^2].
    turning : float
        ``C'`` [1/m].
    slope : float
        ``S`` [-].
    diagonal : float
        Weighted diagonal of the travel [m].
    """

    def __init__(self, metric: PoseMetric, programming: Programming, method: str, probes: int = 1024,
                 seed: int = 0):
        self.metric = metric
        self.programming = programming
        machine = metric.machine
        rng = np.random.default_rng(seed)
        travel = np.where(np.isfinite(machine.travel), machine.travel, np.array([-math.pi, math.pi]))
        span = travel[:, 1] - travel[:, 0]
        q = travel[:, 0] + 0.02 * span + 0.96 * span * rng.random((probes, len(machine.axes)))
        w0 = programming.to_words(q)
        self.weights = self._weights(w0[: min(probes, 256)])
        self.diagonal = float(np.linalg.norm(span * np.where(np.array(machine.axis_kinds) == "linear", 1.0,
                                                                self.weights)))
        exact = PointSolver(metric, method, tol=1e-12, tol_axis=1e-11, max_iter=12)
        probes_out = []
        for fraction in PROBE_LENGTHS:
            length = fraction * self.diagonal
            v = rng.normal(size=w0.shape)
            v /= np.linalg.norm(v, axis=1)[:, None]
            w1 = w0 + length * v / self.weights
            probes_out.append(self._probe(exact, w0, w1, length))
        own, excess, reach, change, slope = (np.concatenate(x) for x in zip(*probes_out))
        self.curvature = SAFETY * float(own.max(initial=0.0))
        self.slope = SAFETY * float(slope.max(initial=0.0))
        coupling, turning = _cover(excess, reach, change)
        self.coupling, self.turning = SAFETY * coupling, SAFETY * turning

    def _weights(self, w: np.ndarray) -> np.ndarray:
        """Largest motion of the nominal pose (point, and tool axis times lever) per unit of each
        program coordinate, by central differences; linear coordinates count 1."""
        metric, prog = self.metric, self.programming
        kinds = np.array(metric.machine.axis_kinds)
        weights = np.ones(w.shape[1])
        for j in np.flatnonzero(kinds != "linear"):
            h = 1e-4
            up, down = w.copy(), w.copy()
            up[:, j] += h
            down[:, j] -= h
            a1, p1 = metric.nominal(prog.to_axes(up))
            a0, p0 = metric.nominal(prog.to_axes(down))
            move = np.hypot(np.linalg.norm(p1 - p0, axis=1), metric.lever * np.linalg.norm(a1 - a0, axis=1))
            weights[j] = max(float(move.max()) / (2 * h), metric.lever)
        return weights

    def _probe(self, solver: PointSolver, w0: np.ndarray, w1: np.ndarray, length: float):
        """Per probe: the error's bend, the compensated bend's excess over it (both per L^2)
        [1/m], ``D`` [m], ``V / L`` [-] and the error's change per length [-]."""
        metric, prog = self.metric, self.programming
        n = len(w0)
        d = prog.to_axes(np.vstack([w0, w1, 0.5 * (w0 + w1)]))
        solved = solver.solve(d[: 2 * n])
        cw = prog.to_words(solved.c)
        c_mid = prog.to_axes(0.5 * (cw[:n] + cw[n:]))
        a_m, p_m = metric.nominal(d[2 * n:])
        g = metric.difference(*metric.actual(solved.c), solved.a_d, solved.p_d)
        g_mid = metric.difference(*metric.actual(c_mid), a_m, p_m)
        bend = 8 * np.linalg.norm(g_mid - 0.5 * (g[:n] + g[n:]), axis=1) / length**2
        e = metric.difference(*metric.actual(d), np.vstack([solved.a_d, a_m]), np.vstack([solved.p_d, p_m]))
        own = 8 * np.linalg.norm(e[2 * n:] - 0.5 * (e[:n] + e[n:2 * n]), axis=1) / length**2
        change = np.linalg.norm(e[n:2 * n] - e[:n], axis=1) / length
        delta = cw - np.vstack([w0, w1])
        reach = np.maximum(self.lengths(delta[:n]), self.lengths(delta[n:]))
        turn = self.lengths(delta[n:] - delta[:n]) / length
        excess = np.maximum(bend - own, 0.0)
        keep = np.isfinite(bend) & np.isfinite(own) & np.isfinite(change) & np.isfinite(reach) & np.isfinite(turn)
        return own[keep], excess[keep], reach[keep], turn[keep], change[keep]

    def lengths(self, delta: np.ndarray) -> np.ndarray:
        """Weighted lengths of straight pieces.

        Parameters
        ----------
        delta : ndarray, shape (P, n_axes)
            Change of the program coordinates along each piece [m, rad].

        Returns
        -------
        ndarray, shape (P,)
            Lengths [m].
        """
        return np.linalg.norm(delta * self.weights[None, :], axis=1)

    def bend(self, length: np.ndarray, reach: np.ndarray, change: np.ndarray, radius: np.ndarray | None = None,
             sweep: np.ndarray | None = None) -> np.ndarray:
        """``M``, the bound of ``|g''|`` over pieces (see the module docstring).

        Parameters
        ----------
        length : ndarray, shape (P,)
            Weighted lengths [m].
        reach : ndarray, shape (P,)
            ``D``: the larger weighted compensation at each piece's ends [m].
        change : ndarray, shape (P,)
            ``V``: the weighted change of the compensation from one end to the other [m].
        radius, sweep : ndarray, shape (P,), optional
            Radius [m] and sweep [rad] of arc pieces (0 for straight ones).

        Returns
        -------
        ndarray, shape (P,)
            [m].
        """
        m = (self.curvature + self.coupling * reach) * length**2 + self.turning * length * change
        if radius is not None:
            m = m + 3.0 * self.slope * radius * sweep**2
        return m


def _cover(excess: np.ndarray, reach: np.ndarray, turn: np.ndarray) -> tuple[float, float]:
    """The smallest ``(C, C')``, weighted by the median probe, with ``C D + C' V/L >= excess``
    for every probe (a linear program in two unknowns)."""
    big = excess > 0
    if not big.any():
        return 0.0, 0.0
    from scipy.optimize import linprog

    A = -np.column_stack([reach[big], turn[big]])
    scale = np.array([max(float(np.median(reach)), 1e-12), max(float(np.median(turn)), 1e-12)])
    fit = linprog(scale, A_ub=A, b_ub=-excess[big], bounds=[(0, None), (0, None)], method="highs")
    if fit.status != 0:  # never expected: fall back to covering with each term alone
        return float((excess / np.maximum(reach, 1e-12)).max()), float((excess / np.maximum(turn, 1e-12)).max())
    return float(fit.x[0]), float(fit.x[1])
