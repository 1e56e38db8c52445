"""Worm gear (gear_phm.models.WormGear) against the closed forms and a vector force balance."""
from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from gear_phm.models import ModelError
from gear_phm.models.worm import WormGear
from helpers.thread import flank_efficiencies, normal_from_normal_angle

SETTINGS = settings(max_examples=200, deadline=None, derandomize=True)
LEAD = st.floats(math.radians(0.5), math.radians(45.0))
ALPHA = st.floats(math.radians(10.0), math.radians(30.0))
MU = st.floats(0.0, 0.3)


def textbook(gamma: float, alpha_n: float, mu: float) -> tuple[float, float]:
    """Literature closed form (Niemann, ISO/TR 14521): tan phi' = mu / cos alpha_n."""
    phi = math.atan(mu / math.cos(alpha_n))
    return math.tan(gamma) / math.tan(gamma + phi), math.tan(gamma - phi) / math.tan(gamma)


@SETTINGS
@given(gamma=LEAD, alpha_n=ALPHA, mu=MU)
def test_closed_form_both_directions(gamma: float, alpha_n: float, mu: float) -> None:
    eta_d, eta_i = WormGear(gamma, 1, 40, alpha_n, mu).efficiencies()
    expected_d, expected_i = textbook(gamma, alpha_n, mu)
    assert eta_d == pytest.approx(expected_d, rel=1e-9, abs=1e-9)
    assert eta_i == pytest.approx(expected_i, rel=1e-9, abs=1e-9)


@SETTINGS
@given(gamma=LEAD, alpha_n=ALPHA, mu=MU)
def test_matches_vector_force_balance(gamma: float, alpha_n: float, mu: float) -> None:
    expected = flank_efficiencies(gamma, normal_from_normal_angle(gamma, alpha_n), mu)
    assert WormGear(gamma, 2, 41, alpha_n, mu).efficiencies() == pytest.approx(
        expected, rel=1e-9, abs=1e-9)


@SETTINGS
@given(gamma=LEAD, alpha_n=ALPHA, mu=st.floats(0.001, 0.3))
def test_self_locking_exactly_when_lead_at_most_friction_angle(gamma, alpha_n, mu) -> None:
    worm = WormGear(gamma, 1, 30, alpha_n, mu)
    phi = math.atan(mu / math.cos(alpha_n))
    assert worm.friction_angle == pytest.approx(phi, rel=1e-12)
    assert worm.self_locking == (gamma <= phi)
    eta_d, eta_i = worm.efficiencies()
    assert (eta_i <= 0.0) == worm.self_locking
    assert 0.0 < eta_d < 1.0
    assert eta_i < eta_d                       # back-driving is always the worse direction


def test_textbook_numbers() -> None:
    # gamma 4 deg, mu 0.09, alpha_n 20 deg: phi' = 5.471 deg, self-locking.
    worm = WormGear(math.radians(4.0), 1, 40, math.radians(20.0), 0.09)
    eta_d, eta_i = worm.efficiencies()
    assert math.degrees(worm.friction_angle) == pytest.approx(5.4709, abs=1e-4)
    assert worm.self_locking is True
    assert eta_d == pytest.approx(0.4192, abs=1e-4)
    assert eta_i == pytest.approx(-0.3672, abs=1e-4)
    assert worm.ratio == 40.0
    assert WormGear(math.radians(20.0), 4, 40).self_locking is False
    assert WormGear(math.radians(20.0), 4, 40, friction=0.0).efficiencies() == (1.0, 1.0)


def test_arrays_broadcast() -> None:
    gamma = np.radians([[3.0], [10.0], [25.0]])
    worm = WormGear(gamma, 1, 50, friction=np.array([0.02, 0.05, 0.1]))
    eta_d, eta_i = worm.efficiencies()
    assert eta_d.shape == eta_i.shape == (3, 3)
    assert worm.self_locking.shape == (3, 3)
    single = WormGear(float(gamma[1, 0]), 1, 50, friction=0.05).efficiencies()
    assert (eta_d[1, 1], eta_i[1, 1]) == single


@pytest.mark.parametrize('field, value, message', [
    ('lead_angle', 0.0, r'^lead_angle must be in \(0, 1\.5708\) rad, got 0\.0$'),
    ('lead_angle', math.nan, r'^lead_angle must be finite, got nan$'),
    ('starts', 0.0, r'^starts must be >= 1 \(one thread\), got 0\.0$'),
    ('wheel_teeth', 0.5, r'^wheel_teeth must be >= 1 \(one tooth\), got 0\.5$'),
    ('normal_pressure_angle', 1.6, r'^normal_pressure_angle must be in \(0, 1\.5708\) rad'),
    ('friction', -0.1, r'^friction must be >= 0, got -0\.1$'),
    ('friction', 10.0, r'^friction too high for the lead angle: .* the thread jams'),
])
def test_bad_field_raises_model_error_naming_it(field: str, value: float, message: str) -> None:
    fields = {'lead_angle': math.radians(30.0), 'starts': 1.0, 'wheel_teeth': 40.0,
              'normal_pressure_angle': math.radians(20.0), 'friction': 0.05}
    fields[field] = value
    with pytest.raises(ModelError, match=message):
        WormGear(**fields)
