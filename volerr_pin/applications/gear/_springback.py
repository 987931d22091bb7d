"""Contact springback: the deformation of a finite line contact under the rolling force and the
CEB model's critical deformation (after the gear-rolling study, seed 004 in the docs' references)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...base import MM, InputError
from ._geometry import REFERENCE_GEAR, GearPair

__all__ = ["Springback", "contact_springback"]


@dataclass(frozen=True)
class Springback:
    """Seed 004's contact springback of a tooth flank (section 3.3), per load case.

    Attributes
    ----------
    deformation : ndarray
        Normal contact deformation ``delta`` of the finite-length line contact [m].
    critical : float
        The CEB model's critical deformation ``delta_c`` at which plastic flow starts [m].
    rebound : ndarray
        The contact springback: ``delta - delta_c`` where the contact is elastoplastic
        (``delta > delta_c``), seed 004's eq. 51; the paper gives no rebound for elastic contact,
        where this takes the whole ``delta`` (so the rebound drops from ``delta_c`` to 0 as
        ``delta`` passes ``delta_c``) [m].
    modulus : float
        The equivalent modulus ``E_c = ((1 - nu1^2) / E1 + (1 - nu2^2) / E2)^-1`` [Pa].
    """

    deformation: np.ndarray
    critical: float
    rebound: np.ndarray
    modulus: float


def contact_springback(force, length, gear: GearPair = REFERENCE_GEAR, *, e_tool: float, e_work: float,
                       nu_tool: float, nu_work: float, yield_strength: float, modulus: float | None = None,
                       roll: float = 0.0) -> Springback:
    """Seed 004's springback of the workpiece flank under the rolling force (its eqs. 49-51).

    The line contact of wheel and workpiece flank (length ``l``, radii of curvature ``R1``,
    ``R2`` of the two involutes where they touch) deforms by
    ``delta = F / (pi E_c l) ln(6.59 l^3 E_c (R1 + R2) / (F R1 R2))``; the CEB model's critical
    deformation is ``delta_c = (pi k H / (2 E_c))^2 R1 R2 / (R1 + R2)`` with
    ``k = 0.454 + 0.41 nu_work`` and ``H = 2.8 yield_strength``.

    Parameters
    ----------
    force : float or array_like
        Normal contact force ``F`` [N] (> 0).
    length : float or array_like
        Length of the contact line ``l`` [m] (> 0), broadcast with ``force``.
    gear : GearPair, default :data:`REFERENCE_GEAR`
        Sets the radii of curvature: for involutes touching at ``roll`` on the line of action,
        ``R2 = r2 sin(alpha) + roll`` (workpiece) and ``R1 = r1 sin(alpha) - roll`` (wheel).
    e_tool, e_work : float
        Elastic moduli of wheel and workpiece [Pa].
    nu_tool, nu_work : float
        Poisson's ratios of wheel and workpiece.
    yield_strength : float
        Yield strength of the workpiece material [Pa].
    modulus : float, optional
        Use this equivalent modulus ``E_c`` [Pa] instead of the one the moduli and Poisson's
        ratios give (to see which ``E_c`` a published table implies).
    roll : float, default 0.0
        Contact position on the line of action from the pitch point [m].

    Returns
    -------
    Springback
        Deformations per load case and the critical deformation.

    Raises
    ------
    InputError
        If a force, length, modulus or strength is not positive and finite, a Poisson's
        ratio is outside [0, 0.5), or ``roll`` puts the contact off either involute.
    """
    try:
        force, length = np.broadcast_arrays(np.asarray(force, dtype=float), np.asarray(length, dtype=float))
    except ValueError as err:
        raise InputError(f"force and length must be numbers of shapes that broadcast: {err}",
                         parameters=("force", "length")) from None
    for name, value in (("force", force), ("length", length)):
        if value.size == 0 or not (np.isfinite(value).all() and (value > 0).all()):
            raise InputError(f"{name} must be positive and finite", parameters=(name,))
    for name, value in (("e_tool", e_tool), ("e_work", e_work), ("yield_strength", yield_strength),
                        ("modulus", 1.0 if modulus is None else modulus)):
        if not (np.isfinite(value) and value > 0):
            raise InputError(f"{name} must be positive, got {value!r}", parameters=(name,))
    for name, value in (("nu_tool", nu_tool), ("nu_work", nu_work)):
        if not 0 <= value < 0.5:
            raise InputError(f"{name} must be within [0, 0.5), got {value!r}", parameters=(name,))
    if not np.isfinite(roll):
        raise InputError(f"roll must be finite, got {roll!r}", parameters=("roll",))
    s = np.sin(gear.pressure_angle)
    r_work, r_tool = gear.pitch_radius * s + roll, gear.tool_pitch_radius * s - roll
    if r_work <= 0 or r_tool <= 0:
        raise InputError(f"roll {roll / MM:g} mm puts the contact off the involutes (radii of curvature "
                         f"{r_work / MM:g}, {r_tool / MM:g} mm)", parameters=("roll",))
    e_c = modulus if modulus is not None else 1.0 / ((1 - nu_tool ** 2) / e_tool + (1 - nu_work ** 2) / e_work)
    delta = force / (np.pi * e_c * length) * np.log(6.59 * length ** 3 * e_c * (r_tool + r_work)
                                                    / (force * r_tool * r_work))
    k = 0.454 + 0.41 * nu_work
    critical = (np.pi * k * 2.8 * yield_strength / (2 * e_c)) ** 2 * r_tool * r_work / (r_tool + r_work)
    rebound = np.where(delta > critical, delta - critical, delta)
    return Springback(delta, float(critical), rebound, float(e_c))
