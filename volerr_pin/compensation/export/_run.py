"""One export: lay out a controller's tables, fit them, round them, write them, read them
back, and simulate the controller applying what was read.

The residual reported is that of the files as read back, applied as the controller applies
them, at points other than those the values were fitted on, and it is set beside the
uncompensated error, the naive tables (component errors sampled at the nodes) and exact
point compensation.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...base import (AXIS_UNIT, MM, InputError, SpecError, Transaction, axis_scale, check_output_folder, check_outputs,
                     transaction)
from ...model import Machine
from ._fit import fit
from ._protocol import Compensation, ControllerFormat
from ._registry import controller_format
from ._simulate import Residuals, exact_setpoints, residuals, summary, tool_tips
from ._zone import Points, Zone

__all__ = ["ExportResult", "export_tables", "layout_files", "write_export"]

#: points at the table nodes where the residual is also reported
NODE_POINTS = 512
#: the fit takes at least this many points per value it chooses (every node well inside the data)
FIT_POINTS_PER_VALUE = 8


@dataclass
class ExportResult:
    """Everything one export computed (SI inside, um in the summaries).

    Attributes
    ----------
    machine : Machine
        The machine.
    controller : ControllerFormat
        The format.
    kind : str
        The kind of tables (one of ``controller.kinds``).
    zone : Zone
        The zone fitted and judged over.
    compensation : Compensation
        The compensation as read back from the texts written (what the controller applies).
    naive : Compensation
        The same tables with the component errors sampled at the nodes (rounded alike).
    texts : dict of str to str
        File name -> text.
    points : Points
        The evaluation points (not those fitted on).
    before, after, naive_after, exact_after : ndarray, shape (N, 3)
        Tool-point position errors at the evaluation points [m]: uncompensated, with the
        files, with the naive tables, with exact point compensation.
    node_points : Points
        Points whose every tabulated axis sits on a table node.
    node_after, node_exact : ndarray, shape (M, 3)
        Residuals there with the files and with exact compensation [m].
    fit_points : int
        Points the values were fitted on.
    random_points : Points or None
        The evaluation positions visited once each in a random order, directions from that path.
    random_after : ndarray, shape (N', 3) or None
        Residuals there with the files [m]: what a program visiting the positions in no
        particular order sees, beside the both-ways judgement of ``after``.
    notes : list of str
        Facts about the layout (which master each cross table reads, tables left out).
    files : list of str
        The files written (paths), once :func:`write_export` ran.
    """

    machine: Machine
    controller: ControllerFormat
    kind: str
    zone: Zone
    compensation: Compensation
    naive: Compensation
    texts: dict[str, str]
    points: Points
    before: np.ndarray
    after: np.ndarray
    naive_after: np.ndarray
    exact_after: np.ndarray
    node_points: Points
    node_after: np.ndarray
    node_exact: np.ndarray
    fit_points: int = 0
    random_points: Points | None = None
    random_after: np.ndarray | None = None
    notes: list[str] = field(default_factory=list)
    files: list[str] = field(default_factory=list)

    @property
    def summaries(self) -> dict[str, Residuals]:
        """Max and RMS of each residual (dict of str to Residuals, um): ``uncompensated``,
        ``residual``, ``naive``, ``exact``, ``node``, ``node_exact`` and (when computed)
        ``random_order``."""
        out = {"uncompensated": summary(self.before), "residual": summary(self.after),
               "naive": summary(self.naive_after), "exact": summary(self.exact_after),
               "node": summary(self.node_after), "node_exact": summary(self.node_exact)}
        if self.random_after is not None:
            out["random_order"] = summary(self.random_after)
        return out

    def to_dict(self) -> dict:
        """The report (JSON-ready; fields in docs/reports.md).

        Returns
        -------
        dict
            Machine, controller, kind, files, zone, points and the residuals in um.
        """
        s = self.summaries
        machine = self.machine
        zone = {a: [float(v / axis_scale(k)) for v in r]
                for a, k, r in zip(machine.axes, machine.axis_kinds, self.zone.ranges)}
        return {
            "machine": machine.name, "controller": self.controller.name, "kind": self.kind,
            "title": self.controller.title, "convention": self.controller.convention,
            "files": list(self.files) or sorted(self.texts),
            "zone": {"ranges": zone, "units": {a: AXIS_UNIT[k] for a, k in zip(machine.axes, machine.axis_kinds)},
                     "tool_mm": [self.zone.tool[0] / MM, self.zone.tool[1] / MM]},
            "points": len(self.points), "fit_points": self.fit_points, "values": int(self.naive.values.size),
            "uncompensated_max_um": s["uncompensated"].max_um, "uncompensated_rms_um": s["uncompensated"].rms_um,
            "residual_max_um": s["residual"].max_um, "residual_rms_um": s["residual"].rms_um,
            "naive_residual_max_um": s["naive"].max_um, "naive_residual_rms_um": s["naive"].rms_um,
            "exact_residual_max_um": s["exact"].max_um, "exact_residual_rms_um": s["exact"].rms_um,
            "node_points": len(self.node_points), "node_residual_max_um": s["node"].max_um,
            "node_exact_residual_max_um": s["node_exact"].max_um,
            **({"random_order_residual_max_um": s["random_order"].max_um,
                "random_order_residual_rms_um": s["random_order"].rms_um} if "random_order" in s else {}),
            "tables": self.compensation.describe(machine),
            "notes": list(self.notes),
            "read_back": True,
        }


def layout_files(machine: Machine, controller: str | ControllerFormat, *, zone: Zone | None = None,
                 kind: str | None = None, nodes: int | None = None) -> list[str]:
    """The names of the files an export will write (checked before any work is done).

    Parameters
    ----------
    machine : Machine
        The machine.
    controller : str or ControllerFormat
        The controller's name (or a format instance).
    zone : Zone, optional
        The zone (default the workspace).
    kind : str, optional
        The kind of tables (default the controller's most capable).
    nodes : int, optional
        Nodes per axis.

    Returns
    -------
    list of str
        File names relative to the output folder.
    """
    fmt = controller if isinstance(controller, ControllerFormat) else controller_format(controller)
    zone = _zone(machine, zone)
    layout = fmt.layout(machine, zone, _kind(fmt, kind, machine, zone, nodes), nodes)
    return sorted(fmt.files(fmt.quantise(layout, machine), machine))


def _zone(machine: Machine, zone: Zone | None) -> Zone:
    """``zone`` (default the workspace), checked where it enters: a finite range of every axis.
    The positions sampled from it are then the library's own, evaluated unchecked."""
    if zone is None:
        return Zone.workspace(machine)
    axes = machine.axes
    try:
        ranges = np.asarray(zone.ranges, dtype=float)
    except (TypeError, ValueError) as err:
        raise InputError(f"zone: the ranges must be numbers: {err}", parameters=("zone",)) from None
    if ranges.shape != (len(axes), 2):
        raise InputError(f"zone: the ranges have shape {ranges.shape}; expected ({len(axes)}, 2), the lower and "
                         f"upper position of each axis {', '.join(axes)}", parameters=("zone",))
    bad = np.flatnonzero(~np.isfinite(ranges).all(axis=1))
    if bad.size:
        j = int(bad[0])
        raise InputError(f"zone: the range of {axes[j]} is {ranges[j].tolist()}; it must be finite",
                         parameters=("zone",))
    return zone


def _kind(fmt: ControllerFormat, kind: str | None, machine: Machine, zone: Zone, nodes: int | None) -> str:
    """``kind``, checked; None: the most capable kind whose layout the machine admits."""
    if kind is None:
        for candidate in reversed(fmt.kinds[1:]):
            try:
                fmt.layout(machine, zone, candidate, nodes)
            except SpecError:
                continue
            return candidate
        return fmt.kinds[0]
    if kind not in fmt.kinds:
        raise InputError(f"kind: {fmt.name} has no tables of kind {kind!r} (kinds: {', '.join(fmt.kinds)})",
                         parameters=("kind",))
    return kind


def _close(a, b) -> bool:
    """Nested tuples equal, numbers and arrays within 1e-12 (SI)."""
    if isinstance(a, (tuple, list)) and isinstance(b, (tuple, list)):
        return len(a) == len(b) and all(_close(x, y) for x, y in zip(a, b))
    if isinstance(a, (np.ndarray, float)) or isinstance(b, (np.ndarray, float)):
        x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        return x.shape == y.shape and bool(np.all(np.abs(x - y) <= 1e-12))
    return a == b


def _same(meant: Compensation, back: Compensation, what: str) -> None:
    if not _close(meant.contents(), back.contents()):
        raise InputError(f"{what}: the files read back do not say what was meant to be written")


def export_tables(machine: Machine, controller: str | ControllerFormat, folder: str | os.PathLike | None = None, *,
                  zone: Zone | None = None, kind: str | None = None, nodes: int | None = None,
                  points: int = 4096, seed: int = 0, progress=None) -> ExportResult:
    """Compensation tables a controller loads, with the residual it leaves.

    Lays out the controller's tables over ``zone``, chooses their values by least squares
    through the model (:func:`volerr_pin.compensation.export.fit`) over ``points`` Sobol' points
    reached from both directions (:meth:`~volerr_pin.compensation.export.Zone.sample`), rounds them to
    the format, writes the files (as text, and into ``folder`` when given, all or none), reads
    them back by the controller's rules and checks they say what was meant, then simulates the
    controller applying what was read at ``points`` other points reached from both directions,
    and at their positions visited in a random order.

    Parameters
    ----------
    machine : Machine
        The machine (its state included).
    controller : str or ControllerFormat
        ``linuxcnc``, ``isg``, ``siemens-840d``, ``heidenhain`` or ``fanuc`` (or a format
        instance, e.g. one built with other resolutions).
    folder : path, optional
        Where to write the files (created if missing); None: keep the texts only.
    zone : Zone, optional
        Working zone and tool lengths (default: the whole travel, the machine's tool).
    kind : str, optional
        Kind of tables (``controller_format(controller).kinds``; default the most capable).
    nodes : int, optional
        Nodes per axis (default: the format's).
    points : int, default 4096
        Points judged on, and at least as many other points fitted on (8 per table value at
        least, so every node is well determined).
    seed : int, default 0
        Seed of the points.
    progress : callable, optional
        Called with a stage name as the export proceeds.

    Returns
    -------
    ExportResult
        Texts, compensation as read back, residuals.

    Raises
    ------
    InputError
        For an unknown controller or kind, a zone whose ranges are not finite positions of
        every axis, a node count or value beyond the format's limits, or files that do not read
        back as written.
    SpecError
        For a machine the controller cannot compensate this way.
    """
    fmt = controller if isinstance(controller, ControllerFormat) else controller_format(controller)
    if folder is not None:
        check_output_folder("folder", folder)
    zone = _zone(machine, zone)
    kind = _kind(fmt, kind, machine, zone, nodes)
    step = progress or (lambda stage: None)
    layout = fmt.layout(machine, zone, kind, nodes)
    step("fitting")
    fit_points = max(points, FIT_POINTS_PER_VALUE * layout.values.size)
    fitted = fit(machine, layout, zone.sample(fit_points, seed))
    meant = fmt.quantise(fitted, machine)
    naive = fmt.quantise(layout.naive(machine), machine)
    texts = fmt.files(meant, machine)
    back = fmt.read(texts, machine)
    _same(meant, back, fmt.name)
    step("simulating")
    evaluation = zone.sample(points, seed + 1)
    exact = tool_tips(machine, exact_setpoints(machine, evaluation), evaluation) - tool_tips(
        machine, evaluation.q, evaluation, nominal=True)
    grid = [n if n is not None else np.unique(zone.ranges[j]) for j, n in enumerate(back.axis_nodes())]
    at_nodes = zone.corners_and_nodes(grid, NODE_POINTS, seed + 2)
    node_exact = tool_tips(machine, exact_setpoints(machine, at_nodes), at_nodes) - tool_tips(
        machine, at_nodes.q, at_nodes, nominal=True)
    shuffled = zone.shuffled(evaluation, seed + 3)
    result = ExportResult(machine, fmt, kind, zone, back, naive, texts, evaluation,
                          residuals(machine, None, evaluation), residuals(machine, back, evaluation),
                          residuals(machine, naive, evaluation), exact, at_nodes,
                          residuals(machine, back, at_nodes), node_exact, fit_points, shuffled,
                          residuals(machine, back, shuffled), list(meant.notes))
    if folder is not None:
        with transaction() as tx:
            write_export(result, folder, tx)
    return result


def write_export(result: ExportResult, folder: str | os.PathLike, tx: Transaction) -> list[str]:
    """Write an export's files into ``folder`` within a transaction, read them back from disk
    by the controller's rules and check they hold what was meant.

    Parameters
    ----------
    result : ExportResult
        The export.
    folder : path
        The output folder (created if missing).
    tx : Transaction
        The transaction the files join (all of a run's outputs are written or none).

    Returns
    -------
    list of str
        The files' paths (also stored in ``result.files``).

    Raises
    ------
    InputError
        If a file is an input of the machine, or does not read back as written.
    """
    folder = Path(folder)
    targets = {name: folder / name for name in sorted(result.texts)}
    inputs = [p for p in {os.fspath(result.machine.spec.source), os.fspath(result.machine.spec.urdf)}
              if Path(p).is_file()]
    tx.folder(folder)
    for target in targets.values():
        check_outputs({"folder": target}, inputs)
    temporary = {}
    for name, target in targets.items():
        path = tx.path(target)
        try:
            with open(path, "w", encoding="ascii", newline="\n") as fh:
                fh.write(result.texts[name])
        except OSError as err:   # a full disk: name the file
            raise OSError(err.errno, err.strerror, str(target)) from None
        temporary[name] = path
    on_disk = {name: path.read_text(encoding="ascii") for name, path in temporary.items()}
    _same(result.compensation, result.controller.read(on_disk, result.machine), f"{folder}")
    result.files = [str(t) for t in targets.values()]
    return result.files
