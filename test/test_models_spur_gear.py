"""Reference spur-gear model (gear_phm.models.SpurGear) against an independent work integration.

:func:`mesh_work_efficiencies` below re-derives the efficiencies without the paper's torque
formulas: it places the two wheels in the plane, moves the contact point in small steps along
the line of action between the two tip circles, computes the velocity of each wheel's material
at the contact point, applies the normal force plus a Coulomb friction force opposing the
sliding, and integrates the power that each wheel exchanges with the contact and with its
bearing. Only the modelling assumptions of the paper are shared (constant normal force, contact
point moving uniformly, bearing friction radius acting on the cycle-mean tooth force).
"""
from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from gear_phm.models import min_teeth, SpurGear

SETTINGS = settings(max_examples=150, deadline=None, derandomize=True)


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


# ---------------------------------------------------------------- exact values

@SETTINGS
@given(geometry=geometries())
def test_no_friction_anywhere_is_exactly_lossless(geometry: dict) -> None:
    geometry.update(friction=0.0, bearing_radius_1=0.0, bearing_radius_2=0.0)
    eta_d, eta_i = SpurGear(**geometry).efficiencies()
    assert eta_d == 1.0
    assert eta_i == 1.0


def test_textbook_pair_with_usual_tooth_friction() -> None:
    # z 20/60, 20 deg, f = 0.05, ideal bearings. First-order sliding loss (independent):
    # P_loss / P = f (1/r_b1 + 1/r_b2) mean|s| with |s| the distance from the pitch point,
    # mean|s| = (A^2 + B^2) / (2 (A + B)) over the path of contact.
    module, theta = 2e-3, math.radians(20.0)
    gear = SpurGear(20, 60, module, theta, friction=0.05)
    eta_d, eta_i = gear.efficiencies()
    assert gear.ratio == 3.0
    assert 0.990 < eta_d < 0.9925
    assert 0.990 < eta_i < 0.9925
    assert abs(eta_d - eta_i) < 1e-4
    r_p1, r_p2 = module * 10, module * 30
    r_b1, r_b2 = r_p1 * math.cos(theta), r_p2 * math.cos(theta)
    a = math.sqrt((r_p1 + module) ** 2 - r_b1 ** 2) - r_p1 * math.sin(theta)
    b = math.sqrt((r_p2 + module) ** 2 - r_b2 ** 2) - r_p2 * math.sin(theta)
    loss = 0.05 * (1 / r_b1 + 1 / r_b2) * (a * a + b * b) / (2 * (a + b))
    assert loss == pytest.approx(0.00879, abs=1e-5)
    assert eta_d == pytest.approx(1 - loss, abs=1e-4)
    assert eta_i == pytest.approx(1 - loss, abs=1e-4)
    # The model's path of contact is this A, B (eq 3 on the motor side, no bearings) ...
    d_1, s = r_p1 * math.sin(theta), 0.05 / (a + b)
    assert gear.torques()['T_M_D'] == pytest.approx(
        r_b1 - s * b * (d_1 - b / 2) + s * a * (d_1 + a / 2), rel=1e-12)
    # ... and a standard full-depth pair's is about 1.67 base pitches (contact ratio).
    assert (a + b) / (math.pi * module * math.cos(theta)) == pytest.approx(1.67, abs=0.01)


# ---------------------------------------------------------------- independent integration

@SETTINGS
@given(geometry=geometries())
def test_matches_numerical_work_integration(geometry: dict) -> None:
    expected_d, expected_i = mesh_work_efficiencies(**geometry)
    eta_d, eta_i = SpurGear(**geometry).efficiencies()
    assert eta_d == pytest.approx(expected_d, rel=1e-9, abs=1e-9)
    assert eta_i == pytest.approx(expected_i, rel=1e-9, abs=1e-9)


@pytest.mark.parametrize('friction, rho_1, rho_2', [
    (0.05, 0.0, 0.0), (0.3, 0.0, 0.0), (0.0, 0.004, 0.0), (0.0, 0.0, 0.01),
    (0.1, 0.003, 0.009), (0.8, 0.01, 0.03)])
def test_matches_numerical_work_integration_concrete(friction, rho_1, rho_2) -> None:
    geometry = {'z1': 23.0, 'z2': 71.0, 'module': 1.5e-3, 'pressure_angle': math.radians(20.0),
                'addendum': 1.5e-3, 'friction': friction, 'bearing_radius_1': rho_1,
                'bearing_radius_2': rho_2}
    expected = mesh_work_efficiencies(**geometry)
    assert SpurGear(**geometry).efficiencies() == pytest.approx(expected, rel=1e-9)


def test_integration_resolves_tooth_friction() -> None:
    # The independent check would be useless if it were insensitive: flipping the friction
    # direction in one half of the path must change the answer well beyond the tolerance.
    base = mesh_work_efficiencies(20, 60, 2e-3, math.radians(20), 2e-3, 0.05, 0, 0)
    more = mesh_work_efficiencies(20, 60, 2e-3, math.radians(20), 2e-3, 0.06, 0, 0)
    assert base[0] - more[0] > 1e-3
    assert base[1] - more[1] > 1e-3


# ---------------------------------------------------------------- physical properties

@SETTINGS
@given(geometry=geometries(max_friction=2.0, max_bearing_fraction=2.0))
def test_efficiencies_never_exceed_one(geometry: dict) -> None:
    eta_d, eta_i = SpurGear(**geometry).efficiencies()
    assert eta_d <= 1.0
    assert eta_i <= 1.0


@SETTINGS
@given(geometry=geometries(), extra=st.floats(1e-3, 0.5))
def test_more_tooth_friction_lowers_both_efficiencies(geometry: dict, extra: float) -> None:
    eta_d, eta_i = SpurGear(**geometry).efficiencies()
    geometry['friction'] += extra
    worse_d, worse_i = SpurGear(**geometry).efficiencies()
    assert worse_d < eta_d
    assert worse_i < eta_i


@SETTINGS
@given(geometry=geometries(), which=st.sampled_from(['bearing_radius_1', 'bearing_radius_2']),
       extra=st.floats(0.01, 0.5))
def test_more_bearing_friction_lowers_both_efficiencies(geometry: dict, which: str,
                                                        extra: float) -> None:
    eta_d, eta_i = SpurGear(**geometry).efficiencies()
    geometry[which] += extra * geometry['module'] * geometry['z1'] / 2
    worse_d, worse_i = SpurGear(**geometry).efficiencies()
    assert worse_d < eta_d
    assert worse_i < eta_i


def test_ratio_is_teeth_ratio() -> None:
    assert SpurGear(20, 60).ratio == 3.0
    assert SpurGear(60, 20).ratio == pytest.approx(1 / 3)


# ---------------------------------------------------------------- broadcasting

def test_array_fields_broadcast_and_match_scalar_instances() -> None:
    z1 = np.array([[18.0], [25.0], [40.0]])                  # (3, 1)
    z2 = np.array([20.0, 57.0, 300.0, 3000.0])               # (4,)
    friction = np.array([0.02, 0.1, 0.3, 0.6])               # (4,)
    gear = SpurGear(z1, z2, module=1e-3, friction=friction, bearing_radius_1=2e-3,
                    bearing_radius_2=5e-3)
    eta_d, eta_i = gear.efficiencies()
    assert eta_d.shape == eta_i.shape == (3, 4)
    assert np.shape(gear.ratio) == (3, 4)
    assert all(np.shape(torque) == (3, 4) for torque in gear.torques().values())
    for i in range(3):
        for j in range(4):
            single = SpurGear(float(z1[i, 0]), float(z2[j]), module=1e-3,
                              friction=float(friction[j]), bearing_radius_1=2e-3,
                              bearing_radius_2=5e-3)
            scalar_d, scalar_i = single.efficiencies()
            assert isinstance(scalar_d, float) and isinstance(scalar_i, float)
            assert eta_d[i, j] == scalar_d
            assert eta_i[i, j] == scalar_i


def test_array_pressure_angle_checks_each_wheel_against_its_own_limit() -> None:
    theta = np.radians([20.0, 30.0])          # limits 17.1 and 8 teeth
    SpurGear(np.array([18.0, 9.0]), 40.0, pressure_angle=theta)
    with pytest.raises(ValueError, match=r'^z1 must be >= 17\.1 .* got 9\.0 at index \(0,\)'):
        SpurGear(np.array([9.0, 9.0]), 40.0, pressure_angle=theta)


# ---------------------------------------------------------------- bad input

@pytest.mark.parametrize('field, value, message', [
    ('z1', 10.0, r'^z1 must be >= 17\.1 \(involute undercut limit 2 \(a/m\) / '
                 r'sin\^2\(pressure_angle\)\), got 10\.0$'),
    ('z2', 17.0, r'^z2 must be >= 17\.1 .*, got 17\.0$'),
    ('z1', math.nan, r'^z1 must be finite, got nan$'),
    ('z2', math.inf, r'^z2 must be finite, got inf$'),
    ('module', 0.0, r'^module must be > 0, got 0\.0$'),
    ('module', -1e-3, r'^module must be > 0, got -0\.001$'),
    ('module', math.nan, r'^module must be finite, got nan$'),
    ('pressure_angle', 0.0, r'^pressure_angle must be in \(0, 1\.5708\) rad, got 0\.0$'),
    ('pressure_angle', math.pi / 2, r'^pressure_angle must be in \(0, 1\.5708\) rad, '
                                    r'got 1\.5707963267948966$'),
    ('pressure_angle', -0.3, r'^pressure_angle must be in \(0, 1\.5708\) rad, got -0\.3$'),
    ('addendum', 0.0, r'^addendum must be > 0, got 0\.0$'),
    ('friction', -0.01, r'^friction must be >= 0, got -0\.01$'),
    ('friction', math.inf, r'^friction must be finite, got inf$'),
    ('bearing_radius_1', -1e-3, r'^bearing_radius_1 must be >= 0, got -0\.001$'),
    ('bearing_radius_2', math.nan, r'^bearing_radius_2 must be finite, got nan$'),
])
def test_bad_field_raises_value_error_naming_field_and_value(field, value, message) -> None:
    fields = {'z1': 20.0, 'z2': 60.0, 'module': 1e-3, 'pressure_angle': math.radians(20.0),
              'friction': 0.05}
    fields[field] = value
    with pytest.raises(ValueError, match=message):
        SpurGear(**fields)


@SETTINGS
@given(theta_deg=st.floats(5.0, 60.0))
def test_undercut_limit_is_two_over_sine_squared(theta_deg: float) -> None:
    theta = math.radians(theta_deg)
    limit = 2.0 / math.sin(theta) ** 2
    assert float(min_teeth(theta)) == pytest.approx(limit, rel=1e-12)
    SpurGear(math.ceil(limit), 1000.0, pressure_angle=theta)
    below = math.ceil(limit) - 1.0
    if below < limit:
        with pytest.raises(ValueError, match=rf'^z1 must be >= .* got {below!r}$'):
            SpurGear(below, 1000.0, pressure_angle=theta)


# ---------------------------------------------------------------- bearing placement

@SETTINGS
@given(geometry=geometries(max_bearing_fraction=0.9))
def test_motor_bearing_alone_follows_the_infinite_ratio_lever(geometry: dict) -> None:
    """With only the motor-wheel bearing lossy, eta_I = 2 - 1/eta_D whatever z2/z1 is.

    That is the limit R -> inf of eq 14. This is why the simplified model, which ties the
    eta_D-eta_I relation to R alone, misses gears whose losses sit in the bearings (see
    docs/paper-reproduction.md).
    """
    geometry.update(friction=0.0, bearing_radius_2=0.0)
    eta_d, eta_i = SpurGear(**geometry).efficiencies()
    assert eta_i == pytest.approx(2.0 - 1.0 / eta_d, rel=1e-12, abs=1e-12)


@SETTINGS
@given(geometry=geometries(max_bearing_fraction=0.9))
def test_load_bearing_alone_follows_the_zero_ratio_lever(geometry: dict) -> None:
    """With only the load-wheel bearing lossy, eta_D = 2 - 1/eta_I: eq 14 at R -> 0."""
    geometry.update(friction=0.0, bearing_radius_1=0.0)
    eta_d, eta_i = SpurGear(**geometry).efficiencies()
    assert eta_d == pytest.approx(2.0 - 1.0 / eta_i, rel=1e-12, abs=1e-12)
