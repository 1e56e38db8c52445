"""Reference spur-gear model (gear_phm.models.SpurGear) against an independent work integration.

:func:`helpers.spur_gear.mesh_work_efficiencies` re-derives the efficiencies without the
paper's torque formulas, by integrating the power of each wheel over one mesh cycle (see
there); only the modelling assumptions of the paper are shared.
"""
from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from gear_phm.models.spur_gear import min_teeth, SpurGear
from helpers.spur_gear import geometries, mesh_work_efficiencies

SETTINGS = settings(max_examples=150, deadline=None, derandomize=True)


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
