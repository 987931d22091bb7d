"""Many coefficient vectors at the same points, in few kernel calls.

:func:`~volerr_pin.model.volumetric_error` evaluates one coefficient vector per call; a Monte
Carlo study evaluates thousands at the same points. Most of a call on a few hundred points is
the error terms' bases, which do not depend on the coefficients. :class:`Evaluator` takes them
once per block of points: the joint values are ``v(theta) = v(0) + sum_k theta_k g_k``
(each coefficient moves the one error joint of its component, by its basis function
``g_k``), exact for terms linear in their coefficients. A machine with non-linear
coefficients (time constants, periods) gets its joint values from
:func:`~volerr_pin.model.joint_values` for every vector instead. The kinematics is then one
call of the compiled kernel (:func:`volerr_pin.model._kinematics.pose_error`, on the chain of
the machine's model, ``machine.model.chain``) for many vectors at once, :data:`CALL_POINTS`
point-vector pairs at a time. The result equals :func:`~volerr_pin.model.volumetric_error` to
rounding (the tests hold it to 1e-15 m).

The evaluator trusts its points as the algorithms do: positions checked where they entered
(:func:`~volerr_pin.studies.make_points`); the covariates are the machine's state,
checked once per block of points.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from ..model import Machine, _kinematics as K, check_covariates, joint_values

__all__ = ["CALL_POINTS", "Evaluator"]

#: point-vector pairs per kernel call (memory: n_joints x CALL_POINTS doubles)
CALL_POINTS = 16384
#: bytes of bases an evaluator keeps for the blocks it saw last
CACHE_BYTES = 256 << 20


class Evaluator:
    """Position errors of a machine for many coefficient vectors at the same points.

    Parameters
    ----------
    machine : Machine
        The machine (its state is used; its coefficients are not).
    """

    def __init__(self, machine: Machine):
        self.machine = machine
        self.model = machine.model
        self.state = machine.state
        self.chain = self.model.chain
        self.linear = not self.model.nonlinear_parameters
        self.nv = self.model.nv
        self._cache: OrderedDict = OrderedDict()
        self._cached_bytes = 0

    def _covariates(self, n: int):
        """The covariates of ``n`` points: the machine's state at every one."""
        return check_covariates(self.model, n, None, self.state)

    def _basis(self, key, q: np.ndarray):
        """(v0 (nv, nb), rows (P,), G (P, nb)): joint values at zero coefficients, the joint
        each coefficient moves and its basis there."""
        if key is not None and key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        model, cov = self.model, self._covariates(len(q))
        P = len(model.names)
        zero = np.zeros(P)
        v0 = joint_values(model, q, zero, cov).T
        rows = np.zeros(P, dtype=np.int64)
        G = np.zeros((P, len(q)))
        for k in range(P):
            unit = zero.copy()
            unit[k] = 1.0
            d = joint_values(model, q, unit, cov).T - v0
            moved = np.flatnonzero(np.any(d != 0.0, axis=1))
            if len(moved) > 1:  # not one joint per coefficient: take every vector as it comes
                self.linear = False
                return None
            rows[k] = moved[0] if len(moved) else 0
            G[k] = d[rows[k]]
        entry = (v0, rows, G)
        if key is not None:
            size = v0.nbytes + G.nbytes
            self._cache[key] = entry
            self._cached_bytes += size
            while self._cached_bytes > CACHE_BYTES and len(self._cache) > 1:
                _, (a, _, b) = self._cache.popitem(last=False)
                self._cached_bytes -= a.nbytes + b.nbytes
        return entry

    def _values(self, q, thetas, basis, cov) -> np.ndarray:
        """(nv, n, nb) joint values of every vector at every point (``cov`` the points'
        covariates, read when there is no basis)."""
        n, nb = len(thetas), len(q)
        if basis is None:
            return np.stack([joint_values(self.model, q, t, cov).T for t in thetas], axis=1)
        v0, rows, G = basis
        V = np.repeat(v0[:, None, :], n, axis=1)
        for r in np.unique(rows):
            ks = np.flatnonzero(rows == r)
            V[r] += thetas[:, ks] @ G[ks]
        return V.reshape(self.nv, n, nb)

    def errors(self, q: np.ndarray, thetas: np.ndarray, *, key=None) -> np.ndarray:
        """Position errors ``e(q_i, theta_s)[:3]`` for every vector and point.

        Parameters
        ----------
        q : ndarray, shape (nb, n_axes)
            NC positions [m, rad], checked (:func:`~volerr_pin.model.check_q`; outside the
            travel where the caller allows it).
        thetas : ndarray, shape (n, P)
            Coefficient vectors [SI], finite.
        key : hashable, optional
            Names the block ``q`` (the same key for the same points): its bases are kept for
            the next call (up to :data:`CACHE_BYTES`).

        Returns
        -------
        ndarray, shape (n, nb, 3)
            dx, dy, dz [m] (exact kinematics).
        """
        thetas = np.atleast_2d(np.asarray(thetas, dtype=float))
        n, nb = len(thetas), len(q)
        basis = self._basis(key, q) if self.linear else None
        cov = None if basis is not None else self._covariates(nb)
        out = np.empty((n, nb, 3))
        step = max(1, CALL_POINTS // max(nb, 1))
        for s0 in range(0, n, step):
            s1 = min(n, s0 + step)
            V = self._values(q, thetas[s0:s1], basis, cov)
            e = K.pose_error(self.chain, V.reshape(self.nv, -1), None)
            out[s0:s1] = e[:, :3].reshape(s1 - s0, nb, 3)
        return out


_EVALUATORS: dict = {}


def evaluator_of(key: str, machine: Machine) -> Evaluator:
    """The evaluator of a machine, made once per process.

    Parameters
    ----------
    key : str
        Identifies the machine (:attr:`PortableMachine.key`).
    machine : Machine
        The machine.

    Returns
    -------
    Evaluator
        The cached evaluator.
    """
    found = _EVALUATORS.get(key)
    if found is None:
        if len(_EVALUATORS) > 4:
            _EVALUATORS.clear()
        found = _EVALUATORS[key] = Evaluator(machine)
    return found
