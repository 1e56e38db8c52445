"""OnePerStamp: at most one estimate per stamp, the dropped measurements carried on."""
from __future__ import annotations

import math

import pytest

from gear_phm.estimation.grouping import OnePerStamp
from gear_phm.estimation.records import FrictionEstimate


def _estimate(stamp: int, z: float = math.nan, variance: float = math.nan,
              operating: float = 10.0, h: float = math.nan,
              bias: float = math.nan) -> FrictionEstimate:
    return FrictionEstimate(stamp, 0.1, 0.01, (1e-4, 0.0, 1e-6), operating_time=operating,
                            measurement=z, measurement_variance=variance,
                            measurement_direction=h, measurement_bias=bias)


def test_the_first_of_each_stamp_is_kept_whatever_the_split() -> None:
    outputs = [_estimate(1), _estimate(1), _estimate(2), _estimate(3), _estimate(3)]
    whole = OnePerStamp()
    kept, keep = whole.keep(outputs)
    assert [o.stamp_ns for o in kept] == [1, 2, 3] and keep == [True, False, True, True, False]
    split = OnePerStamp()
    parts = split.keep(outputs[:1])[0] + split.keep(outputs[1:])[0]
    assert [o.stamp_ns for o in parts] == [1, 2, 3]
    assert whole.last_stamp == split.last_stamp == 3


def test_a_dropped_measurement_is_carried_with_the_rate_and_merged() -> None:
    grouping = OnePerStamp(last_stamp=1)
    kept, _ = grouping.keep([_estimate(1, 0.2, 1e-4, 8.0, -0.5, 0.001)])
    assert kept == [] and grouping.carry == (0.2, 1e-4, 8.0, -0.5, 0.001)
    kept, _ = grouping.keep([_estimate(2, 0.3, 3e-4, 10.0, 0.5, -0.001)])
    moved = 0.2 + 0.01 * (10.0 - 8.0)                     # with the rate to its time
    out = kept[0]
    assert out.measurement == pytest.approx((moved / 1e-4 + 0.3 / 3e-4) / (1e4 + 1e4 / 3),
                                            rel=1e-12)
    assert out.measurement_variance == pytest.approx(0.75e-4, rel=1e-12)
    assert out.measurement_direction == pytest.approx(-0.25, rel=1e-12)
    assert grouping.carry is None


def test_a_carry_reaches_an_estimate_without_a_measurement_of_its_own() -> None:
    grouping = OnePerStamp(last_stamp=1, carry=(0.2, 1e-4, 8.0, -0.5, 0.001))
    out = grouping.keep([_estimate(2)])[0][0]
    assert (out.measurement, out.measurement_variance, out.measurement_direction,
            out.measurement_bias) == (pytest.approx(0.22), 1e-4, -0.5, 0.001)
