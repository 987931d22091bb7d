"""Plain-data descriptions of a machine, for the CLI and for reports (engineering units)."""

from __future__ import annotations

import math

import numpy as np

from ..base import ARCSEC_PER_RAD, UM_PER_M, InputError, axis_scale
from ._machine import Machine


def machine_info(machine: Machine) -> dict:
    """Axes, chains, error terms by kind, travels: what ``volerr info`` prints.

    Travels are in mm (linear) or deg (rotary); the range of each component error is taken
    over its axis' travel (201 points, the other axes at mid travel, endless axes over -pi to
    pi), in um (linear) or arcsec (angular). A machine whose terms read covariates and that
    has no state gets the ranges of the terms that read none.

    Parameters
    ----------
    machine : Machine
        The machine.

    Returns
    -------
    dict
        The fields of docs/reports.md: ``machine``, ``description``, ``source``, ``spec``,
        ``urdf``, ``tool_frame``, ``workpiece_frame``, ``axes`` (per axis ``name``,
        ``joint``, ``kind``, ``unit``, ``travel``, ``chain``, ``sign``, ``errors_frame``),
        ``bodies``, ``chains``, ``terms_by_kind``, ``components`` (per component ``name``,
        ``owner``, ``kinds``, ``unit``, ``min``, ``max``, ``parameters``), ``ranges_of``,
        ``n_error_joints``, ``n_parameters`` and ``provenance`` (the spec's ``[provenance]``
        table: where a written spec's values came from; None when it has none).
    """
    spec = machine.spec
    chains = machine.chains
    axes = []
    for axis, kind, (lo, hi) in zip(spec.axes, machine.axis_kinds, machine.travel):
        factor = 1.0 / axis_scale(kind)
        axes.append({
            "name": axis.name,
            "joint": axis.joint,
            "kind": kind,
            "unit": "mm" if kind == "linear" else "deg",
            "travel": [lo * factor, hi * factor],
            "chain": "tool" if axis.name in chains["tool"] else "workpiece",
            "sign": int(axis.sign),
            "errors_frame": axis.frame,
        })
    terms = machine.model.term_info()
    by_kind: dict[str, list[str]] = {}
    per_component: dict[str, list[dict]] = {}
    for term in terms:
        by_kind.setdefault(term["kind"], []).append(term["component"])
        per_component.setdefault(term["component"], []).append(term)
    # range of each component over its axis travel (other axes at mid travel)
    travel = machine.travel
    travel = np.where(np.isfinite(travel), travel, np.array([-math.pi, math.pi]))
    sweeps = []
    for j in range(len(machine.axes)):
        q = np.tile(travel.mean(axis=1), (201, 1))
        q[:, j] = np.linspace(travel[j, 0], travel[j, 1], 201)
        sweeps.append(q)
    try:
        values = machine.component_values(np.vstack(sweeps))
        ranges_of = "all terms"
    except InputError:  # time-, temperature-, force- or direction-dependent terms and no state
        values = machine.component_values(np.vstack(sweeps), without_covariates=True)
        ranges_of = ("terms that read no covariates (" + ", ".join(sorted(machine.covariates_used))
                     + " not given: hold the machine in a state to include the rest)")
    components = []
    for k, name in enumerate(machine.components):
        angular = name[1] in "ABC"
        factor = ARCSEC_PER_RAD if angular else UM_PER_M
        own = per_component[name]
        components.append({
            "name": name,
            "owner": own[0]["owner"],
            "kinds": [t["kind"] for t in own],
            "unit": "arcsec" if angular else "um",
            "min": float(values[:, k].min() * factor),
            "max": float(values[:, k].max() * factor),
            "parameters": [p for t in own for p in t["parameters"]],
        })
    return {
        "machine": machine.name,
        "description": spec.description,
        "source": spec.reference,
        "spec": spec.source,
        "urdf": str(spec.urdf),
        "tool_frame": machine.tool_frame,
        "workpiece_frame": machine.workpiece_frame,
        "axes": axes,
        "bodies": [{"name": b.name, "joint": b.joint} for b in spec.bodies],
        "chains": {k: list(v) for k, v in chains.items()},
        "terms_by_kind": by_kind,
        "components": components,
        "ranges_of": ranges_of,
        "provenance": (spec.extra or {}).get("provenance"),
        "n_error_joints": len(machine.error_joints),
        "n_parameters": len(machine.parameter_names),
    }
