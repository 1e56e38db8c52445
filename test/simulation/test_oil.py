"""The oil temperature state (gear_phm.simulation.oil): warming, cooling, viscosity factor."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gear_phm.simulation.idle_gap import IdleGap
from gear_phm.simulation.oil import Oil

OIL = Oil(ambient_temperature=20.0, running_temperature=60.0, warm_time_constant=100.0,
          cool_time_constant=300.0, cold_factor=3.0)


def test_the_oil_warms_from_ambient_with_its_time_constant() -> None:
    t = np.array([0.0, 100.0, 200.0, 1000.0])
    expected = 60.0 - 40.0 * np.exp(-t / 100.0)
    np.testing.assert_allclose(OIL.temperature(t), expected, rtol=0, atol=1e-12)
    assert OIL.temperature(np.array([0.0]))[0] == 20.0       # a cold start
    assert OIL.temperature(np.array([100.0]))[0] == pytest.approx(60.0 - 40.0 / math.e)


def test_the_oil_cools_in_an_idle_gap_and_warms_again_after_it() -> None:
    gap = IdleGap(at=200.0, duration=600.0)
    start = 60.0 - 40.0 * math.exp(-2.0)                      # at the gap's start
    end = 20.0 + (start - 20.0) * math.exp(-600.0 / 300.0)    # at its end
    t = np.array([199.0, 200.0, 500.0, 800.0, 900.0])
    temperature = OIL.temperature(t, gap)
    assert temperature[0] == pytest.approx(60.0 - 40.0 * math.exp(-1.99), abs=1e-12)
    assert temperature[1] == pytest.approx(start, abs=1e-12)
    assert temperature[2] == pytest.approx(20.0 + (start - 20.0) / math.e, abs=1e-12)
    assert temperature[3] == pytest.approx(end, abs=1e-12)
    assert temperature[4] == pytest.approx(60.0 + (end - 60.0) / math.e, abs=1e-12)
    assert temperature[3] < temperature[1] - 10.0             # cooler after the gap


def test_the_closed_form_is_the_same_in_any_order_and_chunks() -> None:
    gap = IdleGap(at=50.0, duration=80.0)
    t = np.random.default_rng(3).uniform(0.0, 400.0, 500)
    whole = OIL.temperature(t, gap)
    parts = np.concatenate([OIL.temperature(t[:123], gap), OIL.temperature(t[123:], gap)])
    np.testing.assert_array_equal(whole, parts)
    order = np.argsort(t)
    np.testing.assert_array_equal(OIL.temperature(t[order], gap), whole[order])


def test_initial_warmth_and_start() -> None:
    warm = Oil(initial_warmth=1.0)
    np.testing.assert_allclose(warm.temperature(np.array([0.0, 1e4])), 60.0, atol=1e-12)
    late = Oil(warm_time_constant=100.0, start=1000.0)        # a fleet's later recording
    assert late.temperature(np.array([1000.0]))[0] == 20.0
    assert late.temperature(np.array([1100.0]))[0] == pytest.approx(60.0 - 40.0 / math.e)


def test_the_drag_factor_follows_a_viscosity_like_law() -> None:
    factor = OIL.drag_factor(np.array([20.0, 40.0, 60.0, 70.0]))
    np.testing.assert_allclose(factor, [3.0, math.sqrt(3.0), 1.0, 3.0 ** -0.25], rtol=1e-12)
    np.testing.assert_array_equal(Oil().drag_factor(np.array([20.0, 60.0])), [1.0, 1.0])


@pytest.mark.parametrize('kwargs, message', [
    ({'running_temperature': 20.0}, 'oil_running_temperature must be above'),
    ({'warm_time_constant': 0.0}, 'oil_warm_time_constant must be > 0'),
    ({'cold_factor': 0.5}, 'no_load_cold_factor must be >= 1'),
    ({'initial_warmth': 3.0}, r'oil_initial_warmth must be in \[0, 2\]'),
])
def test_bad_oil_parameters_are_refused(kwargs: dict[str, float], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        Oil(**kwargs)
