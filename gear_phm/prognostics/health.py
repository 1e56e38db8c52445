"""Health-level rules, filter-divergence and staleness checks (pure, time passed in).

Levels (diagnostic_msgs/DiagnosticStatus): OK 0, WARN 1, ERROR 2, STALE 3.

- ERROR: u >= u_eol (end of life; includes self-locking u >= 1 when enabled), or the filter
  diverged (:class:`DivergenceDetector`).
- WARN: RUL 5 % bound < ``warn_horizon`` [s], or eta_D < ``eta_warn``.
- STALE: no estimator input for ``stale_timeout`` [s], judged on the caller's clock (the
  diagnostics node's); it overrides the other levels because the estimate is no longer
  current.
- OK otherwise.
"""
from __future__ import annotations

from collections import deque
import math
from statistics import NormalDist

from gear_phm.status import ERROR, OK, WARN


def chi_square_mean_bound(window: int, probability: float) -> float:
    """Upper ``probability`` quantile of the mean of ``window`` chi-square(1) values.

    Wilson-Hilferty: chi2_q(n) ~ n (1 - 2/(9n) + z_q sqrt(2/(9n)))^3; divided by n. Within
    2 % of the exact quantile for n >= 3 at q = 0.999 (n = 1: 10.2 vs exact 10.83).
    """
    if window < 1:
        raise ValueError(f'window must be >= 1, got {window!r}')
    if not 0.0 < probability < 1.0:
        raise ValueError(f'probability must be in (0, 1), got {probability!r}')
    z = NormalDist().inv_cdf(probability)
    a = 2.0 / (9.0 * window)
    return (1.0 - a + z * math.sqrt(a)) ** 3


class DivergenceDetector:
    """Flags a diverging filter.

    Diverged when (a) the mean of the last ``window`` NIS values exceeds the chi-square bound
    :func:`chi_square_mean_bound` (innovations persistently larger than the filter predicts),
    or (b) sigma_u exceeds ``max_u_sigma`` or is not finite (variance growing without bound).
    NIS values are only counted when the innovation changes, because the estimator republishes
    the last innovation between filter updates.
    """

    def __init__(self, window: int = 20, probability: float = 0.999,
                 max_u_sigma: float = 1.0) -> None:
        self.window = int(window)
        self.bound = chi_square_mean_bound(self.window, probability)
        self.max_u_sigma = float(max_u_sigma)
        self._nis: deque[float] = deque(maxlen=self.window)
        self._last_innovation: tuple[float, float] | None = None

    def reset(self) -> None:
        """Forget the NIS history."""
        self._nis.clear()
        self._last_innovation = None

    @property
    def nis_mean(self) -> float:
        """Mean of the NIS window (NaN if empty)."""
        return sum(self._nis) / len(self._nis) if self._nis else math.nan

    def update(self, innovation: float, innovation_variance: float, nis: float,
               u_sigma: float) -> str:
        """Add one estimate; return '' or the reason the filter is considered diverged."""
        key = (innovation, innovation_variance)
        if math.isfinite(nis) and key != self._last_innovation:
            self._nis.append(float(nis))
            self._last_innovation = key
        if not math.isfinite(u_sigma) or u_sigma > self.max_u_sigma:
            return f'filter diverged: sigma_u {u_sigma:.3g} > {self.max_u_sigma:.3g}'
        if len(self._nis) == self.window and self.nis_mean > self.bound:
            return (f'filter diverged: mean NIS {self.nis_mean:.3g} over {self.window} '
                    f'updates > {self.bound:.3g}')
        return ''


def health_level(u: float, u_eol: float, eol_reason: str, eta_opposing: float, eta_warn: float,
                 rul_p5: float, warn_horizon: float, divergence: str) -> tuple[int, str]:
    """(level, message) for one estimate by the rules of the module docstring."""
    if divergence:
        return ERROR, divergence
    if not math.isfinite(u):
        return ERROR, 'friction estimate is not finite'
    if u >= u_eol:
        what = 'self-locking' if eol_reason == 'self_locking' else f'end of life ({eol_reason})'
        return ERROR, f'{what}: u {u:.4g} >= u_eol {u_eol:.4g}'
    reasons = []
    if rul_p5 < warn_horizon:
        reasons.append(f'RUL p5 {rul_p5:.4g} s < {warn_horizon:.4g} s')
    if eta_opposing < eta_warn:
        reasons.append(f'eta_D {eta_opposing:.4g} < {eta_warn:.4g}')
    if reasons:
        return WARN, '; '.join(reasons)
    return OK, 'ok'


__all__ = ['DivergenceDetector', 'chi_square_mean_bound', 'health_level']
