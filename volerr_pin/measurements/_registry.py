"""The registry of measurement kinds, and :func:`read_any`, which reads a file of any of them.

Kinds are tried in order; the first that recognises a file's header reads it. Point
measurements come last and take whatever no other kind recognises. A new instrument is one
module with a measurement class (see :class:`~volerr_pin.measurements.Measurement`)
and a :class:`~volerr_pin.measurements.MeasurementKind`, registered here or with
:func:`register_kind`; nothing else changes.
"""

from __future__ import annotations

from pathlib import Path

from ..base import InputError
from . import _ballbar as ballbar, _points as points, _runs as runs, _tracker as tracker
from ._protocol import Measurement, MeasurementKind
from ._table import MeasurementError, read_file, read_table

__all__ = ["KINDS", "read_any", "register_kind"]

#: the kinds read_any tries, in order (the catch-all point measurements last)
KINDS: list[MeasurementKind] = [runs.KIND, ballbar.KIND, tracker.KIND, points.KIND]


def register_kind(kind: MeasurementKind) -> MeasurementKind:
    """Add a kind of measurement file, tried before the catch-all point measurements.

    Parameters
    ----------
    kind : MeasurementKind
        The kind.

    Returns
    -------
    MeasurementKind
        ``kind``.

    Raises
    ------
    InputError
        Naming ``kind``, when a kind of that name is registered already.
    """
    if any(k.name == kind.name for k in KINDS):
        raise InputError(f"kind: a measurement kind named {kind.name!r} is registered already", parameters=("kind",))
    KINDS.insert(len(KINDS) - 1, kind)
    return kind


def read_any(path: str | Path, machine=None, axis: str | None = None) -> Measurement:
    """Read a file of any registered kind, telling them apart by the header (the file is read once).

    Parameters
    ----------
    path : str or Path
        The file.
    machine : Machine, optional
        The machine; needed for point measurements and tracker files.
    axis : str, optional
        Moving axis of a run file (see :func:`~volerr_pin.measurements.read_runs`).

    Returns
    -------
    Measurement
        Runs, a BallbarRun, TrackerMeasurements (only with ``machine``), a measurement of a
        registered kind, or else PointMeasurements.

    Raises
    ------
    MeasurementError
        If the file is malformed, or a kind that needs the machine is read without ``machine``.
    """
    path = Path(path)
    text = read_file(path)
    table = next((t for k in KINDS if k.layout is not None for t in [k.layout(path, text)] if t is not None), None)
    if table is None:
        table = read_table(path, text)
    for kind in KINDS:
        if kind.recognises(table.header):
            if kind.needs_machine and machine is None:
                raise MeasurementError(f"{path}: {kind.what} need the machine (its axes and travels)")
            return kind.read(table, machine, axis)
    raise MeasurementError(f"{path}: no kind of measurement reads this file")
