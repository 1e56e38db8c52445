"""Lead, ball and roller screws (gear_phm.models) against closed forms and a force balance."""
from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st
import pytest

from gear_phm.models import ModelError
from gear_phm.models.screw import BallScrew, LeadScrew, RollerScrew
from helpers.thread import flank_efficiencies, normal_from_axial_angle

SETTINGS = settings(max_examples=200, deadline=None, derandomize=True)
LEAD = st.floats(0.5e-3, 50e-3)
DIAMETER = st.floats(6e-3, 100e-3)
ALPHA = st.floats(0.0, math.radians(40.0))
MU = st.floats(0.0, 0.3)


def lead_screw_textbook(lead: float, diameter: float, alpha: float,
                        mu: float) -> tuple[float, float]:
    """Shigley's power-screw formulas (thread angle 2 alpha) as efficiencies."""
    tan_l = lead / (math.pi * diameter)
    cos_alpha_n = math.cos(math.atan(math.tan(alpha) * math.cos(math.atan(tan_l))))
    phi = math.atan(mu / cos_alpha_n)
    lam = math.atan(tan_l)
    return tan_l / math.tan(lam + phi), math.tan(lam - phi) / tan_l


@SETTINGS
@given(lead=LEAD, diameter=DIAMETER, alpha=ALPHA, mu=MU)
def test_lead_screw_closed_form(lead: float, diameter: float, alpha: float, mu: float) -> None:
    if math.atan(lead / (math.pi * diameter)) + math.atan(mu / math.cos(alpha)) > 1.5:
        return                                           # jams when driven: refused
    screw = LeadScrew(lead, diameter, alpha, mu)
    assert screw.efficiencies() == pytest.approx(
        lead_screw_textbook(lead, diameter, alpha, mu), rel=1e-9, abs=1e-9)


@SETTINGS
@given(lead=LEAD, diameter=DIAMETER, alpha=ALPHA, mu=MU)
def test_lead_screw_matches_vector_force_balance(lead, diameter, alpha, mu) -> None:
    lam = math.atan(lead / (math.pi * diameter))
    if lam + math.atan(mu / math.cos(alpha)) > 1.5:
        return
    expected = flank_efficiencies(lam, normal_from_axial_angle(lam, alpha), mu)
    assert LeadScrew(lead, diameter, alpha, mu).efficiencies() == pytest.approx(
        expected, rel=1e-9, abs=1e-9)


@SETTINGS
@given(lead=LEAD, diameter=DIAMETER, mu=st.floats(0.0, 0.02))
def test_ball_screw_at_axial_contact_is_the_catalogue_formula(lead, diameter, mu) -> None:
    # NSK / THK catalogues: eta_1 = (1 - mu tan l) / (1 + mu / tan l), eta_2 = (1 - mu / tan l)
    # / (1 + mu tan l), with mu the equivalent coefficient (contact normal along the axis).
    tan_l = lead / (math.pi * diameter)
    eta_d, eta_i = BallScrew(lead, diameter, math.pi / 2, mu).efficiencies()
    assert eta_d == pytest.approx((1 - mu * tan_l) / (1 + mu / tan_l), rel=1e-9, abs=1e-9)
    assert eta_i == pytest.approx((1 - mu / tan_l) / (1 + mu * tan_l), rel=1e-9, abs=1e-9)


@SETTINGS
@given(lead=LEAD, diameter=DIAMETER, beta=st.floats(math.radians(30.0), math.radians(90.0)),
       mu=st.floats(0.0, 0.02))
def test_ball_and_roller_screw_match_vector_force_balance(lead, diameter, beta, mu) -> None:
    lam = math.atan(lead / (math.pi * diameter))
    expected = flank_efficiencies(lam, normal_from_axial_angle(lam, math.pi / 2 - beta), mu)
    assert BallScrew(lead, diameter, beta, mu).efficiencies() == pytest.approx(
        expected, rel=1e-9, abs=1e-9)
    assert RollerScrew(lead, diameter, beta, mu).efficiencies() == pytest.approx(
        expected, rel=1e-9, abs=1e-9)


def test_ratio_is_two_pi_over_lead_in_rad_per_metre() -> None:
    screw = BallScrew(5e-3, 20e-3)
    assert screw.ratio == pytest.approx(2 * math.pi / 5e-3, rel=1e-15)
    # Ideal: force = R torque; motor speed = R linear speed; power F v = T omega.
    torque, speed = 1.0, 0.01
    assert (screw.ratio * torque) * speed == pytest.approx(torque * (screw.ratio * speed))


def test_typical_screws() -> None:
    # Tr 20x4 lead screw, steel on bronze mu 0.1: self-locking, eta_D about 0.40.
    tr20 = LeadScrew(4e-3, 18e-3, math.radians(15.0), 0.1)
    eta_d, eta_i = tr20.efficiencies()
    assert tr20.self_locking is True
    assert eta_d == pytest.approx(0.4030, abs=1e-4)
    assert eta_i < 0.0
    # 20 x 5 ball screw, mu 0.005: about 0.92 both ways, back-drivable.
    ball = BallScrew(5e-3, 20e-3, rolling_friction=0.005)
    eta_d, eta_i = ball.efficiencies()
    assert ball.self_locking is False
    assert 0.90 < eta_i < eta_d < 0.93


@pytest.mark.parametrize('make, message', [
    (lambda: LeadScrew(0.0, 0.02), r'^lead must be > 0, got 0\.0$'),
    (lambda: LeadScrew(4e-3, -0.02), r'^diameter must be > 0, got -0\.02$'),
    (lambda: LeadScrew(4e-3, 0.02, flank_angle=-0.1), r'^flank_angle must be in \[0, 1\.5708\)'),
    (lambda: LeadScrew(4e-3, 0.02, friction=math.nan), r'^friction must be finite, got nan$'),
    (lambda: LeadScrew(4e-3, 0.02, friction=100.0), r'^friction too high for the lead angle'),
    (lambda: BallScrew(5e-3, 0.02, contact_angle=0.0), r'^contact_angle must be in \(0, '),
    (lambda: BallScrew(5e-3, 0.02, rolling_friction=-1e-3),
     r'^rolling_friction must be >= 0, got -0\.001$'),
])
def test_bad_field_raises_model_error_naming_it(make, message: str) -> None:
    with pytest.raises(ModelError, match=message):
        make()
