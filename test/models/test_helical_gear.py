"""Helical stage (gear_phm.models.HelicalGear): the spur model in the transverse plane."""
from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st
import pytest

from gear_phm.models import ModelError, SpurGear
from gear_phm.models.helical_gear import HelicalGear
from helpers.spur_gear import geometries, mesh_work_efficiencies

SETTINGS = settings(max_examples=100, deadline=None, derandomize=True)
HELIX = st.floats(0.0, math.radians(45.0))


@SETTINGS
@given(geometry=geometries())
def test_zero_helix_angle_is_the_spur_stage_exactly(geometry: dict) -> None:
    helical = HelicalGear(**geometry, helix_angle=0.0)
    assert helical.efficiencies() == SpurGear(**geometry).efficiencies()
    assert helical.ratio == SpurGear(**geometry).ratio


@SETTINGS
@given(geometry=geometries(), beta=HELIX)
def test_matches_work_integration_of_the_transverse_pair(geometry: dict, beta: float) -> None:
    """Independent: the transverse pair integrated with the flank force's transverse share."""
    alpha_n, m_n = geometry['pressure_angle'], geometry['module']
    alpha_t = math.atan(math.tan(alpha_n) / math.cos(beta))
    # Base helix angle from the transverse form tan(beta_b) = tan(beta) cos(alpha_t).
    beta_b = math.atan(math.tan(beta) * math.cos(alpha_t))
    transverse = dict(geometry, module=m_n / math.cos(beta), pressure_angle=alpha_t,
                      friction=geometry['friction'] / math.cos(beta_b))
    expected = mesh_work_efficiencies(**transverse)
    assert HelicalGear(**geometry, helix_angle=beta).efficiencies() == pytest.approx(
        expected, rel=1e-9, abs=1e-9)


@SETTINGS
@given(alpha_n=st.floats(math.radians(14.5), math.radians(30.0)), beta=HELIX)
def test_base_pitch_is_normal_base_pitch_over_cos_base_helix(alpha_n: float,
                                                             beta: float) -> None:
    """Meshing needs p_bn = p_bt cos(beta_b): checks alpha_t and beta_b of the model."""
    m_n = 1e-3
    gear = HelicalGear(40, 80, m_n, alpha_n, beta)
    m_t, alpha_t = float(gear.transverse.module), float(gear.transverse.pressure_angle)
    p_bt = math.pi * m_t * math.cos(alpha_t)
    p_bn = math.pi * m_n * math.cos(alpha_n)
    assert p_bt * math.cos(float(gear.base_helix_angle)) == pytest.approx(p_bn, rel=1e-12)


def test_effective_friction_uses_the_base_helix_angle() -> None:
    beta, alpha_n = math.radians(30.0), math.radians(20.0)
    gear = HelicalGear(30, 90, 2e-3, alpha_n, beta, friction=0.1)
    beta_b = math.asin(math.sin(beta) * math.cos(alpha_n))
    assert float(gear.transverse.friction) == pytest.approx(0.1 / math.cos(beta_b), rel=1e-12)
    assert float(gear.transverse.friction) < 0.1 / math.cos(beta)
    # The same transverse pair with the flank's f is more efficient.
    plain = SpurGear(30, 90, gear.transverse.module, gear.transverse.pressure_angle,
                     gear.transverse.addendum, friction=0.1).efficiencies()
    assert gear.efficiencies()[0] < plain[0]
    assert gear.efficiencies()[1] < plain[1]


def test_helical_undercut_limit_is_lower() -> None:
    # 20 deg, 30 deg helix: z_min = 2 cos(beta) / sin^2(alpha_t) = 11.5 (spur: 17.1).
    beta = math.radians(30.0)
    alpha_t = math.atan(math.tan(math.radians(20.0)) / math.cos(beta))
    assert 2 * math.cos(beta) / math.sin(alpha_t) ** 2 == pytest.approx(11.5, abs=0.05)
    HelicalGear(12, 40, 1e-3, math.radians(20.0), beta)
    with pytest.raises(ModelError, match=r'^z1 must be >= 11\.5'):
        HelicalGear(11, 40, 1e-3, math.radians(20.0), beta)


@pytest.mark.parametrize('field, value, message', [
    ('helix_angle', -0.1, r'^helix_angle must be in \[0, 1\.5708\) rad, got -0\.1$'),
    ('helix_angle', math.pi / 2, r'^helix_angle must be in \[0, 1\.5708\) rad'),
    ('module', 0.0, r'^module must be > 0, got 0\.0$'),
    ('pressure_angle', 0.0, r'^pressure_angle must be in \(0, 1\.5708\) rad'),
    ('friction', -1.0, r'^friction must be >= 0, got -1\.0$'),
    ('z2', math.nan, r'^z2 must be finite, got nan$'),
    ('bearing_radius_2', -1.0, r'^bearing_radius_2 must be >= 0, got -1\.0$'),
])
def test_bad_field_raises_model_error_naming_it(field: str, value: float, message: str) -> None:
    fields = {'z1': 20.0, 'z2': 60.0, 'module': 1e-3, 'pressure_angle': math.radians(20.0),
              'helix_angle': math.radians(15.0), 'friction': 0.05}
    fields[field] = value
    with pytest.raises(ModelError, match=message):
        HelicalGear(**fields)
