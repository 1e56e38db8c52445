"""Saxena's prognostic metrics (gear_phm.prognostics.metrics)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from gear_phm.prognostics.metrics import (alpha_lambda, cumulative_relative_accuracy, evaluate,
                                          prognostic_horizon, true_end_of_life_index)


def test_metrics_on_perfect_and_biased_predictions() -> None:
    t = np.arange(0.0, 100.0, 1.0)
    perfect = 100.0 - t
    result = evaluate(t, perfect, 100.0)
    assert all(check['passed'] for check in result['alpha_lambda'])
    assert result['prognostic_horizon_s'] == 100.0
    assert result['cumulative_relative_accuracy'] == pytest.approx(1.0)
    biased = 1.3 * perfect                                 # 30 % too long everywhere
    check = alpha_lambda(t, biased, 100.0, 0.5)
    assert not check.passed and check.relative_accuracy == pytest.approx(0.7)
    assert check.t_lambda == 50.0 and check.true_rul == 50.0 and check.predicted_rul == 65.0
    # PH bound +/- 0.2 * 100 = 20 s: 0.3 (100 - t) <= 20 from t >= 33.33 -> t_i = 34
    assert prognostic_horizon(t, biased, 100.0) == 66.0
    assert cumulative_relative_accuracy(t, biased, 100.0) == pytest.approx(0.7)


def test_true_end_of_life_is_the_first_sample_at_or_above_u_eol() -> None:
    true_u = np.array([0.1, 0.2, 0.25, 0.3, 0.2])
    assert true_end_of_life_index(true_u, 0.25) == 2             # >=: reaching it counts
    assert true_end_of_life_index(true_u, 0.21) == 2
    assert true_end_of_life_index(true_u, 0.31) is None          # never reached
    assert true_end_of_life_index(true_u, math.inf) is None
    assert true_end_of_life_index(np.array([]), 0.25) is None


def test_metrics_inputs_validated_and_infinite_predictions() -> None:
    t = np.array([0.0, 10.0, 20.0])
    assert not alpha_lambda(t, [np.inf] * 3, 40.0, 0.5).passed
    assert evaluate(t, [np.inf] * 3, 40.0)['prognostic_horizon_s'] == 0.0
    with pytest.raises(ValueError, match='same length'):
        evaluate(t, [1.0], 40.0)
    with pytest.raises(ValueError, match='t_start'):
        evaluate(t, [1.0, 1.0, 1.0], 40.0, t_start=50.0)
    assert json.dumps(evaluate(t, [np.inf] * 3, 40.0))         # JSON-ready
