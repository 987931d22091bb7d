"""Thermal error models fitted to sensor time series (``volerr thermal-fit``).

Methods:

- ``linear`` with ``lag`` K: K = 0 is the static model ``target(t) ~ 1 + sensors(t)`` (what a
  compensation can use online); K >= 1 the one-step-ahead model
  ``target(t) ~ 1 + sensors(t-1) + target(t-1) + ... + target(t-K)``. Lags never cross
  from one file (batch) into the next.
- ``gm11``: GM(1,1) on the target alone; fitted values and held-out forecasts from its
  time response.
- ``gm1n``: GM(1,N) with the sensors as driving series; predictions one step ahead from its
  grey difference equation (the measured target history up to t-1 and the sensors at t),
  the same information as the linear model with lag 1. (Simulating the recursion from the
  first value alone is unstable over long series: ``GM1N.simulate``.)
- ``vwgm1n``: the variable-weight GM(1,N) (background weight chosen on the fitted rows).

Fit statistics are in the unit of the target column: ``r2`` and ``residual_se`` (RSS / (n - p))
on the fitted rows; ``rmse_holdout`` on the last ``holdout`` fraction of the rows, or on
separate test files.

A sensor that cannot be fitted - constant over the fitted rows, the same as another, or a
linear combination of a constant and the sensors before it (to 1e-6 of its variation) - has
no coefficient of its own: it is refused when asked for by name, and left out with a note
(``left_out``: sensor and reason) when the sensors are every other column. A constant target
has nothing to model and is refused.

A column named ``t`` or ``t_s`` is the time of each row in seconds (the measurement files'
convention, docs/measurements.md): it is not a sensor unless named as one, and the picture
draws over it.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from ..base import InputError, same_file
from ..measurements import SeriesData
from .thermal import GM11, GM1N

METHODS = ("linear", "gm11", "gm1n", "vwgm1n")
#: a sensor within this fraction of its variation of a linear combination of a constant and
#: other sensors has no coefficient of its own (exact collinearity, up to rounding in the file)
COLLINEAR = 1e-6

__all__ = ["METHODS", "thermal_fit"]


def _design(data: SeriesData, target: str, sensors: list[str], lag: int):
    """Rows usable for the linear model and its regressor matrix (constant first)."""
    y = data.columns[target]
    rows, X = [], []
    for b in np.unique(data.batch):
        idx = np.flatnonzero(data.batch == b)
        for j in range(lag, len(idx)):
            t = idx[j]
            source = idx[j - 1] if lag else t
            features = [1.0] + [data.columns[s][source] for s in sensors]
            features += [y[idx[j - k]] for k in range(1, lag + 1)]
            rows.append(t)
            X.append(features)
    return np.array(rows, dtype=int), np.array(X, dtype=float).reshape(len(rows), 1 + len(sensors) + lag)


def _stats(y, yhat, p):
    resid = y - yhat
    rss = float(resid @ resid)
    tss = float(((y - y.mean()) ** 2).sum())
    n = len(y)
    return {"r2": 1.0 - rss / tss if tss > 0 else math.nan,
            "residual_se": math.sqrt(rss / (n - p)) if n > p else math.nan}


#: columns that hold each row's time [s], not a sensor
TIME_COLUMNS = ("t", "t_s")


def thermal_fit(data: SeriesData, target: str, sensors=None, *, lag: int = 1, method: str = "linear",
                holdout: float = 0.0, test: SeriesData | None = None, rank_top: int = 5) -> dict:
    """Fit a thermal model of one column from the others (see the module docstring).

    Parameters
    ----------
    data : SeriesData
        The fit data (and, with ``holdout``, the held-out rows).
    target : str
        Column to model.
    sensors : list of str or str, optional
        Columns to model it from (default: every other column; those that cannot be fitted
        are left out and listed in ``left_out``).
    lag : int, default 1
        Linear method: 0 for the static model, K >= 1 for the one-step-ahead model with K
        lags of the target (reported None for the other methods).
    method : str, default "linear"
        "linear", "gm11", "gm1n" or "vwgm1n".
    holdout : float, default 0.0
        Fraction in [0, 1) of the last rows held out.
    test : SeriesData, optional
        Separate test files instead of ``holdout`` (not with "gm11").
    rank_top : int, default 5
        Number of sensors in the greedy sensor ranking.

    Returns
    -------
    dict
        The report fields (docs/reports.md): ``target``, ``method``, ``sensors``, ``lag``,
        ``n_fit``, ``r2``, ``residual_se``, ``n_holdout``, ``rmse_holdout`` (in the unit of
        the target column; None without held-out rows), ``left_out`` (default sensors that
        cannot be fitted: ``sensor`` and ``reason``), plus ``coefficients``,
        ``sensor_ranking`` (sensor and R^2 reached, by greedy forward selection) and the
        predictions ``fitted`` and ``predicted_holdout`` (lists).

    Raises
    ------
    InputError
        For an unknown ``target``, ``method`` or sensor, a sensor listed twice, the target
        among the sensors, sensors given to "gm11", a ``lag`` that is not an integer >= 0, a
        ``holdout`` out of range or given with ``test``, a negative ``rank_top``, test columns
        differing from the data's, a test file that is also a data file, a constant target, a sensor asked for by name that cannot
        be fitted (constant, a duplicate, or collinear with others), no sensor left for a
        model that needs one, too few usable rows, or a grey model that cannot be fitted
        (see :class:`~volerr_pin.applications.thermal.GM11`).
    """
    if target not in data.columns:
        raise InputError(f"target: no column '{target}' (columns: {', '.join(data.columns)})",
                         parameters=("target",))
    if method not in METHODS:
        raise InputError(f"method must be one of {', '.join(METHODS)}, got {method!r}", parameters=("method",))
    if isinstance(lag, bool) or not isinstance(lag, numbers.Integral):
        raise InputError(f"lag must be a whole number of rows, got {lag!r}", parameters=("lag",))
    if lag < 0:
        raise InputError(f"lag must be >= 0, got {lag}", parameters=("lag",))
    if isinstance(rank_top, bool) or not isinstance(rank_top, numbers.Integral) or rank_top < 0:
        raise InputError(f"rank_top must be an integer >= 0, got {rank_top!r}", parameters=("rank_top",))
    if not (isinstance(holdout, numbers.Real) and 0.0 <= holdout < 1.0):
        raise InputError(f"holdout must be a fraction in [0, 1), got {holdout}", parameters=("holdout",))
    if isinstance(sensors, str):  # one name, not its letters
        sensors = [sensors]
    named = bool(sensors)
    sensors = ([c for c in data.columns if c != target and c not in TIME_COLUMNS] if not sensors
               else list(sensors))
    unknown = [s for s in sensors if s not in data.columns]
    if unknown:
        raise InputError(f"sensors: no column(s) {', '.join(map(str, unknown))}", parameters=("sensors",))
    if target in sensors:
        raise InputError(f"sensors: the target '{target}' cannot also be a sensor", parameters=("sensors",))
    twice = sorted({s for s in sensors if sensors.count(s) > 1})
    if twice:
        raise InputError(f"sensors: '{twice[0]}' is listed twice", parameters=("sensors",))
    if method == "gm11" and named:
        raise InputError("sensors: gm11 models the target alone; give sensors to linear, gm1n or vwgm1n",
                         parameters=("sensors",))
    if test is not None and holdout:
        raise InputError("give either holdout or test files, not both", parameters=("holdout",))
    if test is not None and list(test.columns) != list(data.columns):
        raise InputError("the test files' columns differ from the data files'")
    if test is not None:
        shared = [t for t in test.sources if any(same_file(t, d) for d in data.sources)]
        if shared:
            raise InputError(f"test: {shared[0]} is also a data file; a test on the fitted rows says nothing "
                             "of prediction", parameters=("test",))
    # the fit set and the held-out set, in time order
    if test is not None:
        fit_data, held = data, test
    else:
        n_hold = int(round(holdout * data.n))
        cut = data.n - n_hold
        fit_data = _slice(data, slice(0, cut))
        held = _slice(data, slice(cut, data.n)) if n_hold else None
    y_fit = fit_data.columns[target]
    if fit_data.n < 2:
        if data.n - fit_data.n:
            raise InputError(f"holdout {holdout:g} leaves {fit_data.n} of {data.n} rows to fit",
                             parameters=("holdout",))
        raise InputError(f"{', '.join(data.sources)}: {data.n} row(s) of data; a model needs more")
    if np.ptp(y_fit) == 0:
        raise InputError(f"target: '{target}' is {y_fit[0]:g} in every fitted row; a constant has nothing to model",
                         parameters=("target",))
    left_out = _unfittable(fit_data, sensors)
    if left_out and named:
        sensor, reason = left_out[0]
        raise InputError(f"sensors: '{sensor}' is {reason}; it has no coefficient of its own, leave it out",
                         parameters=("sensors",))
    sensors = [s for s in sensors if s not in dict(left_out)]
    if method == "gm11":
        candidates, sensors = sensors, []
    else:
        candidates = sensors
    if not sensors and (method in ("gm1n", "vwgm1n") or (method == "linear" and lag == 0)):
        note = f" (left out: {', '.join(s for s, _ in left_out)})" if left_out else ""
        raise InputError(f"sensors: no sensor to model '{target}' from{note}", parameters=("sensors",))
    result = {"target": target, "method": method, "sensors": sensors,
              "lag": lag if method == "linear" else None,
              "left_out": [{"sensor": s, "reason": reason} for s, reason in left_out]}
    if method == "linear":
        rows, X = _design(fit_data, target, sensors, lag)
        y = fit_data.columns[target][rows]
        if len(rows) <= X.shape[1]:
            raise InputError(f"{len(rows)} usable rows for {X.shape[1]} coefficients; reduce lag"
                             + (" or holdout" if holdout else "") + " (or the sensors)",
                             parameters=("lag", "holdout") if holdout else ("lag",))
        names = ["constant"] + [f"{s}(t-1)" if lag else s for s in sensors] + \
                [f"{target}(t-{k})" for k in range(1, lag + 1)]
        dependent = _unfittable_columns(X, names)
        if dependent:
            j, reason = dependent[0]
            raise InputError(f"the model's column {names[j]} is {reason}; its coefficient "
                             "is not determined (leave out a sensor or change lag)", parameters=("lag",))
        coef, *_ = np.linalg.lstsq(X, y, rcond=None)
        fitted = X @ coef
        result.update({"n_fit": int(len(rows)), **_stats(y, fitted, X.shape[1])})
        result["coefficients"] = dict(zip(names, (float(c) for c in coef)))
        if held is not None:
            hrows, hX = _design(_join(fit_data, held) if test is None else held, target, sensors, lag)
            if test is None:  # one-step predictions may use the last fitted rows as history
                keep = hrows >= fit_data.n
                hrows, hX = hrows[keep] - fit_data.n, hX[keep]
            pred = hX @ coef
            actual = held.columns[target][hrows]
            result.update({"n_holdout": int(len(hrows)),
                           "rmse_holdout": float(np.sqrt(np.mean((actual - pred) ** 2))) if len(hrows) else None})
            result["predicted_holdout"] = pred.tolist()
        result["sensor_ranking"] = _rank_sensors(fit_data, target, sensors, lag, rank_top)
        result["fitted"] = fitted.tolist()
    else:
        y = fit_data.columns[target]
        needed = 4 if method == "gm11" else len(sensors) + 3
        if len(y) < needed:
            raise InputError(f"{len(y)} fitted rows; {method} needs at least {needed}"
                             + ("; reduce holdout" if holdout else ""),
                             parameters=("holdout",) if holdout else ())
        if method == "gm11":
            model = GM11.fit(y)
            fitted = model.predict(len(y))
            result.update({"n_fit": int(len(y)), **_stats(y, fitted, 2)})
            result["coefficients"] = {"a": model.a, "b": model.b, "shift": model.shift}
            if held is not None:
                if test is not None:
                    raise InputError("gm11 forecasts the same series; use holdout, not test files",
                                     parameters=("holdout",))
                pred = model.predict(len(y) + held.n)[len(y):]
                result.update({"n_holdout": held.n, "rmse_holdout": float(np.sqrt(np.mean(
                    (held.columns[target] - pred) ** 2)))})
                result["predicted_holdout"] = pred.tolist()
        else:
            X = np.column_stack([fit_data.columns[s] for s in sensors])
            model = GM1N.fit(y, X, lam=None if method == "vwgm1n" else 0.5, batches=fit_data.batch)
            fitted = _one_step(model, fit_data, target, sensors)
            result.update({"n_fit": int(len(y)), **_stats(y, fitted, 1 + len(sensors))})
            result["coefficients"] = {"a": model.a, "lambda": model.lam,
                                      **{f"b_{s}": float(b) for s, b in zip(sensors, model.b)}}
            if held is not None:
                if test is None:
                    pred = _one_step(model, _join(fit_data, held), target, sensors)[fit_data.n:]
                else:
                    pred = _one_step(model, held, target, sensors)
                result.update({"n_holdout": held.n, "rmse_holdout": float(np.sqrt(np.mean(
                    (held.columns[target] - pred) ** 2)))})
                result["predicted_holdout"] = pred.tolist()
        result["fitted"] = fitted.tolist()
        result["sensor_ranking"] = _rank_sensors(fit_data, target, candidates, 0, rank_top)
    result.setdefault("n_holdout", 0)
    result.setdefault("rmse_holdout", None)
    return result


def _unfittable_columns(X: np.ndarray, names: list[str]) -> list[tuple[int, str]]:
    """Columns of ``X`` (the first a constant) that have no coefficient of their own: constant,
    equal to an earlier column, or within :data:`COLLINEAR` of a linear combination of the
    earlier ones; as (column index, reason naming the others by ``names``). Each is judged
    against the columns kept before it."""
    n = X.shape[0]
    basis = [np.ones(n) / math.sqrt(n)]          # orthonormal basis of the kept columns
    kept: list[int] = [0]
    problems = []
    for j in range(1, X.shape[1]):
        x = X[:, j]
        if np.ptp(x) == 0:
            problems.append((j, f"constant ({x[0]:g} in every fitted row)"))
            continue
        twin = next((k for k in kept[1:] if np.array_equal(X[:, k], x)), None)
        if twin is not None:
            problems.append((j, f"the same as {names[twin]} in every fitted row"))
            continue
        r = x - x.mean()
        size = np.linalg.norm(r)
        for _ in range(2):                        # Gram-Schmidt, twice for round-off
            for q in basis:
                r = r - (q @ r) * q
        if np.linalg.norm(r) <= COLLINEAR * size:
            coef = np.linalg.lstsq(X[:, kept], x, rcond=None)[0]
            spread = np.abs(coef[1:]) * np.ptp(X[:, kept[1:]], axis=0)
            others = [names[k] for k, c in zip(kept[1:], spread) if c > COLLINEAR * np.ptp(x)]
            problems.append((j, f"a linear combination of a constant and {', '.join(others)}"))
            continue
        basis.append(r / np.linalg.norm(r))
        kept.append(j)
    return problems


def _unfittable(data: SeriesData, sensors: list[str]) -> list[tuple[str, str]]:
    """Sensors that cannot be fitted (see :func:`_unfittable_columns`) on ``data``'s rows."""
    if not sensors or data.n == 0:
        return []
    X = np.column_stack([np.ones(data.n)] + [data.columns[s] for s in sensors])
    return [(sensors[j - 1], reason)
            for j, reason in _unfittable_columns(X, ["constant"] + [f"'{s}'" for s in sensors])]


def _one_step(model: GM1N, data: SeriesData, target: str, sensors) -> np.ndarray:
    """GM(1,N) one-step-ahead predictions per batch (accumulation restarts in each batch)."""
    out = np.empty(data.n)
    for b in np.unique(data.batch):
        idx = np.flatnonzero(data.batch == b)
        X = np.column_stack([data.columns[s][idx] for s in sensors])
        out[idx] = model.one_step(data.columns[target][idx], X)
    return out


def _slice(data: SeriesData, rows: slice) -> SeriesData:
    return SeriesData(data.sources, {k: v[rows] for k, v in data.columns.items()}, data.batch[rows])


def _join(a: SeriesData, b: SeriesData) -> SeriesData:
    return SeriesData(a.sources, {k: np.r_[a.columns[k], b.columns[k]] for k in a.columns},
                      np.r_[a.batch, b.batch])


def _rank_sensors(data: SeriesData, target: str, sensors, lag: int, top: int) -> list[dict]:
    """Greedy forward selection: the sensors that, added one by one to the model with the
    target lags (if any), reduce the residual most; with the R^2 reached after each."""
    chosen: list[str] = []
    ranking = []
    remaining = list(sensors)
    for _ in range(min(top, len(sensors))):
        best = None
        for s in remaining:
            rows, X = _design(data, target, chosen + [s], lag)
            y = data.columns[target][rows]
            coef, *_ = np.linalg.lstsq(X, y, rcond=None)
            r2 = _stats(y, X @ coef, X.shape[1])["r2"]
            if best is None or r2 > best[1]:
                best = (s, r2)
        chosen.append(best[0])
        remaining.remove(best[0])
        ranking.append({"sensor": best[0], "r2": float(best[1])})
    return ranking
