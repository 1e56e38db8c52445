"""An independent reference for the thread models: the force on one flank element, in vectors.

:func:`flank_efficiencies` places the contact in the local frame (e_theta circumferential,
e_z axial, e_r radial) of the screw (worm), takes the flank normal from a given vector, lets
the nut (wheel tooth) move so that the sliding stays in the flank, applies the normal force
plus a Coulomb force opposing the sliding, and returns output power over input power for both
directions of the power flow. It shares no formula with gear_phm.models._helix.
"""
from __future__ import annotations

import math

import numpy as np

E_THETA, E_Z, E_R = np.eye(3)


def helix_tangent(lead_angle: float) -> np.ndarray:
    """Return the unit vector along the thread at lead angle gamma."""
    return math.cos(lead_angle) * E_THETA + math.sin(lead_angle) * E_Z


def normal_from_normal_angle(lead_angle: float, normal_angle: float) -> np.ndarray:
    """Flank normal inclined by alpha_n in the plane normal to the thread (worm convention)."""
    across = -math.sin(lead_angle) * E_THETA + math.cos(lead_angle) * E_Z
    return math.cos(normal_angle) * across + math.sin(normal_angle) * E_R


def normal_from_axial_angle(lead_angle: float, axial_angle: float) -> np.ndarray:
    """Flank normal of a thread whose profile is inclined by alpha in the axial section."""
    profile = math.cos(axial_angle) * E_R - math.sin(axial_angle) * E_Z
    normal = np.cross(helix_tangent(lead_angle), profile)
    normal /= np.linalg.norm(normal)
    return normal if normal @ E_Z > 0 else -normal


def flank_efficiencies(lead_angle: float, normal: np.ndarray,
                       friction: float) -> tuple[float, float]:
    """(eta_D, eta_I) [-]: screw (worm) driving, then nut (wheel) driving, same flank."""
    screw_speed = E_THETA                                   # the screw's material, unit speed
    # The nut moves axially at the speed that keeps the relative motion inside the flank.
    nut_speed = (screw_speed @ normal) / (E_Z @ normal) * E_Z
    sliding = screw_speed - nut_speed                       # screw relative to the nut
    assert abs(sliding @ normal) < 1e-12
    along = sliding / np.linalg.norm(sliding)
    results = []
    for back_driven in (False, True):
        sign = -1.0 if back_driven else 1.0                 # the motion reverses, not the force
        # Force of the screw on the nut: pressure on the flank, friction dragging the nut
        # along the screw's relative sliding (sign reverses with the motion).
        force = -normal + friction * sign * along
        to_nut = force @ (sign * nut_speed)                 # power the nut receives
        from_screw = force @ (sign * screw_speed)           # power the screw gives
        results.append(to_nut / from_screw if not back_driven else from_screw / to_nut)
    return results[0], results[1]
