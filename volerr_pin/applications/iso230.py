"""ISO 230-2:2014 evaluation of bidirectional (or unidirectional) positioning runs.

Definitions (x_ij = deviation at target i, approach j; n approaches per direction):
mean per direction x_i_up, x_i_dn; bidirectional mean x_i = (x_i_up + x_i_dn) / 2;
reversal B_i = x_i_up - x_i_dn, B = max |B_i|, B_mean = mean B_i; s = sample standard
deviation (n - 1); R_i_up = 4 s_i_up, R_i_dn = 4 s_i_dn,
R_i = max(2 s_i_up + 2 s_i_dn + |B_i|, R_i_up, R_i_dn), R_up = max R_i_up, R_dn = max R_i_dn,
R = max R_i; E_up = max x_i_up - min x_i_up (same down); E = max of all one-way means - min
of all one-way means; M = max x_i - min x_i; A_up = max(x_i_up + 2 s_i_up) -
min(x_i_up - 2 s_i_up) (same down); A = max over both directions of (x + 2s) - min over both
of (x - 2s). All values in the unit of the deviations.
"""

from __future__ import annotations

import numpy as np

from ..base import InputError
from ..measurements import Runs


def evaluate(targets, directions, deviations, unit: str = "um", source: str = "") -> dict:
    """ISO 230-2 parameters of a positioning run.

    Targets are grouped to 1e-9 (of their unit).

    Parameters
    ----------
    targets, directions, deviations : array_like, shape (N,)
        Target position, approach direction (+1 / -1) and deviation (actual - target) of
        every approach, in any consistent units.
    unit : str, default "um"
        Unit of the deviations, reported back.
    source : str, optional
        File name prefixed to error messages.

    Returns
    -------
    dict
        ``unit``, ``A``, ``A_up``, ``A_down``, ``B``, ``B_mean``, ``E``, ``E_up``, ``E_down``,
        ``M``, ``R``, ``R_up``, ``R_down`` (bidirectional values are None for a
        unidirectional run), ``bidirectional``, ``n_targets`` and ``positions``: per target
        ``target``, ``n_up``, ``n_down``, ``mean_up``, ``mean_down``, ``mean``, ``s_up``,
        ``s_down``, ``B``, ``R_up``, ``R_down``, ``R``. Values in the unit of the deviations.

    Raises
    ------
    InputError
        If the arrays are not 1-D of one length or hold no value, a value is not a finite
        number, a direction is not +1 or -1, or a target has fewer than 2 approaches in a
        direction that is run.
    """
    where = f"{source}: " if source else ""
    arrays = {}
    for name, value in (("targets", targets), ("directions", directions), ("deviations", deviations)):
        try:
            arrays[name] = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"{where}{name} must be numbers", parameters=(name,)) from None
    targets, directions, deviations = arrays.values()
    if not (targets.shape == directions.shape == deviations.shape) or targets.ndim != 1:
        raise InputError(f"{where}targets, directions and deviations must be 1-D of one length",
                         parameters=("targets", "directions", "deviations"))
    if targets.size == 0:
        raise InputError(f"{where}targets: no approach given", parameters=("targets",))
    for name, array in arrays.items():
        bad = np.flatnonzero(~np.isfinite(array))
        if bad.size:
            raise InputError(f"{where}{name}[{bad[0]}] is {array[bad[0]]}; values must be finite",
                             parameters=(name,))
    if not np.all(np.isin(directions, (-1.0, 1.0))):
        raise InputError(f"{where}directions must be +1 or -1")
    keys = np.round(targets, 9)
    levels = np.unique(keys)
    present = {d: np.any(directions == d) for d in (1.0, -1.0)}
    bidirectional = present[1.0] and present[-1.0]
    used = [d for d in (1.0, -1.0) if present[d]]
    stats = {d: [] for d in used}
    positions = []
    for level in levels:
        entry = {"target": float(level)}
        for d in used:
            x = deviations[(keys == level) & (directions == d)]
            label = "up" if d > 0 else "down"
            if x.size < 2:
                raise InputError(f"{where}target {level:g}: {x.size} approach(es) in the "
                                 f"{'positive' if d > 0 else 'negative'} direction; at least 2 are needed "
                                 "for a standard deviation (ISO 230-2 asks for 5)")
            mean, s = float(x.mean()), float(x.std(ddof=1))
            stats[d].append((mean, s))
            entry.update({f"n_{label}": int(x.size), f"mean_{label}": mean, f"s_{label}": s,
                          f"R_{label}": 4.0 * s})
        if bidirectional:
            (mu, su), (md, sd) = stats[1.0][-1], stats[-1.0][-1]
            b = mu - md
            entry.update({"mean": (mu + md) / 2.0, "B": b,
                          "R": max(2 * su + 2 * sd + abs(b), 4 * su, 4 * sd)})
        else:
            entry["mean"] = stats[used[0]][-1][0]
        positions.append(entry)
    result = {"unit": unit, "bidirectional": bool(bidirectional), "n_targets": int(len(levels))}
    for d in (1.0, -1.0):
        label = "up" if d > 0 else "down"
        if d not in stats:
            result.update({f"A_{label}": None, f"E_{label}": None, f"R_{label}": None})
            continue
        m = np.array([v[0] for v in stats[d]])
        s = np.array([v[1] for v in stats[d]])
        result[f"A_{label}"] = float(np.max(m + 2 * s) - np.min(m - 2 * s))
        result[f"E_{label}"] = float(m.max() - m.min())
        result[f"R_{label}"] = float(np.max(4 * s))
    if bidirectional:
        mu, su = (np.array([v[i] for v in stats[1.0]]) for i in (0, 1))
        md, sd = (np.array([v[i] for v in stats[-1.0]]) for i in (0, 1))
        b = mu - md
        result.update({
            "A": float(max(np.max(mu + 2 * su), np.max(md + 2 * sd))
                       - min(np.min(mu - 2 * su), np.min(md - 2 * sd))),
            "B": float(np.max(np.abs(b))),
            "B_mean": float(np.mean(b)),
            "E": float(max(mu.max(), md.max()) - min(mu.min(), md.min())),
            "M": float(np.max((mu + md) / 2) - np.min((mu + md) / 2)),
            "R": float(max(p["R"] for p in positions)),
        })
    else:
        m = np.array([v[0] for v in stats[used[0]]])
        result.update({"A": None, "B": None, "B_mean": None, "E": None, "R": None,
                       "M": float(m.max() - m.min())})
    result["positions"] = positions
    return result


def evaluate_runs(runs: Runs) -> dict:
    """:func:`evaluate` on a positioning-run file (values in the file's units).

    Parameters
    ----------
    runs : Runs
        A positioning run (no component).

    Returns
    -------
    dict
        The fields of :func:`evaluate` plus ``target_unit``, ``source`` and ``n_cycles``.

    Raises
    ------
    InputError
        If ``runs`` is a component run, or as :func:`evaluate`.
    """
    if runs.component is not None:
        raise InputError(f"{runs.source}: this is a {runs.component} run; ISO 230-2 evaluates "
                         "positioning runs (column deviation_um or deviation_arcsec)")
    result = evaluate(runs.file_target, runs.direction, runs.file_value, runs.unit, runs.source)
    result["target_unit"] = runs.target_unit
    result["source"] = runs.source
    result["n_cycles"] = int(len(np.unique(runs.cycle)))
    return result
