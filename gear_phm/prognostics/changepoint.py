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

from dataclasses import dataclass
import functools
import math

import numpy as np

from gear_phm.prognostics.fits import _effective_points, Trend
from gear_phm.prognostics.laws import EXPONENTIAL_FORM, POWER

#: Effective points (n_eff) of a history of measurements below which growth is first
#: detected only at detect_z DETECT_MIN_POINTS / n_eff sigma (posteriors: no such rule; their
#: n_eff is small by their correlation). With fewer, a 2-sigma slope is a noise excursion
#: often enough to be found, lost and found again within seconds (a 3000 s linear matrix
#: run, seed 1: detected at 14 points, released at 19, detected again at 29), and
#: the RUL-based WARN with it. A hard minimum of 24 points kept the RUL of
#: a 300 s life inf for its first 0.1, while its rise was at 6 sigma from 0.04. 36, not
#: 24: the estimator's learned parameters (the direction offset, the rotor
#: inertia) settle over the first tens of windows, and the first windows' readings drift with
#: them: healthy random life 86 (100 Hz, a mismatch) read a proportional law at 2.6 sigma
#: from 29 points and stayed WARN, 39 (1 kHz) found growth at 2.2 sigma in a 22-point regime
#: 75 s before its wear onset (docs/prognostics.md).
DETECT_MIN_POINTS = 36.0


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


#: Exponents p of the hinge's wear part a max(t - tau, 0)^p (:func:`regime_start`).
HINGE_EXPONENTS = np.array([1.0, 2.0, 3.0])
#: At most this many candidate regime starts tau, evenly over the history's bins.
HINGE_CANDIDATES = 32
#: The current regime holds at least this fraction of the history's bins (and min_points).
REGIME_MIN_SHARE = 0.125
#: A regime starts later than the history's first bin only where the hinge there fits better
#: than one from the first bin by this many residual scales (a likelihood ratio: 3 sigma;
#: taking the earliest start within 1 of the best, noise on a straight history moved the
#: start back and forth, and the RUL by 40 %).
REGIME_MARGIN = 9.0
#: ... and only where u does not rise before it (:func:`_rising_before`).
PRE_SLOPE_Z = 2.0
PRE_SLOPE_SHARE = 0.1


@dataclass(frozen=True)
class RegimeStart:
    """Start of the current wear regime in a history (:func:`regime_start`).

    ``index``: its first bin; ``t`` [s]: its time (that bin's, on the history's axis);
    ``exponent``: the hinge's p; ``improvement``: how much the wear part improves the fit,
    (rss without it - rss with it) / residual scale [-] (0 when no rising regime was found).
    """

    index: int = 0
    t: float = 0.0
    exponent: float = 1.0
    improvement: float = 0.0


def regime_start(t: np.ndarray, u: np.ndarray, precision: np.ndarray,
                 min_points: int = 8) -> RegimeStart:
    """Return where the current wear regime starts: the last of :func:`_hinge_start`'s.

    One hinge has one change: a running-in, then a plateau, then wear has two. Once a start is
    found, the history from it is searched again, until no later start is significant
    (random life 13: running-in to 280 s, a plateau to 3560 s, then wear; the one hinge put
    the start at the running-in's end, and the plateau held the fitted slope at 0 until 0.6 of
    the wear life).
    """
    found = _hinge_start(t, u, precision, min_points)
    # a later regime also holds REGIME_MIN_SHARE of the whole history's bins
    least = max(int(min_points), int(math.ceil(REGIME_MIN_SHARE * t.size)))
    while found.index > 0:
        later = _hinge_start(t[found.index:], u[found.index:], precision[found.index:],
                             least)
        if later.index == 0:
            break
        found = RegimeStart(found.index + later.index, later.t, later.exponent,
                            later.improvement)
    return found


def _hinge_start(t: np.ndarray, u: np.ndarray, precision: np.ndarray,
                 min_points: int = 8) -> RegimeStart:
    """Return where the last wear regime starts: a segmented (hinge) regression.

    u = c + d min(t - tau, 0) + a max(t - tau, 0)^p, continuous at tau, with the level c, the
    slope d before tau (a plateau, d = 0, or a running-in, d < 0) and the wear part a > 0 in
    closed form (weighted least squares with the bins' ``precision``), for each candidate tau
    (a bin time, :data:`HINGE_CANDIDATES` of them, leaving at least
    max(``min_points``, :data:`REGIME_MIN_SHARE` n) bins after it) and p in
    :data:`HINGE_EXPONENTS`. The regime starts at the best tau if its fit beats the one from
    the first bin by :data:`REGIME_MARGIN` residual scales, else at the first bin (a straight
    history fits equally with any tau: its regime is the whole of it); the best candidate is
    refined to the bin. No candidate with a > 0: the whole history (index 0).
    """
    n = t.size
    last = n - max(int(min_points), int(math.ceil(REGIME_MIN_SHARE * n)))
    if last <= 0:
        return RegimeStart(0, float(t[0]) if n else 0.0)
    index = _candidates(last)
    rss = _hinge_rss(t, u, precision, index)
    best_per_tau = rss.min(axis=1)
    coarse = int(np.argmin(best_per_tau))
    if not math.isfinite(best_per_tau[coarse]):
        return RegimeStart(0, float(t[0]))
    # refined: every bin between the best candidate's neighbours
    low = int(index[max(coarse - 1, 0)])
    high = int(index[min(coarse + 1, index.size - 1)])
    fine = np.arange(low, high + 1)
    index = np.concatenate((index, fine))
    rss = np.concatenate((rss, _hinge_rss(t, u, precision, fine)))
    best_per_tau = rss.min(axis=1)
    chosen = int(np.argmin(best_per_tau))
    best = float(best_per_tau[chosen])
    # the residual scale: reduced chi-square (>= 1) times n / n_eff, the residuals'
    # autocorrelation (correlated residuals make a kink of noise look significant)
    exponent = float(HINGE_EXPONENTS[int(np.argmin(rss[chosen]))])
    d = t - t[index[chosen]]
    design = np.stack([np.ones_like(d), np.minimum(d, 0.0), np.maximum(d, 0.0) ** exponent],
                      axis=-1)[None]
    beta = _wls_rss(design, u, precision)[1]
    residuals = np.sqrt(precision) * (u - design[0] @ beta[0])
    scale = max(best / max(n - 4, 1), 1.0) * n / _effective_points(residuals)
    if best_per_tau[0] <= best + REGIME_MARGIN * scale or _rising_before(
            t, design[0], beta[0], precision, scale, index[chosen]):
        chosen = 0                  # no significant change point: the whole history
        exponent = float(HINGE_EXPONENTS[int(np.argmin(rss[chosen]))])
    # the fit without the wear part at the regime's start (its 'before' part only)
    d = t - t[index[chosen]]
    rss0 = float(_wls_rss(np.stack([np.ones_like(d), np.minimum(d, 0.0)], axis=-1)[None], u,
                          precision)[0][0])
    improvement = max((rss0 - float(best_per_tau[chosen])) / scale, 0.0)
    return RegimeStart(int(index[chosen]), float(t[index[chosen]]), exponent, improvement)


@functools.lru_cache(maxsize=512)
def _candidates(last: int) -> np.ndarray:
    """Return the candidate taus' bins: at most HINGE_CANDIDATES, evenly over 0..``last``.

    Read-only (cached).
    """
    index = np.unique(np.linspace(0, last, min(HINGE_CANDIDATES, last + 1)).round()
                      .astype(int))
    index.flags.writeable = False
    return index


def _rising_before(t: np.ndarray, design: np.ndarray, beta: np.ndarray, w: np.ndarray,
                   scale: float, start: int) -> bool:
    """Whether u rises before the hinge's tau: its slope d there is significant and not small.

    A regime starts after a plateau or a running-in. A slope before it above PRE_SLOPE_Z
    sigma and above PRE_SLOPE_SHARE of the mean slope after it is one accelerating curve:
    measured u0 + a t^3 read as a plateau and a kink, and the offset law from the kink
    extrapolated too little curvature (the lever matrix's 3000 s power rows: -24 % at
    lambda 0.5).
    """
    if start <= 0 or not t[-1] > t[start]:
        return False
    gram = design.T @ (design * w[:, None])
    if not np.linalg.cond(gram) < 1e14:
        return False
    sigma = math.sqrt(max(float(np.linalg.inv(gram)[1, 1]) * scale, 0.0))
    after = float(design[-1, 2] * beta[2]) / float(t[-1] - t[start])   # mean slope after tau
    return float(beta[1]) > max(PRE_SLOPE_Z * sigma, PRE_SLOPE_SHARE * after)


def _hinge_rss(t: np.ndarray, u: np.ndarray, w: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Return the hinge's rss per (tau = t[index], p).

    inf where the wear part a <= 0 (:func:`regime_start`). All candidates in one pass: the
    normal equations from the weighted sums of the columns (pre and post never overlap, so
    their cross term is 0), as :func:`_wls_rss` would solve them one design at a time.
    """
    d = t[None, :] - t[index][:, None]                      # (m, n)
    pre = np.minimum(d, 0.0)
    wear = _wear_columns(np.maximum(d, 0.0))                           # (m, e, n)
    wu = w * u
    sw, su = w.sum(), float(wu.sum())
    sp, spp, spu = pre @ w, (pre * pre) @ w, pre @ wu                  # (m,)
    sq, sqq, squ = wear @ w, (wear * wear) @ w, wear @ wu              # (m, e)
    m, e = wear.shape[:2]
    gram = np.zeros((m, e, 3, 3))
    gram[..., 0, 0] = sw
    gram[..., 0, 1] = gram[..., 1, 0] = sp[:, None]
    gram[..., 1, 1] = spp[:, None]
    gram[..., 0, 2] = gram[..., 2, 0] = sq
    gram[..., 2, 2] = sqq
    right = np.stack([np.full((m, e), su), np.broadcast_to(spu[:, None], (m, e)), squ], axis=-1)
    beta = _solve(gram.reshape(m * e, 3, 3), right.reshape(m * e, 3)).reshape(m, e, 3)
    fitted = beta[..., :1] + beta[..., 1:2] * pre[:, None, :] + beta[..., 2:] * wear
    rss = ((u[None, None, :] - fitted) ** 2 * w[None, None, :]).sum(axis=2)
    return np.where(beta[..., 2] > 0.0, rss, np.inf)


def _wear_columns(post: np.ndarray) -> np.ndarray:
    """Return post^p (m, e, n) for p in HINGE_EXPONENTS, from ``post`` (m, n) >= 0.

    Whole exponents by products (a tenth of the cost of ``**`` with an array of exponents,
    within an ulp of it); others by ``**``.
    """
    if not np.array_equal(HINGE_EXPONENTS, np.round(HINGE_EXPONENTS)) \
            or HINGE_EXPONENTS.min() < 1.0:
        return np.asarray(post[:, None, :] ** HINGE_EXPONENTS[None, :, None])
    wear = np.empty((post.shape[0], HINGE_EXPONENTS.size, post.shape[1]))
    power, held = post, 1
    for j, p in enumerate(HINGE_EXPONENTS.astype(int).tolist()):
        while held < p:
            power, held = power * post, held + 1
        wear[:, j] = power
    return wear


def _solve(gram: np.ndarray, right: np.ndarray) -> np.ndarray:
    """Return the coefficients of the normal equations gram (k, q, q) beta = right (k, q).

    A ridge of 1e-12 of the largest diagonal element; a column that is zero throughout (tau
    at the first bin: no 'before') gets a coefficient 0.
    """
    diagonal = np.einsum('kii->ki', gram)
    ridge = 1e-12 * diagonal.max(axis=1, keepdims=True) + (diagonal == 0.0)
    gram = gram + ridge[:, :, None] * np.eye(gram.shape[2])[None, :, :]
    return np.asarray(np.linalg.solve(gram, right[:, :, None])[:, :, 0])


def _wls_rss(design: np.ndarray, u: np.ndarray, w: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
    """Return the weighted rss and coefficients of u ~ design (k, n, q) for each of k designs.

    A column that is zero throughout (tau at the first bin: no 'before') gets a coefficient 0.
    """
    weighted = design * w[None, :, None]
    gram = np.einsum('kni,knj->kij', weighted, design)
    right = np.einsum('kni,n->ki', weighted, u)
    beta = _solve(gram, right)
    fitted = np.einsum('kni,ki->kn', design, beta)
    rss = ((u[None, :] - fitted) ** 2 * w[None, :]).sum(axis=1)
    return rss, beta
