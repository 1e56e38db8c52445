"""Total squared error between a reference point and the simplified curve (eq 15)."""
from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from gear_phm.models import (eta_aiding, eta_aiding_from_opposing, eta_opposing,
                             eta_opposing_from_aiding)
from gear_phm.models.comparison import total_squared_error

SETTINGS = settings(max_examples=200, deadline=None, derandomize=True)


@SETTINGS
@given(u=st.floats(0.0, 20.0), ratio=st.floats(0.1, 50.0))
def test_point_on_the_curve_has_zero_error(u: float, ratio: float) -> None:
    error = total_squared_error(eta_opposing(u, ratio), eta_aiding(u, ratio), ratio)
    assert error == pytest.approx(0.0, abs=1e-24)


@SETTINGS
@given(eta_d=st.floats(0.2, 1.0), eta_i=st.floats(-0.5, 1.0), ratio=st.floats(0.1, 50.0))
def test_error_is_altitude_of_right_triangle(eta_d: float, eta_i: float, ratio: float) -> None:
    e_i = eta_i - eta_aiding_from_opposing(eta_d, ratio)
    e_d = eta_d - eta_opposing_from_aiding(eta_i, ratio)
    error = total_squared_error(eta_d, eta_i, ratio)
    if math.isnan(e_d) or math.isnan(e_i):
        assert math.isnan(error)
        return
    # Altitude h of the right triangle with legs |e_D|, |e_I|: h * hypotenuse = product of legs.
    hypotenuse = math.hypot(e_d, e_i)
    if hypotenuse == 0.0:
        assert error == 0.0
        return
    assert error == pytest.approx((abs(e_d) * abs(e_i) / hypotenuse) ** 2, rel=1e-9, abs=1e-30)
    assert error <= min(e_d * e_d, e_i * e_i) * (1 + 1e-12)


def test_concrete_value() -> None:
    # R = 1: curve eta_I = eta_D. Point (0.8, 0.6): e_I = -0.2, e_D = 0.2, e_tot = 0.02.
    assert total_squared_error(0.8, 0.6, 1.0) == pytest.approx(0.02, rel=1e-12)


def test_broadcasts() -> None:
    result = total_squared_error(np.array([[0.8], [0.9]]), np.array([0.6, 0.7, 0.8]), 1.0)
    assert result.shape == (2, 3)
    assert result[0, 2] == 0.0
    assert result[0, 0] == total_squared_error(0.8, 0.6, 1.0)


def test_bad_input_names_argument() -> None:
    with pytest.raises(ValueError, match=r'^ratio must be > 0, got 0\.0$'):
        total_squared_error(0.8, 0.6, 0.0)
    with pytest.raises(ValueError, match=r'^eta_aiding_ref must be finite, got nan$'):
        total_squared_error(0.8, math.nan, 2.0)
