"""Growth detection: whether the wear history shows significant growth of u.

The RUL is finite only when the growth of u is significant twice over
(:class:`~gear_phm.prognostics.predictor.RulPredictor`):

1. the best law's slope at the newest time, r > detect_z sigma_r;
2. the rise of u over the history against its own uncertainty (:func:`rise_sigma`;
   posteriors: rise > detect_z sqrt(sigma_start^2 + sigma_end^2), sigma_end from the newest
   bin's P_uu, sigma_start from the first quarter of the history); the rise is the smaller of
   the fitted law's u_end - u(t_start) and the data's last-quarter minus first-quarter mean
   (:func:`rise`: a law fitted to a few points can extrapolate a steep start that the data do
   not show).

Test 2 is needed early in a history: a few seconds of a filter settling from its prior or
wandering within its sigma are a "significant" slope to a fit of a handful of correlated
points. The rise of each law over the span T: r T (linear), r (1 - exp(-k T)) / k
(exponential and proportional), r T / p (power).
"""
from __future__ import annotations

import math

import numpy as np

from gear_phm.prognostics.fits import Trend
from gear_phm.prognostics.laws import EXPONENTIAL_FORM, POWER

#: Effective points (n_eff) of a history of measurements below which growth is first
#: detected only at detect_z DETECT_MIN_POINTS / n_eff sigma (posteriors: no such rule; their
#: n_eff is small by their correlation). With fewer, a 2-sigma slope is a noise excursion
#: often enough to be found, lost and found again within seconds (a 3000 s linear matrix
#: run, seed 1, 2026-11-25: detected at 14 points, released at 19, detected again at 29), and
#: the RUL-based WARN with it. A hard minimum of 24 points (until 2026-11-26) kept the RUL of
#: a 300 s life inf for its first 0.1, while its rise was at 6 sigma from 0.04.
DETECT_MIN_POINTS = 24.0


def _quarters(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return masks of the first and the last quarter of the span of times ``t`` [s]."""
    quarter = 0.25 * (t[-1] - t[0])
    return t <= t[0] + quarter, t >= t[-1] - quarter


def rise_sigma(t: np.ndarray, precision: np.ndarray, independent: bool = False,
               scale: float = 1.0) -> float:
    """Return the uncertainty [-] of a rise of u over the history.

    Posteriors: sqrt(sigma_start^2 + sigma_end^2), sigma_end from the newest bin's mean
    precision, sigma_start from the mean precision of the bins in the first quarter of the
    span (which includes the filter's start-up from its prior). ``independent``
    measurements: the uncertainty of the last quarter's mean minus the first quarter's (the
    data rise of :func:`rise`), each from its summed precision, times sqrt(``scale``) (the
    fit's reduced chi-square times n / n_eff).
    """
    first, last = _quarters(t)
    if independent:
        start, end = float(precision[first].sum()), float(precision[last].sum())
        if not (start > 0.0 and end > 0.0):
            return math.inf
        return math.sqrt(max(scale, 1.0) * (1.0 / start + 1.0 / end))
    start, end = float(precision[first].mean()), float(precision[-1])
    if not (start > 0.0 and end > 0.0):
        return math.inf
    return math.sqrt(1.0 / start + 1.0 / end)


def rise(law: Trend, t: np.ndarray, u: np.ndarray, precision: np.ndarray) -> float:
    """Return the rise [-] of u over the history.

    The smaller of the law's (extrapolated to the start, :func:`fitted_rise`) and the data's
    (precision-weighted mean u of the last quarter of the span minus that of the first).
    """
    first, last = _quarters(t)
    data = float(np.average(u[last], weights=precision[last])
                 - np.average(u[first], weights=precision[first]))
    return min(fitted_rise(law), data)


def fitted_rise(law: Trend) -> float:
    """Return the rise [-] of u over the fitted span, u_end - u(t_start) (module docstring)."""
    span = law.span
    if law.model in EXPONENTIAL_FORM and law.shape > 0.0:
        return law.slope * -math.expm1(-law.shape * span) / law.shape
    if law.model == POWER and law.shape > 0.0:
        return law.slope * span / law.shape
    return law.slope * span
