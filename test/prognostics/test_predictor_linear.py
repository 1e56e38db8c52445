"""RulPredictor (gear_phm.prognostics.predictor) on linear and flat histories."""
from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from gear_phm.prognostics.predictor import RulPredictor


def _line(predictor: RulPredictor, rate: float, until: float, sigma: float = 1e-3) -> None:
    rng = np.random.default_rng(0)
    for t in np.arange(0.0, until, 2.0):
        predictor.add(float(t), 0.1 + rate * t + sigma * rng.standard_normal(), sigma ** 2)


def test_linear_rul_from_the_history() -> None:
    predictor = RulPredictor(0.6, trend='linear')
    _line(predictor, 1e-4, 2000.0)
    rul = predictor.predict(1998.0, 0.2998)
    assert rul.model == 'linear'
    assert rul.median == pytest.approx(3002.0, rel=0.01)
    assert rul.p5 < 3002.0 < rul.p95
    assert rul.p95 / rul.p5 < 1.1


def test_rul_inf_without_significant_degradation_and_zero_at_end_of_life() -> None:
    predictor = RulPredictor(0.6, detect_z=2.0)
    _line(predictor, 0.0, 600.0)
    no_wear = predictor.predict(598.0, 0.1)
    assert (no_wear.median, no_wear.p5, no_wear.p95, no_wear.model) == (math.inf, math.inf,
                                                                        math.inf, 'none')
    worn = predictor.predict(598.0, 0.61)
    assert (worn.median, worn.p5, worn.p95) == (0.0, 0.0, 0.0)
    assert RulPredictor(0.6).predict(0.0, 0.1).median == math.inf     # no history yet


@settings(max_examples=25, deadline=None, derandomize=True)
@given(rate=st.floats(1e-5, 1e-3), sigma=st.floats(1e-4, 1e-2))
def test_rul_quantiles_ordered_and_deterministic(rate: float, sigma: float) -> None:
    predictor = RulPredictor(0.6, mc_samples=500, seed=3)
    _line(predictor, rate, 400.0, sigma)
    first = predictor.predict(398.0, 0.1 + rate * 398.0)
    assert first.p5 <= first.median <= first.p95
    assert first == predictor.predict(398.0, 0.1 + rate * 398.0)
