"""A laser interferometer: positioning runs along one linear axis (ISO 230-2 style), one run
per unit.

A run moves one linear axis through ``targets`` equally spaced positions over the zone's
range of that axis, first in the positive direction, then back in the negative one (both
approach directions: what separates a reversal error from a scale error), the other axes
standing at the run's own positions. It observes the error along the axis' own motion at
every target, with the instrument's zero as a nuisance term of its own (docs/measurements.md,
positioning runs). Candidate runs cycle through the linear axes that move in the zone; the
other axes' positions are the layout's (Sobol', grid, random) points of the zone.

Each run is its own file (``# axis:`` and ``# at:`` header lines, then
``target_mm,cycle,direction,deviation_um`` with the deviations empty): a plan of N runs is N
files.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...base import InputError, axis_scales
from ...measurements import Runs
from ._poses import pose_candidates
from ._nc import StopsProgram
from ._protocol import Instrument, numbered_files, Setup

__all__ = ["INTERFEROMETER", "Interferometer", "Run"]


@dataclass(frozen=True)
class Run:
    """One planned run (SI).

    Attributes
    ----------
    axis : int
        Index of the moving axis.
    base : ndarray, shape (n_axes,)
        Positions of all axes [m, rad]; the moving axis' entry is not used.
    targets : ndarray, shape (n,)
        Target positions of the moving axis [m], increasing.
    """

    axis: int
    base: np.ndarray
    targets: np.ndarray

    def path(self) -> tuple[np.ndarray, np.ndarray]:
        """Targets in the order visited and their approach directions: up, then down.

        Returns
        -------
        target : ndarray, shape (2 n,)
            Positions [m].
        direction : ndarray of int, shape (2 n,)
            +1 on the way up, -1 on the way down.
        """
        return (np.concatenate([self.targets, self.targets[::-1]]),
                np.concatenate([np.ones(len(self.targets), int), -np.ones(len(self.targets), int)]))


@dataclass(frozen=True)
class Interferometer(StopsProgram, Instrument):
    """The laser-interferometer instrument (see the module docstring).

    Attributes
    ----------
    name : str
        "interferometer".
    unit : str
        "run".
    default_sigma_um : float
        0.5 um per reading, as a default.
    targets : int
        Targets per run (11: ISO 230-2 asks for at least 5 per metre and 5 in all).

    Notes
    -----
    The methods of :class:`~volerr_pin.studies.plan.Instrument` (documented there) do here:

    - ``candidates``: runs cycling through the moving linear axes, the others at the layout's
      points.
    - ``measurements``: one run object per planned run.
    - ``outputs``: the files a plan of ``count`` runs writes for ``out``: ``STEM_run01.csv`` ...
    - ``files``: one positioning-run file per run, deviations empty.
    - ``visits``: every target of every run, in the order measured.
    """

    name: str = "interferometer"
    unit: str = "run"
    default_sigma_um: float = 0.5
    targets: int = 11

    def _moving(self, machine, setup: Setup) -> list[int]:
        moving = [j for j, k in enumerate(machine.axis_kinds)
                  if k == "linear" and setup.zone[j, 1] > setup.zone[j, 0]]
        if not moving:
            raise InputError("zone: no linear axis moves in it: an interferometer has no run to measure",
                             parameters=("zone",))
        if np.any(setup.targets != 0):
            raise InputError("targets: a positioning run measures the tool point only", parameters=("targets",))
        return moving

    def candidates(self, machine, setup: Setup, count: int, layout: str, seed: int) -> list:
        moving = self._moving(machine, setup)
        bases = pose_candidates(setup.zone, machine.axis_kinds, count, layout, seed)
        out = []
        for i, base in enumerate(bases):
            j = moving[i % len(moving)]
            out.append(Run(j, base, np.linspace(setup.zone[j, 0], setup.zone[j, 1], self.targets)))
        return out

    def _at(self, machine, run: Run) -> dict:
        scale = axis_scales(machine.axis_kinds)
        return {a: float(np.round(run.base[k] / scale[k], 4)) for k, a in enumerate(machine.axes) if k != run.axis}

    def measurements(self, machine, setup: Setup, units: list, values: np.ndarray | None = None
                     ) -> tuple[list, np.ndarray]:
        out, owner, start = [], [], 0
        for i, run in enumerate(units):
            target, direction = run.path()
            n = len(target)
            value = np.zeros(n) if values is None else np.asarray(values[start:start + n], dtype=float)
            start += n
            out.append(Runs(f"planned run {i + 1}", target, np.ones(n, int), direction, value, target * 1e3,
                            value * 1e6, "mm", "um", None, machine.axes[run.axis], self._at(machine, run),
                            np.arange(n) + 4))
            owner.append(np.full(n, i))
        return out, np.concatenate(owner) if owner else np.zeros(0, int)

    def outputs(self, out: str | Path, count: int) -> list[Path]:
        return numbered_files(out, count, "run")

    def files(self, machine, setup: Setup, units: list) -> list[str]:
        texts = []
        for run in units:
            target, direction = run.path()
            at = ", ".join(f"{a}={v:g}" for a, v in self._at(machine, run).items())
            lines = [f"# axis: {machine.axes[run.axis]}", *([f"# at: {at}"] if at else []),
                     "target_mm,cycle,direction,deviation_um"]
            lines += [f"{t * 1e3:.4f},1,{d},"for t, d in zip(target, direction)]
            texts.append("\n".join(lines) + "\n")
        return texts

    def visits(self, machine, units: list) -> np.ndarray:
        rows = []
        for run in units:
            target, _ = run.path()
            q = np.tile(run.base, (len(target), 1))
            q[:, run.axis] = target
            rows.append(q)
        return np.vstack(rows) if rows else np.zeros((0, len(machine.axes)))


#: the laser interferometer
INTERFEROMETER = Interferometer()
