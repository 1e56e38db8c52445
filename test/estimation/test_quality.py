"""DataQuality: the evidence of a reversed torque sign, wrong units and a wrong ratio."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gear_phm.estimation.quality import (DataQuality, OVER_UNITY_MIN, RATIO_CHECK_MIN,
                                         REVERSED_MIN)


def _samples(quality: DataQuality, n: int, ratio: float, impossible: int,
             load_larger: bool = True) -> None:
    """Add ``n`` moving samples of speed ratio ``ratio``, ``impossible`` of them so."""
    rng = np.random.default_rng(3)
    w_l = rng.uniform(0.1, 1.0, n)
    w_m = ratio * w_l
    p_m = np.full(n, 1.0)
    p_l = np.full(n, 2.0 if load_larger else 0.5)
    bad = np.zeros(n, dtype=bool)
    bad[:impossible] = True
    everything = np.ones(n, dtype=bool)
    quality.add_samples(w_m, w_l, p_m, p_l, everything, everything, bad)


def test_the_speeds_give_the_ratio_and_a_wrong_parameter_is_reported() -> None:
    quality = DataQuality()
    assert math.isnan(quality.speed_ratio()) and quality.ratio_check(3.0) == ''
    _samples(quality, RATIO_CHECK_MIN, 3.0, 0)
    assert quality.speed_ratio() == pytest.approx(3.0, rel=1e-12)
    assert quality.ratio_check(3.05) == ''                  # within the 2 % tolerance
    assert quality.ratio_check(5.0).startswith('the speeds give ratio 3 ')


def test_a_quantised_load_speed_gives_the_ratio_and_is_not_refused() -> None:
    """A load speed differenced from a coarse encoder at 1 kHz: noise of its own spread."""
    rng = np.random.default_rng(7)
    n = 20_000
    t = np.arange(n) * 1e-3
    w_l = 0.3 * np.sin(2.0 * np.pi * 0.2 * t)                  # strokes both ways [rad/s]
    count = 2.0 * np.pi / 2 ** 16                              # one count [rad]
    angle = np.floor((np.cumsum(w_l) * 1e-3 + rng.uniform(0, count)) / count) * count
    w_l_read = np.diff(angle, prepend=angle[0]) / 1e-3         # encoder differencing
    w_m = 30.0 * w_l + rng.normal(0.0, 0.05, n)
    moving = np.abs(w_m) > 0.5
    ones = np.ones(n, dtype=bool)
    quality = DataQuality()
    quality.add_samples(w_m, w_l_read, np.ones(n), np.ones(n), moving, ones, ~ones)
    assert quality.speed_ratio() == pytest.approx(30.0, rel=2e-3)
    assert quality.ratio_check(30.0) == ''
    # the least squares of w_m on the read w_l, as the check was, reads low: refused
    w_l_moving = w_l_read[moving]
    least_squares = np.sum(w_m[moving] * w_l_moving) / np.sum(w_l_moving ** 2)
    assert least_squares < 30.0 * (1.0 - 0.02)


def test_too_few_moving_samples_report_no_ratio() -> None:
    quality = DataQuality()
    _samples(quality, RATIO_CHECK_MIN - 1, 3.0, 0)
    assert quality.ratio_check(5.0) == ''


@pytest.mark.parametrize(('load_larger', 'name'), [(True, 'load_effort_sign'),
                                                   (False, 'motor_effort_sign')])
def test_the_shaft_with_the_larger_power_names_the_reversed_sign(load_larger: bool,
                                                                 name: str) -> None:
    quality = DataQuality()
    _samples(quality, 4 * REVERSED_MIN, 3.0, REVERSED_MIN, load_larger)
    assert quality.reversed_torque_fix(1, -1) == (name, -1 if name == 'motor_effort_sign'
                                                  else 1)
    assert f'set {name}' in quality.reversed_torque(1, -1)
    assert quality.reversed_torque(1, 1).startswith('25 % of the samples')


def test_few_impossible_samples_report_nothing() -> None:
    quality = DataQuality()
    _samples(quality, 4 * REVERSED_MIN + 4, 3.0, REVERSED_MIN)      # under 25 %
    assert quality.reversed_torque_fix(1, 1) is None and quality.reversed_torque(1, 1) == ''


def test_windows_far_over_unity_are_reported_with_the_largest() -> None:
    quality = DataQuality()
    for eta in (0.9,) * 10:
        quality.add_window(eta, 1e-4)
    for _ in range(OVER_UNITY_MIN - 1):
        quality.add_window(1.2, 1e-4)                       # 20 sigma over
    quality.add_window(1.04, 1e-4)                          # 4 sigma: noise
    assert quality.over_unity() == ''
    quality.add_window(900.0, 1.0)
    assert (quality.windows_measured, quality.windows_over_unity) == (16, OVER_UNITY_MIN)
    assert quality.largest_efficiency == 900.0
    assert quality.over_unity().startswith('31.2 % of the windows')
