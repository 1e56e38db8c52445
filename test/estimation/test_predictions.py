"""predicted_estimates: a batch's published estimates from one stacked prediction."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gear_phm.estimation.kalman import process_covariance, transition
from gear_phm.estimation.predictions import BatchCounts, predicted_estimates, PredictionBase
from gear_phm.models.lever import efficiencies


def _base(u: float, t: float) -> PredictionBase:
    p = np.array([[1e-4, 1e-6], [1e-6, 1e-7]])
    return PredictionBase(np.array([u, 1e-3]), p, t, 1e-9, (-0.001, 0.001),
                          (0.9, 0.01, 1e-4, 1.0), (1e-5, 2e-5), (math.nan,) * 3)


def test_each_run_is_its_base_predicted_to_each_sample() -> None:
    n = 6
    batch = BatchCounts(np.arange(n, dtype=np.int64) * 10_000_000, np.array([1, 1, 2, 2, 1, 1]),
                        np.arange(1, n + 1), np.zeros(n, dtype=np.int64),
                        np.linspace(10.0, 15.0, n))
    runs = [(np.array([0, 1]), _base(0.1, 9.0)), (np.array([3, 5]), _base(0.2, 12.0))]
    first, second = predicted_estimates(runs, batch, 3.0)
    assert [e.stamp_ns for e in first + second] == [0, 10_000_000, 30_000_000, 50_000_000]
    assert [e.samples_used for e in second] == [4, 6] and second[0].power_flow == 2
    f = transition(3.0)                                     # from t 12 s to 15 s
    x = f @ np.array([0.2, 1e-3])
    p = f @ _base(0.2, 12.0).p @ f.T + process_covariance(3.0, 1e-9)
    last = second[1]
    assert (last.u, last.rate) == pytest.approx((x[0], x[1]), rel=1e-12)
    assert last.covariance == pytest.approx((p[0, 0], p[0, 1], p[1, 1]), rel=1e-12)
    assert last.eta_opposing == efficiencies(last.u - 0.001, 3.0)[0]
    assert last.eta_aiding == efficiencies(last.u + 0.001, 3.0)[1]
    assert last.direction_offset == pytest.approx(0.002)
    assert math.isnan(last.measurement) and last.operating_time == 15.0
    assert (last.measured_efficiency, last.mismatch_variance) == (0.9, (1e-5, 2e-5))
