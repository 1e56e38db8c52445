"""Simplified lever model (gear_phm.models.lever): exact values, inverses, domain, broadcasting."""
from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from gear_phm.models import (
    d_u_d_eta_aiding,
    d_u_d_eta_opposing,
    eta_aiding,
    eta_aiding_from_opposing,
    eta_opposing,
    eta_opposing_from_aiding,
    u_from_eta_aiding,
    u_from_eta_opposing,
)

SETTINGS = settings(max_examples=300, deadline=None, derandomize=True)
RATIOS = st.floats(0.01, 1e4)
FRICTIONS = st.floats(0.0, 1e3)


def close(a: float, b: float, tol: float = 1e-12) -> bool:
    return math.isclose(a, b, rel_tol=tol, abs_tol=tol)


# ---------------------------------------------------------------- exact values

@SETTINGS
@given(ratio=RATIOS)
def test_frictionless_lever_is_lossless_both_ways(ratio: float) -> None:
    assert eta_opposing(0.0, ratio) == 1.0
    assert eta_aiding(0.0, ratio) == 1.0
    assert u_from_eta_opposing(1.0, ratio) == 0.0
    assert u_from_eta_aiding(1.0, ratio) == 0.0


@SETTINGS
@given(u=FRICTIONS, ratio=RATIOS)
def test_aiding_efficiency_negative_exactly_when_self_locking(u: float, ratio: float) -> None:
    eta_i = eta_aiding(u, ratio)
    assert (eta_i < 0.0) == (u > 1.0)
    assert (eta_i > 0.0) == (u < 1.0)


@SETTINGS
@given(ratio=RATIOS)
def test_zero_efficiency_points(ratio: float) -> None:
    assert eta_opposing(ratio, ratio) == 0.0     # the lever jams at u = R
    assert eta_aiding(1.0, ratio) == 0.0         # self-locking onset at u = 1


@SETTINGS
@given(u=FRICTIONS, ratio=RATIOS)
def test_efficiencies_bounded_by_energy_and_by_their_limits(u: float, ratio: float) -> None:
    eta_d, eta_i = eta_opposing(u, ratio), eta_aiding(u, ratio)
    assert -1.0 / ratio <= eta_d <= 1.0
    assert -ratio <= eta_i <= 1.0


@SETTINGS
@given(u=st.floats(0.0, 1e3), du=st.floats(1e-6, 1e3), ratio=RATIOS)
def test_efficiencies_decrease_with_friction(u: float, du: float, ratio: float) -> None:
    assert eta_opposing(u + du, ratio) < eta_opposing(u, ratio)
    assert eta_aiding(u + du, ratio) < eta_aiding(u, ratio)


def test_exact_textbook_numbers() -> None:
    # R = 2, u = 0.5: eta_D = 1.5 / 3 = 0.5, eta_I = 2 * 0.5 / 2.5 = 0.4.
    assert eta_opposing(0.5, 2.0) == pytest.approx(0.5, abs=1e-15)
    assert eta_aiding(0.5, 2.0) == pytest.approx(0.4, abs=1e-15)
    assert eta_aiding_from_opposing(0.5, 2.0) == pytest.approx(0.4, abs=1e-15)
    assert eta_opposing_from_aiding(0.4, 2.0) == pytest.approx(0.5, abs=1e-15)
    # R = 1: eta_D = eta_I = (1 - u) / (1 + u); u = 1/3 -> 0.5.
    assert eta_opposing(1 / 3, 1.0) == pytest.approx(0.5, abs=1e-15)
    assert eta_aiding(1 / 3, 1.0) == pytest.approx(0.5, abs=1e-15)


def test_large_ratio_half_opposing_efficiency_gives_zero_aiding() -> None:
    # Paper, section 3: for high R, eta_I -> 0 as eta_D -> 0.5.
    eta_i = eta_aiding_from_opposing(0.5, 1e6)
    assert abs(eta_i) < 1e-5
    assert eta_i == pytest.approx(1.0 / (0.5e6 + 1.5), rel=1e-12)
    # The limit curve (2 eta_D - 1) / eta_D.
    for eta_d in (0.3, 0.5, 0.7, 0.9):
        assert eta_aiding_from_opposing(eta_d, 1e9) == pytest.approx(
            (2 * eta_d - 1) / eta_d, abs=1e-7)


# ---------------------------------------------------------------- inverses

ROUND_TRIP_U = st.floats(0.0, 100.0)
ROUND_TRIP_R = st.floats(0.1, 50.0)


@SETTINGS
@given(u=ROUND_TRIP_U, ratio=ROUND_TRIP_R)
def test_u_round_trips_through_opposing_efficiency(u: float, ratio: float) -> None:
    assert close(u_from_eta_opposing(eta_opposing(u, ratio), ratio), u)


@SETTINGS
@given(u=ROUND_TRIP_U, ratio=ROUND_TRIP_R)
def test_u_round_trips_through_aiding_efficiency(u: float, ratio: float) -> None:
    assert close(u_from_eta_aiding(eta_aiding(u, ratio), ratio), u)


@SETTINGS
@given(u=ROUND_TRIP_U, ratio=ROUND_TRIP_R)
def test_opposing_round_trips_through_aiding(u: float, ratio: float) -> None:
    eta_d = eta_opposing(u, ratio)
    eta_i = eta_aiding_from_opposing(eta_d, ratio)
    assert close(eta_opposing_from_aiding(eta_i, ratio), eta_d)


@SETTINGS
@given(u=ROUND_TRIP_U, ratio=ROUND_TRIP_R)
def test_aiding_from_opposing_equals_aiding_of_same_friction(u: float, ratio: float) -> None:
    assert close(eta_aiding_from_opposing(eta_opposing(u, ratio), ratio),
                 eta_aiding(u, ratio))
    assert close(eta_opposing_from_aiding(eta_aiding(u, ratio), ratio),
                 eta_opposing(u, ratio))


@SETTINGS
@given(eta=st.floats(-0.9, 1.0), ratio=ROUND_TRIP_R)
def test_derivatives_match_central_differences(eta: float, ratio: float) -> None:
    step = 1e-6
    eta_d = max(eta, -0.9 / ratio)      # keep away from the pole at eta_D = -1/R
    numeric = (u_from_eta_opposing(eta_d + step, ratio)
               - u_from_eta_opposing(eta_d - step, ratio)) / (2 * step)
    assert d_u_d_eta_opposing(eta_d, ratio) == pytest.approx(numeric, rel=1e-5)
    eta_i = max(eta, -0.9 * ratio)      # and from the pole at eta_I = -R
    numeric = (u_from_eta_aiding(eta_i + step, ratio)
               - u_from_eta_aiding(eta_i - step, ratio)) / (2 * step)
    assert d_u_d_eta_aiding(eta_i, ratio) == pytest.approx(numeric, rel=1e-5)


# ---------------------------------------------------------------- out of domain (documented)

def test_efficiency_slightly_above_one_continues_to_negative_friction() -> None:
    # A noisy measurement above 1 maps to u < 0, not clipped (estimator unbiasedness).
    u = u_from_eta_opposing(1.001, 3.0)
    assert u < 0.0
    assert u == pytest.approx(3.0 * (1 - 1.001) / (3.0 * 1.001 + 1), rel=1e-12)
    assert eta_opposing(u, 3.0) == pytest.approx(1.001, rel=1e-12)
    u = u_from_eta_aiding(1.001, 3.0)
    assert u < 0.0
    assert eta_aiding(u, 3.0) == pytest.approx(1.001, rel=1e-12)
    assert eta_opposing(-0.01, 3.0) > 1.0
    assert eta_aiding(-0.01, 3.0) > 1.0


def test_no_pre_image_gives_nan() -> None:
    ratio = 4.0
    assert math.isnan(eta_opposing(-1.0, ratio))
    assert math.isnan(eta_opposing(-2.0, ratio))
    assert math.isnan(eta_aiding(-ratio, ratio))
    assert math.isnan(u_from_eta_opposing(-1.0 / ratio, ratio))
    assert math.isnan(u_from_eta_opposing(-1.0, ratio))
    assert math.isnan(u_from_eta_aiding(-ratio, ratio))
    assert math.isnan(eta_aiding_from_opposing(-1.0, ratio))
    assert math.isnan(eta_opposing_from_aiding(-5.0, ratio))
    assert math.isnan(d_u_d_eta_opposing(-1.0 / ratio, ratio))
    assert math.isnan(d_u_d_eta_aiding(-ratio, ratio))
    # Just inside the physical domain the values are finite.
    assert math.isfinite(u_from_eta_opposing(-0.99 / ratio, ratio))
    assert math.isfinite(u_from_eta_aiding(-0.99 * ratio, ratio))


def test_nan_elements_do_not_warn_or_poison_neighbours() -> None:
    with np.errstate(all='raise'):
        result = u_from_eta_opposing(np.array([-1.0, 0.5, 1.0]), 1.0)
    assert math.isnan(result[0])
    assert result[1] == pytest.approx(1.0 / 3.0)
    assert result[2] == 0.0


# ---------------------------------------------------------------- broadcasting

FUNCTIONS = [eta_opposing, eta_aiding, u_from_eta_opposing, u_from_eta_aiding,
             eta_aiding_from_opposing, eta_opposing_from_aiding, d_u_d_eta_opposing,
             d_u_d_eta_aiding]


@pytest.mark.parametrize('function', FUNCTIONS, ids=lambda f: f.__name__)
def test_broadcasts_like_a_ufunc(function) -> None:
    first = np.array([[0.1], [0.4], [0.8]])              # (3, 1)
    ratios = np.array([0.5, 1.0, 3.0, 40.0])              # (4,)
    result = function(first, ratios)
    assert isinstance(result, np.ndarray)
    assert result.shape == (3, 4)
    for i in range(3):
        for j in range(4):
            scalar = function(float(first[i, 0]), float(ratios[j]))
            assert isinstance(scalar, float)
            assert result[i, j] == scalar


# ---------------------------------------------------------------- bad input

@pytest.mark.parametrize('function', FUNCTIONS, ids=lambda f: f.__name__)
@pytest.mark.parametrize('ratio, shown', [(0.0, '0.0'), (-2.5, '-2.5')])
def test_non_positive_ratio_names_argument_and_value(function, ratio, shown) -> None:
    with pytest.raises(ValueError, match=rf'^ratio must be > 0, got {shown}$'):
        function(0.5, ratio)


@pytest.mark.parametrize('function', FUNCTIONS, ids=lambda f: f.__name__)
@pytest.mark.parametrize('bad, shown', [(math.nan, 'nan'), (math.inf, 'inf'),
                                        (-math.inf, '-inf')])
def test_non_finite_arguments_name_argument_and_value(function, bad, shown) -> None:
    with pytest.raises(ValueError, match=rf'^ratio must be finite, got {shown}$'):
        function(0.5, bad)
    with pytest.raises(ValueError, match=rf' must be finite, got {shown}$') as info:
        function(bad, 2.0)
    first_name = function.__code__.co_varnames[0]
    assert str(info.value).startswith(f'{first_name} must be finite')


def test_bad_array_element_is_located() -> None:
    with pytest.raises(ValueError, match=r'^ratio must be > 0, got -1\.0 at index \(2,\) '
                                         r'\(1 bad element\(s\)\)$'):
        eta_opposing(0.1, np.array([1.0, 2.0, -1.0]))


def test_non_numeric_argument_is_named() -> None:
    with pytest.raises(ValueError, match=r"^u must be a real number or array, got 'abc'$"):
        eta_opposing('abc', 2.0)


@pytest.mark.parametrize('ratio', [0.5, 3.0, 30.0])
def test_float_readings_are_eq_13_both_ways(ratio: float) -> None:
    """``readings`` (the diagnostics' per-update path) agrees with the numpy functions."""
    from gear_phm.models.lever import efficiencies, readings, u_from_eta_aiding
    for u in (0.0, 0.05, 0.3, 0.9):
        eta_d, eta_i = efficiencies(u, ratio)
        u_d, u_i = readings(eta_d, eta_i, ratio)
        assert u_d == pytest.approx(float(u_from_eta_opposing(eta_d, ratio)), rel=1e-12,
                                    abs=1e-15)
        assert u_i == pytest.approx(float(u_from_eta_aiding(eta_i, ratio)), rel=1e-12,
                                    abs=1e-15)
        assert (u_d, u_i) == pytest.approx((u, u), abs=1e-12)
    u_d, u_i = readings(-1.0 / ratio - 0.1, math.nan, ratio)     # no u reaches them
    assert math.isnan(u_d) and math.isnan(u_i)


@pytest.mark.parametrize('ratio', [0.5, 3.0, 30.0])
def test_reading_with_slope_is_bit_identical_to_the_numpy_functions(ratio: float) -> None:
    """The estimator's per-window path gives the numpy functions' values to the last bit.

    Also at an eta where base * base and numpy's scalar base ** 2 differ (0.93..., R = 3).
    """
    from gear_phm.models.lever import reading_with_slope
    rng = np.random.default_rng(5)
    etas = [0.9307554281028677, -1.0 / ratio - 0.1, -ratio - 0.1, *rng.uniform(-2, 1.5, 400)]
    for eta in etas:
        for aiding, u_of, slope_of in ((False, u_from_eta_opposing, d_u_d_eta_opposing),
                                       (True, u_from_eta_aiding, d_u_d_eta_aiding)):
            u, slope = reading_with_slope(float(eta), ratio, aiding)
            np.testing.assert_array_equal([u, slope],
                                          [float(u_of(eta, ratio)), float(slope_of(eta, ratio))])
    u, slope = reading_with_slope(-ratio - 0.1, ratio, aiding=True)    # no u reaches it
    assert math.isnan(u) and math.isnan(slope)
    with pytest.raises(ValueError, match='eta must be finite'):
        reading_with_slope(math.inf, ratio, aiding=False)


@pytest.mark.parametrize('u, ratio, message', [
    (0.1, 0, r'^ratio must be > 0 and finite, got 0$'),
    (0.1, -1.0, r'^ratio must be > 0 and finite, got -1\.0$'),
    (0.1, math.nan, r'^ratio must be > 0 and finite, got nan$'),
    (0.1, math.inf, r'^ratio must be > 0 and finite, got inf$'),
    (0.1, '3', r"^ratio must be a real number \(one value; .*got '3'$"),
    (0.1, True, r'^ratio must be a real number'),
    (np.array([0.1, 0.2]), 3.0, r'^u must be a real number \(one value; the numpy functions '
                                r'take arrays\), got array'),
    ('0.1', 3.0, r"^u must be a real number .*got '0\.1'$"),
])
def test_float_paths_refuse_a_bad_argument_by_name(u, ratio, message) -> None:
    """``efficiencies``, ``readings``, ``reading_with_slope``: ModelError, a ValueError."""
    from gear_phm.errors import GearPhmError
    from gear_phm.models import efficiencies, ModelError
    from gear_phm.models.lever import reading_with_slope, readings
    with pytest.raises(ModelError, match=message) as info:
        efficiencies(u, ratio)
    assert isinstance(info.value, ValueError) and isinstance(info.value, GearPhmError)
    with pytest.raises(ModelError, match=message.replace('^u ', '^eta_d ')):
        readings(u, 0.5, ratio)
    with pytest.raises(ModelError, match=message.replace('^u ', '^eta ')):
        reading_with_slope(u, ratio, aiding=False)


def test_float_paths_keep_their_values_for_numbers_of_any_real_type() -> None:
    from gear_phm.models import efficiencies
    assert efficiencies(0.1, 3) == efficiencies(0.1, 3.0) == (
        float(eta_opposing(0.1, 3.0)), float(eta_aiding(0.1, 3.0)))
    assert efficiencies(np.float64(0.1), np.int64(3)) == efficiencies(0.1, 3.0)
    assert all(math.isnan(eta) for eta in efficiencies(math.nan, 3.0))


def test_numpy_functions_raise_model_error() -> None:
    from gear_phm.models import ModelError
    with pytest.raises(ModelError, match=r'^ratio must be > 0, got 0\.0$'):
        eta_opposing(0.1, 0.0)
