"""The prediction of the part a program cuts (:func:`predict`): the program's moves read once, the
deviation sampled along the path, the features measured on the cut, each ranked by the error
sources that decide it (:class:`PartPrediction`); see :mod:`volerr_pin.applications.part`."""

from __future__ import annotations

import operator
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from ...base import UM_PER_M, InputError
from ...compensation import POINT
from ...model import Machine
from ._measure import measure
from ._path import CuttingPath
from ._ranking import feature_ranking
from ._sampling import PathDeviation, deviation_along

__all__ = ["NOT_PREDICTED_SHARE", "PartPrediction", "predict"]

#: the share of a program's blocks above which the blocks not predicted are told in the headline
#: (below it they are listed after the features): one in a hundred
NOT_PREDICTED_SHARE = 0.01


@dataclass
class PartPrediction:
    """What a program cuts on a machine: the deviation along the path and the features.

    Attributes
    ----------
    machine : Machine
    source : str
        The program's name.
    reference : str or None
        The name of the program that defines the features, when not the program itself.
    deviation : PathDeviation
        Along the program's own path (normal to it).
    circles, sides, pairs, cones : list
        The features (:func:`measure`).
    notes : list of str
        What the reader tells of the program (work and tool offsets taken as the model's), and
        why a feature the program defines is not measured.
    not_predicted : list of Skipped
        The program's blocks not predicted, with why (:attr:`MoveBatch.skipped`): constructs
        kept as written, and cuts from a position not known.
    blocks_run : int
        The blocks of the program that move or are not predicted (a loop's pass counts each
        time): what :attr:`not_predicted_share` divides by.
    rankings : list of list of dict
        Per feature (circles, sides, pairs, cones' sections in that order),
        :func:`feature_ranking`; empty with
        a reference, where what is left is the compensation's, not an error source's.
    """

    machine: Machine
    source: str
    reference: str | None
    deviation: PathDeviation
    circles: list
    sides: list
    pairs: list
    rankings: list
    cones: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    not_predicted: list = field(default_factory=list)
    blocks_run: int = 0

    @property
    def not_predicted_blocks(self) -> int:
        """How many blocks run are not predicted (int)."""
        return sum(s.blocks for s in self.not_predicted)

    @property
    def not_predicted_share(self) -> float:
        """The share of :attr:`blocks_run` not predicted (0 when every block is)."""
        return self.not_predicted_blocks / self.blocks_run if self.blocks_run else 0.0

    @property
    def features(self) -> list:
        """Every feature, in the order of :attr:`rankings` (circles, sides, pairs, cones' sections)."""
        return [*self.circles, *self.sides, *self.pairs, *self.cones]

    def to_dict(self, top: int = 5) -> dict:
        """The report: the largest deviation and its block, every block's, and the features
        with the ``top`` error sources of each, its ``drivers`` (JSON: ``features``).

        Parameters
        ----------
        top : int, default 5
            How many error sources of each feature's ranking to keep.

        Returns
        -------
        dict
            JSON-ready: ``machine``, ``program``, ``reference``, ``state``, ``tolerance_um``,
            ``samples``, ``max_normal_deviation_um``, ``max_line``, ``blocks`` (each block's
            ``line`` and ``max_um``), ``features``, ``notes``, ``not_predicted`` (each run of
            blocks not predicted: ``line``, ``last_line``, ``blocks``, ``reason``) and
            ``not_predicted_share``.
        """
        blocks = self.deviation.per_block()
        worst = max(blocks, key=blocks.get)
        features = []
        for feature, ranking in zip(self.features, self.rankings):
            row = feature.to_dict()
            row["drivers"] = ranking[:top]
            features.append(row)
        return {"machine": self.machine.name, "program": self.source, "reference": self.reference,
                "state": {key: value.tolist() if isinstance(value, np.ndarray) else value   # (directions, forces)
                          for key, value in self.machine.state.items()},
                "tolerance_um": self.deviation.tolerance * UM_PER_M,
                "samples": int(len(self.deviation.line)), "max_normal_deviation_um": self.deviation.max_um,
                "max_line": int(worst),
                "blocks": [{"line": int(line), "max_um": value} for line, value in blocks.items()],
                "features": features, "notes": list(self.notes),
                "not_predicted": [s.to_dict() for s in self.not_predicted],
                "not_predicted_share": self.not_predicted_share}


def predict(machine: Machine, program: str | Iterable[tuple[str, str]], source: str = "<program>", *,
            reference: str | Iterable[tuple[str, str]] | None = None, reference_source: str = "<reference>",
            tolerance: float = 0.01e-6, start=None, origin=None, plane: tuple[int, int] | None = None,
            tool_diameter: float = 0.0, cone_heights=(0.0,), dialect=None, work_offsets=None,
            subroutines=None) -> PartPrediction:
    """Predict the part a program cuts: the deviation along its path and its features with the
    error sources that decide them.

    Parameters
    ----------
    machine : Machine
        The machine, in the state to predict (:meth:`Machine.with_state`).
    program : str, ProgramFile or iterable of (str, str)
        The program, read as ``compensate`` reads it: its text, its file, or its lines with
        their endings (:func:`volerr_pin.compensation.gcode.interpret` reads them once).
    source : str, default "<program>"
        Its name, for messages and the report.
    reference : str, ProgramFile or iterable of (str, str), optional
        The program that defines the part (for a compensated program: the program it was
        made from), as ``program``: its features are measured on the cut of ``program``
        (:func:`measure`).
    reference_source : str, default "<reference>"
        Its name.
    tolerance : float, default 0.01e-6
        Sampling tolerance of the path [m] (:func:`deviation_along`).
    start, origin : array_like, optional
        Where the axes stand when it starts, and the program zero [m, rad]
        (:func:`volerr_pin.compensation.gcode.interpret`).
    plane : tuple of int, optional
        The contour plane of the features (default: :func:`contour_plane` of the cut).
    tool_diameter : float, default 0
        The tool's diameter [m]: a cone cut by the tool's flank is offset by its radius from
        the tool's axis (0: the cone the tool's axis sweeps).
    cone_heights : sequence of float, default (0,)
        A cone's sections: heights along its axis above the plane the tool's end cuts in [m].
    dialect : str, optional
        The programs' dialect (``"linuxcnc"``, ``"fanuc"``, ``"haas"``; default: told from the
        program, else LinuxCNC's); a dialect the program or the caller chose is said in the notes.
    work_offsets : dict of str to array_like, optional
        The controller's work offsets [m, rad] by name, for a program with several set-ups
        (:func:`volerr_pin.compensation.gcode.read_work_offsets`).
    subroutines : str or Path, optional
        The folder of the subroutine files the program calls (``o<rcone> call`` runs
        ``rcone.ngc``; default: not followed).

    Returns
    -------
    PartPrediction

    Raises
    ------
    GcodeError
        A block of a program that cannot be read, naming its line.
    InputError
        If a program has no cutting move, a move leaves the travel (naming its line), the
        tolerance is not a positive number or takes too many samples, ``plane`` is not two
        different coordinates, the tool is too large for a cone's flank, a cone has no section
        at a height, or the cut follows none of the reference's circles and sides.
    """
    from ...compensation.gcode import interpret

    if plane is not None:
        plane = _plane(plane)
    batch = interpret(machine, program, source, start=start, origin=origin, dialect=dialect, work_offsets=work_offsets,
                      subroutines=subroutines)
    if batch.skipped and not np.any(batch.kind != POINT):
        unprogrammed = any("not yet programmed" in s.reason for s in batch.skipped)
        raise InputError(f"{source}: no cut can be predicted: " + "; ".join(
            f"{s.where}: {s.reason}" for s in batch.skipped[:3]) + (
            f" (and {len(batch.skipped) - 3} more)" if len(batch.skipped) > 3 else "") + (
            "; give where the axes stand at the start (start; a 2-D program never writes Z)"
            if unprogrammed else ""), parameters=("start",) if unprogrammed else ())
    moves = CuttingPath(machine, batch)
    defining = None if reference is None else interpret(machine, reference, reference_source, start=start,
                                                         origin=origin, dialect=dialect, work_offsets=work_offsets)
    deviation = deviation_along(machine, moves, tolerance)
    found = measure(machine, moves, defining, plane=plane, tool_diameter=tool_diameter, cone_heights=cone_heights)
    # with a reference (a compensated program), what is left is the compensation's (its tolerance,
    # the written numbers' rounding), not an error source's: the sources' profiles cancel
    cache: dict = {}
    rankings = [feature_ranking(machine, f, cache=cache) if reference is None else []
                for f in [*found.circles, *found.sides, *found.pairs, *found.cones]]
    return PartPrediction(machine, source, None if reference is None else reference_source, deviation, found.circles,
                          found.sides, found.pairs, rankings, found.cones, _dialect_note(batch) + batch.notes + found.notes,
                          batch.skipped,
                          len(batch) + sum(s.blocks for s in batch.skipped if not s.moved))


def _dialect_note(batch) -> list[str]:
    """The dialect the program was read in, when the program or the caller chose one."""
    name, said = batch.dialect
    return [] if said.startswith("the default") else [f"read as a {name} program ({said})"]


def _plane(plane) -> tuple[int, int]:
    """A contour plane as two coordinates of x, y, z (0, 1, 2), ascending; refused naming
    ``plane`` otherwise."""
    try:
        i, j = (operator.index(c) for c in plane)
    except (TypeError, ValueError):
        raise InputError(f"plane {plane!r} is not two coordinates (0, 1, 2 for x, y, z)",
                         parameters=("plane",)) from None
    if not {i, j} <= {0, 1, 2} or i == j:
        raise InputError(f"plane {(i, j)} is not two different coordinates of 0, 1, 2 (x, y, z)", parameters=("plane",))
    return min(i, j), max(i, j)
