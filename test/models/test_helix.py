"""Coulomb friction on a helical thread (gear_phm.models._helix): angles and efficiencies."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gear_phm.models._helix import friction_angle, thread_efficiencies
from gear_phm.models._validation import ModelError


def test_friction_angle_is_the_arctangent_over_the_flank_cosine() -> None:
    assert friction_angle(np.float64(0.1), np.float64(0.0)) == pytest.approx(math.atan(0.1))
    assert friction_angle(np.float64(0.1), np.float64(math.radians(20.0))) \
        == pytest.approx(math.atan(0.1 / math.cos(math.radians(20.0))), rel=1e-15)


def test_thread_efficiencies_of_an_inclined_plane() -> None:
    lead, phi = np.float64(math.radians(10.0)), np.float64(math.radians(4.0))
    eta_d, eta_i = thread_efficiencies(lead, phi)
    assert eta_d == pytest.approx(math.tan(lead) / math.tan(lead + phi), rel=1e-15)
    assert eta_i == pytest.approx(math.tan(lead - phi) / math.tan(lead), rel=1e-15)
    assert 0.0 < eta_i < eta_d < 1.0
    assert thread_efficiencies(lead, np.float64(0.0)) == pytest.approx((1.0, 1.0))


def test_a_thread_at_or_below_its_friction_angle_cannot_be_back_driven() -> None:
    lead = np.array([0.05, 0.07, 0.2])
    _, eta_i = thread_efficiencies(lead, np.full(3, 0.07))
    assert eta_i[0] < 0.0 and eta_i[1] == pytest.approx(0.0, abs=1e-15) and eta_i[2] > 0.0


def test_a_thread_that_jams_when_driven_is_refused_naming_the_index() -> None:
    lead = np.array([0.3, 1.2])
    with pytest.raises(ModelError, match=r'^mu too high for the lead angle at index \(1,\)'):
        thread_efficiencies(lead, np.array([0.3, 0.4]), name='mu')
    with pytest.raises(ModelError, match=r'lead angle \+ friction angle 1\.6 rad >= pi/2'):
        thread_efficiencies(np.float64(1.2), np.float64(0.4))
