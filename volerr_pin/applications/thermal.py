"""Thermal drift from displacement sensors, and grey prediction models (after the five-axis
study, seed 003 in the docs' references).

**Spindle 5-point method.** Sensors 1 and 3 read the x displacement of a test mandrel at
two axial positions ``l1`` apart (sensor 1 the nearer to the tool point, at distance ``l``
from it), sensors 2 and 4 read y likewise (``l2`` apart), sensor 5 reads the axial
displacement. Fitting a straight line through each pair (derived here; the paper prints
``dSx = s3 - s1`` and ``tilt = (s3 - s1) l / l1``, which are the pair difference and its
effect at the tool):

    tilt_x = (s3 - s1) / l1,  tilt_y = (s4 - s2) / l2          (rad: slope of the mandrel)
    dx = s1 - tilt_x l,       dy = s2 - tilt_y l               (drift at the tool point)
    dz = -s5                                                  (growth towards the work)

so the paper's ``(s3 - s1) l / l1`` is the tilt's share of the drift at the tool.

**Feed-axis 6-point method.** Three sensor pairs, each reading one direction against a
reference sensor: ``dX = s8 - s9``, ``dY = s6 - s11``, ``dZ = s7 - s10``.

**Grey models** (Deng's grey system theory). GM(1,1) fits ``x0(k) + a z1(k) = b`` on the
accumulated series ``x1``; GM(1,N) adds the accumulated driving series:
``x0_1(k) + a z1_1(k) = sum_i b_i x1_i(k)``. The background value is
``z1(k) = lam x1(k) + (1 - lam) x1(k-1)``, ``lam = 0.5`` in the classic models. Seed 003's
"variable weight" GM(1,n) is reconstructed here (the paper gives no formula) as GM(1,N) with
the background weight ``lam`` chosen on the fitted data to minimise the one-step error, as in
GM(1,1;lambda) models. Predictions of GM(1,N) use the exact recursion of its grey
difference equation, ``x0_1(k) = (sum_i b_i x1_i(k) - a x1_1(k-1)) / (1 + a lam)``, rather
than the approximate time response.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..base import InputError


def spindle_five_point(s1, s2, s3, s4, s5, l: float, l1: float, l2: float) -> dict:
    """Thermal drift and tilt of a spindle from five displacement sensors.

    Any consistent length unit for the readings; ``l``, ``l1``, ``l2`` in one unit; tilts in
    rad when the readings and lengths share a unit. See the module docstring for the formulas.

    Parameters
    ----------
    s1, s2, s3, s4, s5 : array_like, shape (n,) or scalar
        Sensor readings: s1, s3 the x displacement of the test mandrel at two axial positions
        (s1 the nearer to the tool point), s2, s4 the y displacement likewise, s5 the axial
        displacement [length unit].
    l : float
        Distance of sensor 1 (and 2) from the tool point [length unit], >= 0.
    l1 : float
        Axial distance between sensors 1 and 3 [length unit], > 0.
    l2 : float
        Axial distance between sensors 2 and 4 [length unit], > 0.

    Returns
    -------
    dict of str to ndarray
        ``dx``, ``dy``, ``dz`` (drift at the tool point) [length unit], ``tilt_x``,
        ``tilt_y`` (slopes of the mandrel in the xz and yz planes) [rad] and
        ``tilt_share_x``, ``tilt_share_y`` (the paper's ``(s3 - s1) l / l1``: the tilts'
        effect at the tool) [length unit]; each of the readings' shape.

    Raises
    ------
    InputError
        Unless l1 > 0, l2 > 0 and l >= 0 are finite and the readings are finite.
    """
    s1, s2, s3, s4, s5 = (np.asarray(s, dtype=float) for s in (s1, s2, s3, s4, s5))
    if not (l1 > 0 and l2 > 0 and l >= 0 and all(np.isfinite(v) for v in (l, l1, l2))):
        raise InputError(f"spindle five-point method needs finite l1 > 0, l2 > 0 and l >= 0; got {l1}, {l2}, {l}",
                         parameters=("l1", "l2", "l"))
    _finite(s1=s1, s2=s2, s3=s3, s4=s4, s5=s5)
    tilt_x = (s3 - s1) / l1
    tilt_y = (s4 - s2) / l2
    return {"dx": s1 - tilt_x * l, "dy": s2 - tilt_y * l, "dz": -s5, "tilt_x": tilt_x,
            "tilt_y": tilt_y, "tilt_share_x": (s3 - s1) * l / l1, "tilt_share_y": (s4 - s2) * l / l2}


def feed_axis_six_point(s6, s7, s8, s9, s10, s11) -> dict:
    """Thermal drift of a feed axis from three sensor pairs (seed 003's 6-point method).

    ``dX = s8 - s9``, ``dY = s6 - s11``, ``dZ = s7 - s10``.

    Parameters
    ----------
    s6, s7, s8, s9, s10, s11 : array_like, shape (n,) or scalar
        Sensor readings, any one length unit.

    Returns
    -------
    dict of str to ndarray
        ``dx``, ``dy``, ``dz``: the drift, in the readings' unit and shape.

    Raises
    ------
    InputError
        If a reading is not a finite number.
    """
    s6, s7, s8, s9, s10, s11 = (np.asarray(s, dtype=float) for s in (s6, s7, s8, s9, s10, s11))
    _finite(s6=s6, s7=s7, s8=s8, s9=s9, s10=s10, s11=s11)
    return {"dx": s8 - s9, "dy": s6 - s11, "dz": s7 - s10}


def _finite(**arrays: np.ndarray) -> None:
    """Refuse a reading that is not a finite number, naming its parameter."""
    for name, array in arrays.items():
        if not np.all(np.isfinite(array)):
            raise InputError(f"{name} holds a value that is not a finite number", parameters=(name,))


def _ago(x: np.ndarray) -> np.ndarray:
    return np.cumsum(x, axis=0)


def _background(x1: np.ndarray, lam: float) -> np.ndarray:
    return lam * x1[1:] + (1.0 - lam) * x1[:-1]


@dataclass(frozen=True)
class GM11:
    """GM(1,1): development coefficient ``a``, grey input ``b``, first value ``x0_1``.

    Attributes
    ----------
    a : float
        Development coefficient.
    b : float
        Grey input (unit of the series).
    x0_1 : float
        First value of the shifted series.
    shift : float
        Added to the series before fitting (and removed from predictions).
    """

    a: float
    b: float
    x0_1: float
    shift: float = 0.0

    @classmethod
    def fit(cls, x0, shift: float | None = None) -> "GM11":
        """Fit on a series.

        Parameters
        ----------
        x0 : array_like, shape (n,)
            The series, n >= 4, any unit.
        shift : float, optional
            Added before and removed after, as grey models need positive data (default: none
            if all values are positive, else ``1 - min``).

        Returns
        -------
        GM11
            The model (least squares with background weight 0.5).

        Raises
        ------
        InputError
            If ``x0`` is not 1-D with at least 4 finite values, or the development coefficient
            is zero.
        """
        x0 = np.asarray(x0, dtype=float)
        if x0.ndim != 1 or x0.size < 4:
            raise InputError(f"GM(1,1) needs a 1-D series of at least 4 values, got shape {x0.shape}",
                             parameters=("x0",))
        _finite(x0=x0)
        if shift is None:
            shift = 0.0 if x0.min() > 0 else 1.0 - float(x0.min())
        x = x0 + shift
        x1 = _ago(x)
        B = np.column_stack([-_background(x1, 0.5), np.ones(x.size - 1)])
        (a, b), *_ = np.linalg.lstsq(B, x[1:], rcond=None)
        if abs(a) < 1e-300:
            raise InputError("GM(1,1): development coefficient a is zero")
        return cls(float(a), float(b), float(x[0]), float(shift))

    def accumulated(self, n: int) -> np.ndarray:
        """x1_hat(k), k = 1..n: the time response (x0(1) - b/a) e^{-a (k-1)} + b/a.

        Parameters
        ----------
        n : int
            Number of values.

        Returns
        -------
        ndarray, shape (n,)
            The accumulated (shifted) series predicted.
        """
        k = np.arange(n)
        return (self.x0_1 - self.b / self.a) * np.exp(-self.a * k) + self.b / self.a

    def predict(self, n: int) -> np.ndarray:
        """x0_hat(k), k = 1..n (the first ``len(data)`` fit, the rest forecast).

        Parameters
        ----------
        n : int
            Number of values.

        Returns
        -------
        ndarray, shape (n,)
            Predicted series, in its own unit (the shift removed).
        """
        x1 = self.accumulated(n)
        return np.r_[x1[0], np.diff(x1)] - self.shift


@dataclass(frozen=True)
class GM1N:
    """GM(1,N) with background weight ``lam`` (0.5: classic; other: variable weight).

    Attributes
    ----------
    a : float
        Development coefficient.
    b : ndarray, shape (N - 1,)
        Driving coefficients, one per driving series (target unit per driver unit).
    lam : float
        Background weight in [0, 1].
    """

    a: float
    b: np.ndarray
    lam: float

    @classmethod
    def fit(cls, target, drivers, lam: float | None = 0.5, batches=None) -> "GM1N":
        """Fit on the target series and driving series.

        Parameters
        ----------
        target : array_like, shape (n,)
            The target series.
        drivers : array_like, shape (n, N - 1) or (n,)
            The driving series.
        lam : float or None, default 0.5
            Background weight; None chooses it in [0, 1] (steps of 0.01) minimising the one-step
            error (variable weight).
        batches : array_like, shape (n,), optional
            Labels of separate experiments: accumulation restarts in each.

        Returns
        -------
        GM1N
            The model (least squares over all batches).

        Raises
        ------
        InputError
            If the shapes do not match, there are fewer than N + 2 rows, a value is not
            finite, or ``lam`` is outside [0, 1].
        """
        y = np.asarray(target, dtype=float)
        X = np.asarray(drivers, dtype=float)
        if X.ndim == 1:
            X = X[:, None]
        if y.ndim != 1 or X.shape[0] != y.size or y.size < X.shape[1] + 3:
            raise InputError(f"GM(1,N) needs n > N + 2 rows; got target {y.shape}, drivers {X.shape}",
                             parameters=("target", "drivers"))
        _finite(target=y, drivers=X)
        if lam is not None and not 0.0 <= lam <= 1.0:
            raise InputError(f"lam must be in [0, 1], got {lam}", parameters=("lam",))
        labels = np.zeros(y.size, dtype=int) if batches is None else np.asarray(batches)
        parts = [(y[labels == b], X[labels == b]) for b in np.unique(labels)]
        if lam is None:
            grid = np.linspace(0.0, 1.0, 101)
            errors = [cls._fit(parts, g)._one_step_error(parts) for g in grid]
            return cls._fit(parts, float(grid[int(np.argmin(errors))]))
        return cls._fit(parts, float(lam))

    @classmethod
    def _fit(cls, parts, lam):
        rows, rhs = [], []
        for y, X in parts:
            y1, X1 = _ago(y), _ago(X)
            rows.append(np.column_stack([-_background(y1, lam), X1[1:]]))
            rhs.append(y[1:])
        coef, *_ = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)
        return cls(float(coef[0]), coef[1:].copy(), lam)

    def _one_step_error(self, parts) -> float:
        res = np.concatenate([self.one_step(y, X)[1:] - y[1:] for y, X in parts])
        return float(np.sqrt(np.mean(res**2)))

    def one_step(self, target, drivers) -> np.ndarray:
        """x0_hat(k) from the measured history up to k - 1 and the drivers at k.

        Parameters
        ----------
        target : array_like, shape (n,)
            Measured target series (one experiment).
        drivers : array_like, shape (n, N - 1) or (n,)
            Driving series.

        Returns
        -------
        ndarray, shape (n,)
            One-step-ahead predictions; the first is the measured first value.
        """
        y = np.asarray(target, dtype=float)
        X1 = _ago(np.atleast_2d(np.asarray(drivers, dtype=float).T).T)
        y1 = _ago(y)
        out = np.empty_like(y)
        out[0] = y[0]
        out[1:] = (X1[1:] @ self.b - self.a * y1[:-1]) / (1.0 + self.a * self.lam)
        return out

    def simulate(self, first: float, drivers) -> np.ndarray:
        """x0_hat(k), k = 1..n, from the first target value and the drivers only.

        The recursion runs on its own accumulated predictions.

        Parameters
        ----------
        first : float
            First target value.
        drivers : array_like, shape (n, N - 1) or (n,)
            Driving series.

        Returns
        -------
        ndarray, shape (n,)
            Simulated target series.
        """
        X1 = _ago(np.atleast_2d(np.asarray(drivers, dtype=float).T).T)
        out = np.empty(X1.shape[0])
        out[0] = first
        acc = first
        for k in range(1, X1.shape[0]):
            out[k] = (X1[k] @ self.b - self.a * acc) / (1.0 + self.a * self.lam)
            acc += out[k]
        return out
