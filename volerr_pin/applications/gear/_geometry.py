"""The gear pair of a study: the workpiece gear and the rolling wheel, their circles and the
active part of the line of action."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...base import DEG, MM, InputError

__all__ = ["DEVIATIONS", "FLANKS", "REFERENCE_GEAR", "GearPair"]


#: the two flanks of a tooth; +1: the clockwise side seen from +z (right), -1: the other
FLANKS = {"right": 1, "left": -1}


#: the deviations reported, seed 004's first, then ISO 1328-1's
DEVIATIONS = ("profile", "helix", "pitch", "F_alpha", "F_beta", "f_pt", "F_p", "seam")


@dataclass(frozen=True)
class GearPair:
    """A spur workpiece gear and the gear-shaped tool (rolling wheel) that generates it.

    Attributes
    ----------
    module : float
        Normal module [m].
    pressure_angle : float
        Pressure angle [rad].
    teeth : int
        Number of teeth of the workpiece.
    tool_teeth : int
        Number of teeth of the rolling wheel.
    face_width : float
        Face width of the workpiece over which the helix is evaluated [m].
    addendum : float, default 1.0
        Addendum coefficient of the workpiece: tip radius = pitch radius + ``addendum`` * module.
    tool_addendum : float, default 1.0
        Addendum coefficient of the wheel's finishing teeth: the wheel's tip circle sets where
        the active profile of the workpiece starts (its form circle).

    Raises
    ------
    InputError
        If a value is not positive and finite, a tooth count is not an integer >= 5, the
        pressure angle is not within (0, 45) deg, or the wheel's tip reaches below the
        workpiece's base circle (undercut: the involute has no form circle).
    """

    module: float
    pressure_angle: float
    teeth: int
    tool_teeth: int
    face_width: float
    addendum: float = 1.0
    tool_addendum: float = 1.0

    def __post_init__(self):
        for name in ("module", "face_width", "addendum", "tool_addendum"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
                    or not (np.isfinite(value) and value > 0):
                shown = f"{value / MM:g} mm" if name in ("module", "face_width") and isinstance(value, (int, float)) \
                    else repr(value)
                raise InputError(f"{name} must be a positive number, got {shown}", parameters=(name,))
        for name in ("teeth", "tool_teeth"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 5:
                raise InputError(f"{name} must be an integer >= 5, got {value!r}", parameters=(name,))
        if not (0 < self.pressure_angle < 45 * DEG):
            raise InputError(f"pressure_angle must be within (0, 45) deg, got "
                             f"{self.pressure_angle / DEG:g} deg", parameters=("pressure_angle",))
        if self.roll_start <= -self.pitch_radius * np.sin(self.pressure_angle):
            raise InputError(f"the wheel's tip (radius {self.tool_tip_radius / MM:g} mm) reaches below the "
                             f"workpiece's base circle: the {self.teeth}-tooth gear is undercut",
                             parameters=("tool_addendum",))
        if self.roll_end >= self.tool_pitch_radius * np.sin(self.pressure_angle):
            raise InputError(f"the workpiece's tip (radius {self.tip_radius / MM:g} mm) reaches below the wheel's "
                             f"base circle: the {self.tool_teeth}-tooth wheel would interfere", parameters=("addendum",))

    @property
    def pitch_radius(self) -> float:
        """Pitch radius of the workpiece, m z / 2 [m]."""
        return self.module * self.teeth / 2

    @property
    def tool_pitch_radius(self) -> float:
        """Pitch radius of the wheel [m]."""
        return self.module * self.tool_teeth / 2

    @property
    def centre_distance(self) -> float:
        """Centre distance of wheel and workpiece, the sum of the pitch radii [m]."""
        return self.pitch_radius + self.tool_pitch_radius

    @property
    def base_radius(self) -> float:
        """Base radius of the workpiece [m]."""
        return self.pitch_radius * np.cos(self.pressure_angle)

    @property
    def tool_base_radius(self) -> float:
        """Base radius of the wheel [m]."""
        return self.tool_pitch_radius * np.cos(self.pressure_angle)

    @property
    def tip_radius(self) -> float:
        """Tip radius of the workpiece [m]."""
        return self.pitch_radius + self.addendum * self.module

    @property
    def tool_tip_radius(self) -> float:
        """Tip radius of the wheel's finishing teeth [m]."""
        return self.tool_pitch_radius + self.tool_addendum * self.module

    @property
    def roll_end(self) -> float:
        """Where the line of action meets the workpiece's tip circle, from the pitch point [m]."""
        return float(np.sqrt(self.tip_radius ** 2 - self.base_radius ** 2)
                     - self.pitch_radius * np.sin(self.pressure_angle))

    @property
    def roll_start(self) -> float:
        """Where the line of action meets the wheel's tip circle, from the pitch point [m] (< 0)."""
        return float(-(np.sqrt(self.tool_tip_radius ** 2 - self.tool_base_radius ** 2)
                       - self.tool_pitch_radius * np.sin(self.pressure_angle)))

    @property
    def form_radius(self) -> float:
        """Radius where the active profile of the workpiece starts (wheel tip contact) [m]."""
        return self.radius_at(self.roll_start)

    def radius_at(self, u) -> np.ndarray:
        """Radius of the workpiece's flank point touched at ``u`` on the line of action [m].

        Parameters
        ----------
        u : float or array_like
            Signed distance from the pitch point along the line of action, positive towards
            the workpiece's tip [m].

        Returns
        -------
        float or ndarray
            Radius [m], same shape as ``u``.
        """
        return np.sqrt(self.base_radius ** 2 + (self.pitch_radius * np.sin(self.pressure_angle)
                                                + np.asarray(u, dtype=float)) ** 2)

    def to_dict(self) -> dict:
        """The gear data in engineering units (mm, deg), for reports.

        Returns
        -------
        dict
            ``module_mm``, ``pressure_angle_deg``, ``teeth``, ``tool_teeth``, ``face_width_mm``,
            ``pitch_diameter_mm``, ``base_diameter_mm``, ``tip_diameter_mm``,
            ``form_diameter_mm``, ``centre_distance_mm``.
        """
        return {"module_mm": self.module / MM, "pressure_angle_deg": self.pressure_angle / DEG,
                "teeth": int(self.teeth), "tool_teeth": int(self.tool_teeth),
                "face_width_mm": self.face_width / MM,
                "pitch_diameter_mm": 2 * self.pitch_radius / MM,
                "base_diameter_mm": float(2 * self.base_radius / MM),
                "tip_diameter_mm": float(2 * self.tip_radius / MM),
                "form_diameter_mm": float(2 * self.form_radius / MM),
                "centre_distance_mm": self.centre_distance / MM}


#: the gear-rolling study's gear (seed 004, Table 7): module 1.75 mm, 20 deg, 46 teeth rolled by a
#: 128-tooth wheel; the face width (not given in the paper) is its 20 mm contact line at the start
#: of rolling
REFERENCE_GEAR = GearPair(module=1.75 * MM, pressure_angle=20 * DEG, teeth=46, tool_teeth=128,
                          face_width=20 * MM)
