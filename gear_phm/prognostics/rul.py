"""Remaining useful life from the friction filter's posterior on x = [u, du/dt].

Trend models (time to go tau [s] from the current posterior u, r = du/dt to u_eol):

- linear:       u(t + tau) = u + r tau                    ->  tau = (u_eol - u) / r
- exponential:  du/dt grows like r exp(k tau), i.e. u(t + tau) = u + (r / k)(exp(k tau) - 1)
                                                          ->  tau = ln(1 + k (u_eol - u) / r) / k

The exponential form is ``u = c + a exp(k t)`` for any offset c, so k = u'' / u' does not need
to know the offset (the spur plant's u has one from the bearings).

Choice (``trend='auto'``): :class:`TrendDetector` keeps a history of (t, u, P_uu) posteriors
over the last ``trend_window`` seconds and fits, by least squares weighted with 1/P_uu
(s = t - t_now), a line u = a + b s and an exponential u = c + a exp(k s) (k on a log grid,
c and a in closed form). The trend is exponential when both

1. the exponential lowers the weighted residual sum of squares by more than accel_z^2
   residual variances, and
2. the rate grows materially over the span: exp(k span) - 1 > min_growth,

and linear otherwise. k's standard error comes from the curvature of the RSS at its minimum.

Rate of the exponential branch: the fitted slope a k at s = 0, not the filter's r. The filter
models a constant rate, so under accelerating wear its r lags (16 % low at half-life on the
seed-12 bag of docs/prognostics.md, while u_hat lags by ~2.5 s only), and a lagging r makes
the RUL too long. The spread of the rate draws stays the filter's P.

Uncertainty: Monte Carlo. (u, r) is drawn from N(x, P) (r centred on the fitted slope in the
exponential branch) and k from N(k, se_k) (clipped at 0),
tau is computed per draw (inf where the draw never reaches u_eol, 0 where it already has), and
the 5 %, 50 % and 95 % quantiles are taken (inverted-CDF, so inf quantiles stay inf). Monte
Carlo rather than the analytic first-passage formula because the exponential model and draws
with r <= 0 make tau non-Gaussian and possibly infinite. The standard-normal draws are fixed
once from ``seed`` (common random numbers), so the same posterior always gives the same RUL
and successive RULs do not jitter from resampling.

No degradation: when r <= detect_z * sigma_r the rate is not significantly > 0 and every RUL
quantile is inf. Already worn (u >= u_eol): every quantile is 0.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass
import math

import numpy as np

LINEAR, EXPONENTIAL, NONE = 'linear', 'exponential', 'none'


@dataclass(frozen=True)
class Trend:
    """Fitted trend: ``model`` (linear/exponential), k [1/s] and its standard error [1/s]."""

    model: str = LINEAR
    k: float = 0.0
    k_sigma: float = 0.0
    curvature_z: float = 0.0
    growth: float = 0.0
    #: Slope du/dt [1/s] of the fitted exponential at the newest point (0: not fitted).
    slope: float = 0.0


@dataclass(frozen=True)
class RulEstimate:
    """RUL quantiles [s] (inf allowed) and the trend model used ('none' if no degradation)."""

    median: float
    p5: float
    p95: float
    model: str


class TrendDetector:
    """History of (t, u, P_uu) and the linear/exponential decision (module docstring)."""

    def __init__(self, window: float, accel_z: float = 3.0, min_growth: float = 0.25,
                 max_points: int = 200, min_points: int = 10, min_span: float = 0.25
                 ) -> None:
        if not window > 0.0:
            raise ValueError(f'window must be > 0 s, got {window!r}')
        self.window = float(window)
        self.accel_z = float(accel_z)
        self.min_growth = float(min_growth)
        self.min_points = int(min_points)
        self.min_span = float(min_span)
        self._period = self.window / max_points
        self._history: deque[tuple[float, float, float]] = deque()
        self._fitted: Trend | None = None          # fit() of the current history

    def reset(self) -> None:
        """Forget the history (e.g. after the filter re-initialised)."""
        self._history.clear()
        self._fitted = None

    def __len__(self) -> int:
        return len(self._history)

    def add(self, t: float, u: float, u_variance: float) -> None:
        """Record a posterior at time t [s]; at most one point per window/max_points."""
        if not (math.isfinite(t) and math.isfinite(u) and math.isfinite(u_variance)
                and u_variance > 0.0):
            return
        if self._history and t < self._history[-1][0]:
            self.reset()                                   # time went backwards: new run
        if self._history and t - self._history[-1][0] < self._period:
            return
        self._history.append((t, u, u_variance))
        while self._history and self._history[0][0] < t - self.window:
            self._history.popleft()
        self._fitted = None

    def fit(self) -> Trend:
        """Decide the trend from the history; linear when too short or not accelerating.

        The result depends on the history only, so it is cached until the history changes.
        """
        if self._fitted is None:
            self._fitted = self._fit()
        return self._fitted

    def _fit(self) -> Trend:
        if len(self._history) < self.min_points:
            return Trend()
        data = np.asarray(self._history)
        t_now = data[-1, 0]
        span = t_now - data[0, 0]
        if span < self.min_span * self.window:
            return Trend()
        s = data[:, 0] - t_now                              # <= 0 [s]
        weights = 1.0 / data[:, 2]
        weights = weights / weights.mean()
        u = data[:, 1]
        rss_linear = _wls_rss(np.column_stack([np.ones_like(s), s]), u, weights)
        ks = np.geomspace(0.01, 20.0, 120) / span
        rss, amplitude = _exponential_fits(ks, s, u, weights)
        best = int(np.argmin(rss))
        k = float(ks[best])
        dof = len(s) - 3
        sigma2 = rss[best] / dof
        improvement_z = (rss_linear - rss[best]) / sigma2 if sigma2 > 0.0 else math.inf
        growth = math.expm1(k * span)
        # curvature of RSS(k) at the minimum (log-spaced grid: central differences in k)
        lo, hi = max(best - 1, 0), min(best + 1, len(ks) - 1)
        k_sigma = k
        if 0 < best < len(ks) - 1 and sigma2 > 0.0:
            d1, d2 = ks[best] - ks[lo], ks[hi] - ks[best]
            second = 2.0 * (d1 * rss[hi] - (d1 + d2) * rss[best] + d2 * rss[lo]) \
                / (d1 * d2 * (d1 + d2))
            if second > 0.0:
                k_sigma = math.sqrt(2.0 * sigma2 / second)
        accelerating = (0 < best < len(ks) - 1 and improvement_z > self.accel_z ** 2
                        and growth > self.min_growth)
        if accelerating:
            return Trend(EXPONENTIAL, k, float(k_sigma), float(math.sqrt(improvement_z)),
                         float(growth), float(k * amplitude[best]))   # du/ds at s = 0
        return Trend(LINEAR, 0.0, 0.0, float(math.sqrt(max(improvement_z, 0.0))),
                     float(growth))


def _exponential_fits(ks: np.ndarray, s: np.ndarray, u: np.ndarray,
                      weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted RSS and amplitude a of u ~ c + a exp(k s) for every k in ``ks`` (closed-form
    2x2 WLS); RSS inf and a 0 where the fit is degenerate."""
    e = np.exp(np.outer(ks, s))                              # (k, n)
    sw, su, suu = weights.sum(), weights @ u, weights @ (u * u)
    se, see, seu = e @ weights, (e * e) @ weights, e @ (weights * u)
    det = sw * see - se * se
    valid = det > 1e-12 * sw * see
    with np.errstate(divide='ignore', invalid='ignore'):
        explained = (see * su * su - 2.0 * se * su * seu + sw * seu * seu) / det
        amplitude = (sw * seu - se * su) / det
    return np.where(valid, suu - explained, np.inf), np.where(valid, amplitude, 0.0)


def _wls_rss(design: np.ndarray, values: np.ndarray, weights: np.ndarray) -> float:
    """Weighted residual sum of squares of a least-squares fit."""
    root = np.sqrt(weights)
    a = design * root[:, None]
    b = values * root
    coef, *_ = np.linalg.lstsq(a, b, rcond=None)
    residual = b - a @ coef
    return float(residual @ residual)


class RulPredictor:
    """RUL quantiles from a posterior (module docstring); fixed seeded draws."""

    def __init__(self, u_eol: float, detect_z: float = 2.0, samples: int = 2000,
                 seed: int = 0) -> None:
        if not math.isfinite(u_eol):
            raise ValueError(f'u_eol must be finite, got {u_eol!r}')
        if samples < 2:
            raise ValueError(f'samples must be >= 2, got {samples!r}')
        self.u_eol = float(u_eol)
        self.detect_z = float(detect_z)
        normals = np.random.default_rng(seed).standard_normal((int(samples), 3))
        self._n0, self._n1, self._n2 = (np.ascontiguousarray(normals[:, i]) for i in range(3))

    def predict(self, u: float, rate: float, covariance: np.ndarray,
                trend: Trend = Trend()) -> RulEstimate:
        """RUL [s] from posterior mean (u [-], rate [1/s]) and 2x2 covariance."""
        cov = np.asarray(covariance, dtype=float).reshape(2, 2)
        return self.predict_from(u, rate, float(cov[0, 0]), 0.5 * float(cov[0, 1] + cov[1, 0]),
                                 float(cov[1, 1]), trend)

    def predict_from(self, u: float, rate: float, p_uu: float, p_ur: float, p_rr: float,
                     trend: Trend = Trend()) -> RulEstimate:
        """:meth:`predict` with the covariance as its three entries P_uu [-], P_ur [1/s],
        P_rr [1/s^2] (the per-update path: no matrix is built)."""
        if not (math.isfinite(u) and math.isfinite(rate) and math.isfinite(p_uu)
                and math.isfinite(p_ur) and math.isfinite(p_rr)):
            raise ValueError(f'posterior must be finite, got u={u!r}, rate={rate!r}, '
                             f'P=[[{p_uu!r}, {p_ur!r}], [{p_ur!r}, {p_rr!r}]]')
        if u >= self.u_eol:
            return RulEstimate(0.0, 0.0, 0.0, trend.model)
        rate_sigma = math.sqrt(max(p_rr, 0.0))
        if not rate > self.detect_z * rate_sigma or rate <= 0.0:
            return RulEstimate(math.inf, math.inf, math.inf, NONE)
        l_uu, l_ru, l_rr = _psd_cholesky(p_uu, p_ur, p_rr)
        n0, n1 = self._n0, self._n1           # draws: [u, rate] + L @ [n0, n1], L lower
        gap = (self.u_eol - u) - l_uu * n0
        r_i = l_ru * n0
        r_i += l_rr * n1
        r_i += trend.slope if trend.model == EXPONENTIAL and trend.slope > 0.0 else rate
        with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
            tau = gap / r_i
            if trend.model == EXPONENTIAL and trend.k > 0.0:
                k_i = np.maximum(trend.k + trend.k_sigma * self._n2, 0.0)
                growth = np.where(r_i > 0.0, k_i * tau, np.inf)
                tau_exp = np.log1p(growth) / np.where(k_i > 0.0, k_i, 1.0)
                tau = np.where(k_i > 0.0, tau_exp, tau)
        if not r_i.min() > 0.0:
            tau[r_i <= 0.0] = np.inf                  # never reaches u_eol
        if not gap.min() > 0.0:
            tau[gap <= 0.0] = 0.0                     # already past u_eol
        p5, median, p95 = inverted_cdf_quantiles(tau, (0.05, 0.5, 0.95))
        return RulEstimate(median, p5, p95, trend.model)


def inverted_cdf_quantiles(values: np.ndarray, probabilities: tuple[float, ...]
                           ) -> list[float]:
    """``np.quantile(values, probabilities, method='inverted_cdf')`` from one sort (numpy's
    vectorised sort beats ``np.quantile``, and ``np.partition`` with several ranks, for a few
    thousand draws; the tests check they agree). NaN-free input."""
    n = values.size
    ordered = np.sort(values)
    return [float(ordered[max(math.ceil(p * n) - 1, 0)]) for p in probabilities]


def _psd_cholesky(p_uu: float, p_ur: float, p_rr: float) -> tuple[float, float, float]:
    """Lower factor (l_uu, l_ru, l_rr) of a 2x2 covariance, L L^T = P, in closed form;
    tolerates semi-definite P (a zero or negative variance gives a zero column)."""
    if p_uu > 0.0:
        l_uu = math.sqrt(p_uu)
        l_ru = p_ur / l_uu
        return l_uu, l_ru, math.sqrt(max(p_rr - l_ru * l_ru, 0.0))
    return 0.0, 0.0, math.sqrt(max(p_rr, 0.0))
