"""The friction filter (gear_phm.estimation.kalman): gating, prediction, process noise."""
from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from gear_phm.estimation.kalman import FrictionFilter


def test_filter_gates_outlier_and_reinitialises_after_repeated_rejections() -> None:
    kf = FrictionFilter(0.1, 0.01, 1e-4, 0.0, gate_threshold=10.83, max_consecutive_gated=3)
    assert kf.update(0.1, 1e-6, 1.0).accepted
    outlier = kf.update(0.2, 1e-6, 2.0)
    assert not outlier.accepted and outlier.nis > 10.83
    assert not kf.update(0.2, 1e-6, 3.0).accepted
    third = kf.update(0.2, 1e-6, 4.0)
    assert third.accepted and third.reinitialised and kf.x[0] == pytest.approx(0.2)


def test_filter_predict_covariance_grows_with_process_noise() -> None:
    kf = FrictionFilter(0.1, 0.01, 1e-3, 1e-6, 10.83, 3)
    kf.predict(0.0)
    x, p = kf.predicted(10.0)
    assert p[0, 0] > kf.P[0, 0] and kf.t == 0.0          # predicted() does not mutate
    kf.predict(10.0)
    assert np.allclose(kf.P, p) and np.allclose(kf.x, x)


def test_predicted_many_is_bit_identical_to_predicted_one_by_one() -> None:
    rng = np.random.default_rng(7)
    for q in (0.0, 1e-12, 3e-7):
        kf = FrictionFilter(0.1, 0.01, 1e-3, q, 10.83, 3)
        times = np.concatenate(([-3.0, 20.0], rng.uniform(-5.0, 500.0, size=38)))
        x, p = kf.predicted_many(times)             # before any update: the prior
        assert np.array_equal(x, np.tile(kf.x, (40, 1)))
        kf.update(0.12, 1e-5, 20.0)
        kf.kf.x[1, 0] = 1e-5                        # a rate, so that dt matters
        x, p = kf.predicted_many(times)
        assert x.shape == (40, 2) and p.shape == (40, 2, 2)
        for k, t in enumerate(times):               # also at or before the filter's time
            x_k, p_k = kf.predicted(float(t))
            assert np.array_equal(x[k], x_k) and np.array_equal(p[k], p_k)
        assert x[times > 20.0, 0].min() > kf.x[0] and np.array_equal(x[1], kf.x)


@settings(max_examples=200, deadline=None)
@given(st.floats(1e-6, 1e3), st.floats(1e-15, 1e2))
def test_process_covariance_is_filterpys_continuous_white_noise(dt: float, q: float) -> None:
    from filterpy.common import Q_continuous_white_noise

    from gear_phm.estimation.kalman import process_covariance
    np.testing.assert_allclose(process_covariance(dt, q),
                               Q_continuous_white_noise(dim=2, dt=dt, spectral_density=q),
                               rtol=1e-12, atol=0.0)
    assert not process_covariance(0.0, q).any() and not process_covariance(dt, 0.0).any()
