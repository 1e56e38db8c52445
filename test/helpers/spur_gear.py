"""An independent reference for the spur-gear model: work integration and drawn geometries.

:func:`mesh_work_efficiencies` re-derives the efficiencies without the paper's torque
formulas: it places the two wheels in the plane, moves the contact point in small steps along
the line of action between the two tip circles, computes the velocity of each wheel's material
at the contact point, applies the normal force plus a Coulomb friction force opposing the
sliding, and integrates the power that each wheel exchanges with the contact and with its
bearing. Only the modelling assumptions of the paper are shared (constant normal force, contact
point moving uniformly, bearing friction radius acting on the cycle-mean tooth force).
:func:`geometries` draws valid gear pairs for hypothesis.
"""
from __future__ import annotations

import math

from hypothesis import strategies as st
import numpy as np

from gear_phm.models import min_teeth


def _cross_z(vector_x, vector_y, omega):
    """Velocity (vx, vy) of a point at (vector_x, vector_y) from the centre, rotation omega."""
    return -omega * vector_y, omega * vector_x


def mesh_work_efficiencies(z1: float, z2: float, module: float, pressure_angle: float,
                           addendum: float, friction: float, bearing_radius_1: float,
                           bearing_radius_2: float, steps: int = 4000) -> tuple[float, float]:
    """(eta_D, eta_I) [-] from the power balance of one mesh cycle, integrated numerically."""
    r_p1, r_p2 = module * z1 / 2, module * z2 / 2              # pitch radii, p = pi m
    r_b1, r_b2 = r_p1 * math.cos(pressure_angle), r_p2 * math.cos(pressure_angle)
    r_a1, r_a2 = r_p1 + addendum, r_p2 + addendum
    centre_distance = r_p1 + r_p2
    # Line of action along +x through T1 = (0, 0); wheel 1 below it, wheel 2 above it.
    length = math.sqrt(centre_distance ** 2 - (r_b1 + r_b2) ** 2)    # |T1 T2|
    o1, o2 = np.array([0.0, -r_b1]), np.array([length, r_b2])
    pitch_point = o1 + (o2 - o1) * r_p1 / centre_distance
    assert abs(pitch_point[1]) < 1e-12 * centre_distance            # P lies on the line
    # Contact exists where the point is inside both tip circles.
    x_start = length - math.sqrt(r_a2 ** 2 - r_b2 ** 2)
    x_end = math.sqrt(r_a1 ** 2 - r_b1 ** 2)
    x_pitch = pitch_point[0]
    assert x_start < x_pitch < x_end
    # Midpoints of small steps; the pitch point (where sliding reverses) is a step boundary.
    pieces = []
    for low, high in ((x_start, x_pitch), (x_pitch, x_end)):
        count = max(2, int(steps * (high - low) / (x_end - x_start)))
        edges = np.linspace(low, high, count + 1)
        pieces.append(((edges[:-1] + edges[1:]) / 2, np.diff(edges)))
    x = np.concatenate([p[0] for p in pieces])
    weight = np.concatenate([p[1] for p in pieces]) / (x_end - x_start)   # time fraction

    def cycle(omega_1: float) -> tuple[float, float, float, float]:
        """Mean powers per unit normal force.

        Into wheel 1, into wheel 2 (from the contact), lost in bearing 1, lost in bearing 2.
        """
        omega_2 = -omega_1 * r_b1 / r_b2
        v1 = _cross_z(x - o1[0], 0.0 - o1[1], omega_1)
        v2 = _cross_z(x - o2[0], 0.0 - o2[1], omega_2)
        assert np.allclose(v1[0], v2[0], rtol=1e-12, atol=0.0)   # no separation or overlap
        sliding = v1[1] - v2[1]           # velocity of wheel 1 relative to wheel 2, normal to LoA
        # Force on wheel 2 from wheel 1: the normal force pushes wheel 2 along +x (the same
        # flanks stay in contact for both load conditions); friction drags wheel 2 along the
        # motion of wheel 1 relative to it.
        force_x = np.ones_like(x)
        force_y = friction * np.sign(sliding)
        power_2 = np.sum(weight * (force_x * v2[0] + force_y * v2[1]))
        power_1 = np.sum(weight * (-force_x * v1[0] - force_y * v1[1]))
        mean_force = math.hypot(np.sum(weight * force_x), np.sum(weight * force_y))
        return (power_1, power_2, bearing_radius_1 * mean_force * abs(omega_1),
                bearing_radius_2 * mean_force * abs(omega_2))

    # Opposing load: motor turns wheel 1 clockwise, the contact point runs from B into A.
    power_1, power_2, loss_1, loss_2 = cycle(-1.0)
    motor_in = -power_1 + loss_1
    load_out = power_2 - loss_2
    eta_d = load_out / motor_in
    # Aiding load: motion reversed, the load drives; the motor absorbs power.
    power_1, power_2, loss_1, loss_2 = cycle(+1.0)
    load_in = -power_2 + loss_2
    motor_out = power_1 - loss_1
    eta_i = motor_out / load_in
    return eta_d, eta_i


@st.composite
def geometries(draw, max_friction: float = 0.5, max_bearing_fraction: float = 0.5) -> dict:
    """Draw valid gear pairs: teeth >= the undercut limit, bearing radii < pitch radius."""
    pressure_angle = math.radians(draw(st.floats(12.0, 35.0)))
    z_low = math.ceil(float(min_teeth(pressure_angle)))
    z1 = draw(st.integers(z_low, 400))
    z2 = draw(st.integers(z_low, 3000))
    module = draw(st.floats(2e-4, 1e-2))
    return {
        'z1': float(z1), 'z2': float(z2), 'module': module, 'pressure_angle': pressure_angle,
        'addendum': module * draw(st.floats(0.6, 1.0)),
        'friction': draw(st.floats(0.0, max_friction)),
        'bearing_radius_1': draw(st.floats(0.0, max_bearing_fraction)) * module * z1 / 2,
        'bearing_radius_2': draw(st.floats(0.0, max_bearing_fraction)) * module * z2 / 2,
    }
