"""The RUL's fast paths give what the plain computations give (issue 23: analysis speed).

The hinge candidates in one pass against one weighted least-squares design at a time; a
forecast origin's law against :func:`fit_laws` of that law alone; the forecast errors with
their cache against without; the band from the laws' draws made once against made anew.
"""
from __future__ import annotations

import numpy as np
import pytest

from gear_phm.prognostics import calibration, changepoint
from gear_phm.prognostics.calibration import (crossing_draws, Draws, forecast_errors,
                                              ForecastCache, law_draws)
from gear_phm.prognostics.fits import fit_laws, forecast_law
from gear_phm.prognostics.laws import MODELS


def _history(seed: int, n: int = 120) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return a plateau then accelerating wear, noisy: t [s], u [-], precision [1/-^2]."""
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0.0, 3000.0, n))
    u = 0.05 + 2e-9 * np.maximum(t - 1000.0, 0.0) ** 2.5 + 1e-3 * rng.standard_normal(n)
    return t, u, rng.uniform(0.5e6, 2e6, n)


@pytest.mark.parametrize('seed', [1, 2, 3])
def test_hinge_candidates_in_one_pass_equal_one_design_at_a_time(seed: int) -> None:
    t, u, w = _history(seed)
    index = np.arange(0, 100, 7)
    rss = changepoint._hinge_rss(t, u, w, index)
    for i, k in enumerate(index):
        d = t - t[k]
        ones, pre, post = np.ones_like(d), np.minimum(d, 0.0), np.maximum(d, 0.0)
        for j, p in enumerate(changepoint.HINGE_EXPONENTS):
            plain, beta = changepoint._wls_rss(
                np.stack([ones, pre, post ** p], axis=-1)[None], u, w)
            expected = plain[0] if beta[0, 2] > 0.0 else np.inf
            assert rss[i, j] == pytest.approx(expected, rel=1e-10)
    assert np.isfinite(rss).sum() >= 10      # the wear part is found rising at most taus


@pytest.mark.parametrize('model', MODELS)
def test_forecast_law_is_fit_laws_of_that_law_alone(model: str) -> None:
    t, u, w = _history(4)
    law = forecast_law(t[:80], u[:80], w[:80], model)
    full = fit_laws(t[:80], u[:80], w[:80], model)
    assert law is not None and len(full) == 1
    for name in ('model', 't_end', 'u_end', 'slope', 'shape', 'span'):
        assert getattr(law, name) == getattr(full[0], name)
    assert forecast_law(t[:5], u[:5], w[:5], model) is None and not fit_laws(
        t[:5], u[:5], w[:5], model)


def test_forecast_errors_cache_reuses_unchanged_origins(monkeypatch: pytest.MonkeyPatch
                                                        ) -> None:
    t, u, w = _history(5)
    law = fit_laws(t, u, w, 'linear')[0]
    plain = forecast_errors(t, u, w, law, horizon=500.0)
    cache: ForecastCache = {}
    assert np.array_equal(forecast_errors(t, u, w, law, horizon=500.0, cache=cache), plain)
    assert len(cache) == 5 and plain.size == 11         # 5 origins, each rho and its mirror
    calls = []

    def counted(*args: object, **kwargs: object) -> object:
        calls.append(args)
        return forecast_law(*args, **kwargs)         # type: ignore[arg-type]
    monkeypatch.setattr(calibration, 'forecast_law', counted)
    assert np.array_equal(forecast_errors(t, u, w, law, horizon=500.0, cache=cache), plain)
    assert calls == []                                 # nothing refitted
    u2 = u.copy()
    u2[-1] += 1e-4                                     # only the newest point changed
    forecast_errors(t, u2, w, law, horizon=500.0, cache=cache)
    assert calls == []                                 # the origins' points did not change


def test_band_from_draws_made_once_equals_made_anew() -> None:
    t, u, w = _history(6)
    laws = fit_laws(t, u, w)
    draws = Draws.seeded(0, 2000)
    errors = np.array([0.0, 0.3, -0.2, 0.1, -0.1])
    shares = law_draws(laws, draws, 0.6)
    for rho in (None, errors):
        expected = crossing_draws(laws, draws, 0.6, 1e-3, 25.0, rho)
        assert np.array_equal(crossing_draws(shares, draws, 0.6, 1e-3, 25.0, rho), expected)
    assert np.isfinite(expected).mean() > 0.5
