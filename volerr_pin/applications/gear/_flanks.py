"""The flanks a machine generates: the normal deviation of every flank point (the actual pose of
the wheel at the instant of generation moves its contact point), and seed 004's and ISO
1328-1's profile, helix and pitch deviations from them."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from ...model import Machine, check_covariates, check_theta, tool_poses
from ...base import UM
from ._generation import Generation, generation_of
from ._geometry import FLANKS, REFERENCE_GEAR, GearPair

__all__ = ["FlankDeviations", "each_flanks", "flank_deviations", "flanks_of", "pitch_positions"]


def pitch_positions(normal: np.ndarray, gear: GearPair) -> np.ndarray:
    """Flank positions along the pitch circle at mid face, from the normal deviations.

    A normal offset dN turns an involute by dN / rb, which moves it along the pitch circle by
    dN / cos(pressure angle).

    Parameters
    ----------
    normal : ndarray, shape (2, n_teeth, n_profile, n_face)
        Normal deviations [m] (:attr:`FlankDeviations.normal`).
    gear : GearPair
        The gear.

    Returns
    -------
    ndarray, shape (2, n_teeth)
        Positions [m] of the right and left flank of each tooth.
    """
    return normal[:, :, normal.shape[2] // 2, normal.shape[3] // 2] / np.cos(gear.pressure_angle)


def _both_signs(values: np.ndarray, axis: int) -> np.ndarray:
    """Seed 004's measure: |largest positive| + |largest negative| (each 0 when absent)."""
    return np.maximum(values.max(axis=axis), 0.0) + np.maximum(-values.min(axis=axis), 0.0)


@dataclass(frozen=True)
class FlankDeviations:
    """Normal deviations of the generated flanks and the gear deviations they give.

    Attributes
    ----------
    gear : GearPair
        The gear.
    normal : ndarray, shape (2, n_teeth, n_profile, n_face)
        Normal deviation [m] of the right (index 0) and left (1) flank of each tooth, over
        the active profile and the face width; positive: more material.
    roll : ndarray, shape (n_profile,)
        Positions on the line of action from the pitch point [m] (the middle one is 0).
    radius : ndarray, shape (n_profile,)
        Radii of the profile points [m].
    face : ndarray, shape (n_face,)
        Face positions from mid face [m].
    teeth : ndarray, shape (n_teeth,)
        Tooth numbers, ascending (0: the tooth centred on the tool point at the nominal
        configuration; numbers grow counter-clockwise seen from +z).
    points : ndarray, shape (2, n_teeth, n_profile, n_face, 3)
        The ideal flank points in the workpiece frame [m].
    normals : ndarray, shape (2, n_teeth, n_profile, n_face, 3)
        Their outward unit normals.
    values : dict
        Flank name ("right", "left") -> {deviation name: value [m]} for :data:`DEVIATIONS`;
        ``f_pt``, ``F_p`` and ``seam`` are None unless every tooth was evaluated.
    """

    gear: GearPair
    normal: np.ndarray
    roll: np.ndarray
    radius: np.ndarray
    face: np.ndarray
    teeth: np.ndarray
    points: np.ndarray = field(repr=False)
    normals: np.ndarray = field(repr=False)
    values: dict = field(repr=False)

    def to_dict(self) -> dict:
        """The deviations in micrometres, per flank.

        Returns
        -------
        dict
            ``{"right": {"profile_um": ..., ...}, "left": {...}}`` with one ``<name>_um``
            field per entry of :data:`DEVIATIONS` (None where not evaluated).
        """
        return {flank: {f"{k}_um": (None if v is None else v / UM) for k, v in vals.items()}
                for flank, vals in self.values.items()}


def _deviations(normal: np.ndarray, gear: GearPair, all_teeth: bool) -> dict:
    mid_u, mid_s = normal.shape[2] // 2, normal.shape[3] // 2
    positions = pitch_positions(normal, gear)
    out = {}
    for index, flank in enumerate(FLANKS):
        d = normal[index]
        profile = d[:, :, mid_s]                    # (n_t, n_u) at mid face
        helix = d[:, mid_u, :]                      # (n_t, n_s) on the pitch circle
        at_pitch = d[:, mid_u, mid_s]
        worst = int(np.argmax(np.abs(at_pitch)))
        vals = {"profile": float(_both_signs(profile, 1).max()),
                "helix": float(_both_signs(helix, 1).max()),
                "pitch": float(at_pitch[worst]),
                "F_alpha": float(np.ptp(profile, axis=1).max()),
                "F_beta": float(np.ptp(helix, axis=1).max()),
                "f_pt": None, "F_p": None, "seam": None}
        if all_teeth:
            position = positions[index]
            vals["f_pt"] = float(np.abs(position - np.roll(position, 1)).max())
            vals["F_p"] = float(np.ptp(position))
            # teeth z//2 and z//2 + 1 are adjacent but generated last and first, a turn apart
            last = gear.teeth // 2
            vals["seam"] = float(position[last + 1] - position[last])
        out[flank] = vals
    return out


def flank_deviations(machine: Machine, gear: GearPair = REFERENCE_GEAR, *, spindles: Sequence[str] = ("B", "A"),
                     at: Mapping | None = None, feed: str | None = None, profile_points: int = 21,
                     face_points: int = 11, tooth_numbers: Sequence[int] | None = None, theta=None,
                     **covariates) -> FlankDeviations:
    """Deviations of the gear flanks the machine generates with its present errors.

    Parameters
    ----------
    machine : Machine
        A rolling machine: its tool frame is the wheel's pitch point, the workpiece frame's
        z axis is the gear axis.
    gear : GearPair, default :data:`REFERENCE_GEAR`
        The gear and the wheel; its pitch radii must match the machine (tool point 40.25 mm
        from the workpiece axis and 112 mm from the wheel axis for seed 004).
    spindles : pair of str, default ("B", "A")
        The workpiece spindle and the wheel spindle (rotary axes).
    at : mapping of str to float, optional
        Positions of the other axes during generation [m, rad], and of the spindles where
        a tooth is centred on the tool point; axes not given are at 0. The gear's mid face is
        where the tool point is here (on gear_roller, Z above the workpiece frame's origin).
    feed : str, optional
        The feed axis of through rolling (a linear axis along the gear axis): each transverse
        section is finished as this axis carries it through the wheel's mid plane. Default:
        the whole face at the feed position of ``at``, the contact line spanning the face.
    profile_points : int, default 21
        Points over the active profile (odd: the middle one is on the pitch circle).
    face_points : int, default 11
        Points over the face width (odd: the middle one is mid face).
    tooth_numbers : sequence of int, optional
        Teeth to evaluate (0 .. ``gear.teeth`` - 1; 0 is the tooth centred on the tool point at
        the nominal configuration); default every tooth, which ``f_pt`` and ``F_p`` need.
    theta : array_like, shape (P,), optional
        Coefficients of the machine (SI); defaults to :attr:`Machine.theta`.
    **covariates
        As for :meth:`Machine.volumetric_error` (``t``, ``temperatures``, ``forces``,
        ``directions``), one value per flank point or from the machine's state.

    Returns
    -------
    FlankDeviations
        Normal deviations over both flanks of the teeth and the deviations they give.

    Raises
    ------
    InputError
        If the spindles are not rotary axes of the machine, the gear does not fit the
        machine's geometry, ``at`` names an unknown axis or leaves the travel, ``feed`` is not a
        linear axis along the gear axis, or the point counts or tooth numbers are invalid.
    """
    generation = generation_of(machine, gear, spindles, at, feed, profile_points, face_points, tooth_numbers)
    return flanks_of(machine, gear, generation, theta, covariates)


def flanks_of(machine: Machine, gear: GearPair, generation: Generation, theta, covariates) -> FlankDeviations:
    """The flanks ``machine`` generates: its actual poses move the wheel's contact points.

    Parameters
    ----------
    machine : Machine
        The machine.
    gear : GearPair
        The gear pair.
    generation : Generation
        Where and when every flank point is generated.
    theta : array_like or None
        Coefficients (SI); defaults to the machine's.
    covariates : dict
        As for :meth:`Machine.tool_poses`, one value per flank point; those not given from the
        machine's state.

    Returns
    -------
    FlankDeviations
        The deviations.

    Raises
    ------
    InputError
        If ``theta`` or the covariates are invalid (:func:`~volerr_pin.model.check_theta`,
        :func:`~volerr_pin.model.check_covariates`).
    """
    grid = generation.grid   # its positions checked against the travel where it was made
    model = machine.model
    theta = machine.theta if theta is None else check_theta(model, theta)
    R1, p1 = tool_poses(model, grid.q, theta, check_covariates(model, len(grid.q), covariates, machine.state))
    moved = np.einsum("nij,nj->ni", R1, generation.local) + p1
    normal = np.einsum("ni,ni->n", moved - grid.point, grid.normal).reshape(grid.shape)
    return FlankDeviations(gear, normal, grid.roll, gear.radius_at(grid.roll), grid.face, grid.teeth,
                           grid.point.reshape(grid.shape + (3,)), grid.normal.reshape(grid.shape + (3,)),
                           _deviations(normal, gear, grid.teeth.size == gear.teeth))


_GEOMETRY = ("spindles", "at", "feed", "profile_points", "face_points", "tooth_numbers")


def each_flanks(machines, gear: GearPair, options: dict) -> list[FlankDeviations]:
    """:func:`flank_deviations` of machines that share their nominal geometry (the first's):
    where each flank point is generated is worked out once.

    Parameters
    ----------
    machines : list of Machine
        The machines.
    gear : GearPair
        The gear pair.
    options : dict
        Keyword options of :func:`flank_deviations`.

    Returns
    -------
    list of FlankDeviations
        One per machine.
    """
    rest = dict(options)
    geometry = {k: rest.pop(k) for k in _GEOMETRY if k in rest}
    theta = rest.pop("theta", None)
    generation = generation_of(machines[0], gear, **geometry)
    return [flanks_of(m, gear, generation, theta, rest) for m in machines]
