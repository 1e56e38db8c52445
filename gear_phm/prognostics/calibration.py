"""The RUL band: quantiles of the time of reaching u_eol over the laws' parameter draws.

The parameters (u_end, r, shape) of each law are drawn from their Gaussian (fixed
standard-normal draws from a seed, :class:`Draws`: common random numbers, no jitter between
fits), each draw's first passage of u_eol after t_end is solved in closed form
(:func:`~gear_phm.prognostics.fits.crossing_offsets`; inf where the draw never reaches it, e.g.
r <= 0), and the 5/50/95 % inverted-CDF quantiles of the crossing time are kept
(:func:`crossing_quantiles`). Each law takes its Akaike weight's share of the draws.

Two uncertainties that no residual of the fit shows are added to each draw's crossing:

- the history's resolution: wear accrues unseen between two points, so the crossing lies
  anywhere within one mean spacing of the points (uniform);
- a systematic error of the measured u, ``u_systematic`` [-] at end of life (a sensor
  calibration or model accuracy, the same for every window, so it does not average out):
  the crossing moves by u_systematic / (du/dt at the crossing), normal.

Without them the band of a long, well-fitted history narrows to a fraction of a per cent of
the RUL and misses the truth, which the wear between two windows, or a measurement bias of
0.05 % of u, moves by more (docs/prognostics.md).
"""
from __future__ import annotations

from dataclasses import dataclass
import itertools
import math

import numpy as np

from gear_phm.prognostics.fits import (crossing_offsets, crossing_slopes, forecast_law, P_FLOOR,
                                       Trend)
from gear_phm.prognostics.laws import LINEAR, POWER, PROPORTIONAL


@dataclass(frozen=True)
class Draws:
    """Fixed random numbers of the band's Monte Carlo (common random numbers).

    ``normals`` (3, n): the parameters' standard-normal draws; ``uniforms`` (n): which law a
    draw belongs to, ascending (the draws are kept in that order, so that each law's share is
    one slice; the quantiles do not depend on the order); ``phases`` (n): uniform in
    [-0.5, 0.5), the resolution's shift; ``systematic`` (n): standard normal, the systematic
    error's.
    """

    normals: np.ndarray
    uniforms: np.ndarray
    phases: np.ndarray
    systematic: np.ndarray
    #: uniform in [0, 1): which rolling-origin forecast error a draw takes
    errors: np.ndarray

    @classmethod
    def seeded(cls, seed: int, samples: int) -> Draws:
        """Return ``samples`` draws from ``seed``."""
        rng = np.random.default_rng(seed)
        normals = rng.standard_normal((3, samples))
        uniforms = rng.random(samples)
        phases = rng.random(samples) - 0.5
        systematic = rng.standard_normal(samples)
        errors = rng.random(samples)
        order = np.argsort(uniforms, kind='stable')
        return cls(np.ascontiguousarray(normals[:, order]), uniforms[order], phases[order],
                   systematic[order], errors[order])

    def share(self, lower: float, upper: float) -> slice:
        """Return the draws whose ``uniforms`` are in [lower, upper): one slice."""
        return slice(int(np.searchsorted(self.uniforms, lower, 'left')),
                     int(np.searchsorted(self.uniforms, upper, 'left')))


def inverted_cdf_quantiles(values: np.ndarray, probabilities: tuple[float, ...]
                           ) -> list[float]:
    """Return ``np.quantile(values, probabilities, method='inverted_cdf')`` from one sort.

    numpy's vectorised sort beats ``np.quantile``, and ``np.partition`` with several ranks,
    for a few thousand draws; the tests check they agree. NaN-free input.
    """
    n = values.size
    ordered = np.sort(values)
    return [float(ordered[max(math.ceil(p * n) - 1, 0)]) for p in probabilities]


@dataclass(frozen=True)
class LawDraws:
    """Each law's share of the draws (:func:`law_draws`): which draws, and their parameters.

    ``parts``: per law, (the law, its draws (:meth:`Draws.share`), their time after t_end to
    u_eol [s], rate [1/s], shape).
    """

    parts: tuple[tuple[Trend, slice, np.ndarray, np.ndarray, np.ndarray], ...]


def law_draws(laws: tuple[Trend, ...], draws: Draws, u_eol: float) -> LawDraws:
    """Return the laws' parameter draws and their first passages of ``u_eol``.

    Each law takes its Akaike weight's share of the draws (module docstring); the part of
    :func:`crossing_draws` that does not depend on the forecast errors.
    """
    parts = []
    edges = np.cumsum([law.weight for law in laws])
    edges[-1] = 1.0
    lower = 0.0
    for law, upper in zip(laws, edges):
        chosen = draws.share(lower, upper)
        lower = upper
        if chosen.stop <= chosen.start:
            continue
        k = 3 if law.model != LINEAR else 2
        cov = np.asarray(law.covariance).reshape(k, k)
        values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
        root = vectors * np.sqrt(np.maximum(values, 0.0))
        drawn = root @ draws.normals[:k, chosen]
        rate = law.slope + drawn[1]
        shape = law.shape + drawn[2] if k == 3 else np.zeros_like(rate)
        if k == 3:
            shape = np.clip(shape, law.shape_low, law.shape_high)
        if law.model == POWER:
            shape = np.maximum(shape, P_FLOOR)
        elif law.model == PROPORTIONAL:     # r = k u_end exactly, not to first order
            rate = (law.u_end + drawn[0]) * shape
        offsets = crossing_offsets(
            law.model, u_eol - (law.u_end + drawn[0]), rate, shape, law.span)
        parts.append((law, chosen, offsets, rate, shape))
    return LawDraws(tuple(parts))


def crossing_draws(laws: tuple[Trend, ...] | LawDraws, draws: Draws, u_eol: float,
                   u_systematic: float, spacing: float, errors: np.ndarray | None = None
                   ) -> np.ndarray:
    """Return each draw's absolute time [s] of reaching ``u_eol`` (inf: never).

    Over the laws' parameter draws, each law taking its Akaike weight's share of the draws
    (``laws``, or their :func:`law_draws` already made);
    ``u_systematic`` [-] and the history's mean ``spacing`` [s] as in the module docstring.
    ``errors``: the history's own relative forecast errors (:func:`forecast_errors`); each
    draw takes one of them, rho, and its time to u_eol is divided by 1 + rho.
    """
    if errors is not None and errors.size:
        rho = errors[np.minimum((draws.errors * errors.size).astype(int), errors.size - 1)]
    else:
        rho = None
    shares = laws if isinstance(laws, LawDraws) else law_draws(laws, draws, u_eol)
    crossing = np.empty(draws.uniforms.size)
    for law, chosen, offsets, rate, shape in shares.parts:
        if rho is not None:
            offsets = np.where(offsets > 0.0, offsets / (1.0 + rho[chosen]), offsets)
        if u_systematic > 0.0:
            with np.errstate(invalid='ignore'):
                offsets = offsets + u_systematic * draws.systematic[chosen] \
                    / crossing_slopes(law.model, offsets, rate, shape, law.span)
        crossing[chosen] = law.t_end + offsets
    # the resolution of the history: wear accrues between two points unseen, so the
    # crossing lies anywhere within one spacing
    crossing += spacing * draws.phases
    return crossing


def crossing_quantiles(laws: tuple[Trend, ...] | LawDraws, draws: Draws, u_eol: float,
                       u_systematic: float, spacing: float, errors: np.ndarray | None = None
                       ) -> tuple[float, float, float]:
    """Return the 5/50/95 % quantiles [s] of :func:`crossing_draws` (inf: never)."""
    p5, median, p95 = inverted_cdf_quantiles(
        crossing_draws(laws, draws, u_eol, u_systematic, spacing, errors), (0.05, 0.5, 0.95))
    return (p5, median, p95)


#: Model-form uncertainty of the RUL, a log-normal sigma [-] of the time to u_eol below and
#: above the median (:func:`widened`). The parameter draws and the rolling-origin errors hold
#: the uncertainty of the fitted family; a gearbox whose wear follows no law of it (mixed
#: laws, regime changes, gamma and Wiener increments) strays further. It is added in
#: quadrature, in log RUL, to the band's own half-widths, so that a wide band stays nearly as
#: it is and a narrow one cannot claim more than the family is worth; more below the median,
#: where an optimistic RUL is the costlier error. Chosen on the 71 wear lives of the
#: random-life ensemble's seeds 1-60 and checked on the held-out seeds 61-100
#: (docs/prognostics.md, "Model-form uncertainty").
MODEL_FORM_SIGMA = (0.4, 0.2)
#: z of the band's 5 % and 95 % quantiles: the standard normal's one-sided 95 % quantile
#: (also the end of life's, :data:`gear_phm.prognostics.health.EOL_Z`)
BAND_Z = 1.645


def widened(median: float, bound: float, sigma: float, upper: bool) -> float:
    """Return the band's ``bound`` [s] with a model-form log sigma ``sigma`` [-] added.

    log(bound / median) and BAND_Z sigma in quadrature, below the median (``upper`` False)
    or above it. Unchanged where the median or the bound is 0 or inf.
    """
    if not (0.0 < median < math.inf and 0.0 < bound < math.inf):
        return bound
    half = math.hypot(math.log(bound / median), BAND_Z * sigma)
    return median * math.exp(half if upper else -half)


#: Forecast origins of :func:`forecast_errors`, as fractions of the regime's span.
ORIGINS = (0.4, 0.5, 0.6, 0.7, 0.8)
#: Limits of a relative forecast error rho: a time to u_eol is divided by 1 + rho, so at most
#: 4 times longer, and at most 5 times shorter.
RHO_LIMITS = (-0.75, 4.0)


#: Laws fitted at forecast origins, by their model and points (:func:`forecast_errors`).
ForecastCache = dict[tuple[str, int, bytes], Trend | None]
#: At most this many laws are kept in a :data:`ForecastCache`, the least recently used
#: dropped first. Between two merges of the history's bins the origins' points recur: a later
#: refit's origin 0.4 often ends at an earlier one's 0.5 (3000 s of linear wear at 100 Hz:
#: ~50 % of the origins found, against 11 % keeping the last refit's only).
FORECAST_CACHE_SIZE = 256


def forecast_errors(t: np.ndarray, u: np.ndarray, precision: np.ndarray, law: Trend,
                    min_points: int = 8, horizon: float = 0.0,
                    cache: ForecastCache | None = None) -> np.ndarray:
    """Return the history's own relative forecast errors rho [-], rolling origin.

    At each origin (:data:`ORIGINS` of the span of ``t`` [s, from the regime's start]) the
    law of ``law.model`` is fitted to the points up to it, and its time to reach the level
    the present fit ``law`` has now (u_end at t[-1]) is compared with the time that took:
    rho = forecast / actual - 1 (> 0: the forecast came too late, optimistic). Each error
    and its mirror 1 / (1 + rho) - 1 (a forecast as much too early) is one draw's
    (:func:`crossing_draws`), with rho = 0, the present fit as it is, once too.
    An origin with too few points or no growth in its fit gives none. An error measured over
    a time h shorter than the ``horizon`` [s] the band is for (the RUL median) grows to it as
    a diffusion does: log(1 + rho) times sqrt(horizon / h). ``cache``: the laws fitted at
    origins before, by their exact points (an origin whose points were fitted before is not
    fitted again); the laws used now are added or moved to its end, and it is cut to the
    :data:`FORECAST_CACHE_SIZE` used last.
    """
    errors = [0.0]
    span = float(t[-1] - t[0]) if t.size else 0.0
    for fraction in ORIGINS:
        k = int(np.searchsorted(t, t[0] + fraction * span, side='right'))
        if k < min_points or k >= t.size:
            continue
        key = (law.model, min_points, t[:k].tobytes() + u[:k].tobytes() + precision[:k].tobytes())
        if cache is not None and key in cache:
            earlier = cache.pop(key)
        else:
            earlier = forecast_law(t[:k], u[:k], precision[:k], law.model, min_points)
        if cache is not None:
            cache[key] = earlier                # the most recently used last
        if earlier is None or not earlier.slope > 0.0:
            continue
        actual = float(t[-1]) - earlier.t_end
        if not actual > 0.0:
            continue
        forecast = float(crossing_offsets(
            earlier.model, np.array([law.u_end - earlier.u_end]), np.array([earlier.slope]),
            np.array([earlier.shape]), earlier.span)[0])
        forecast = max(forecast, 0.0)
        rho = forecast / actual - 1.0 if math.isfinite(forecast) else RHO_LIMITS[1]
        rho = min(max(rho, RHO_LIMITS[0]), RHO_LIMITS[1])
        if horizon > actual and math.isfinite(horizon):
            rho = math.expm1(math.log1p(rho) * math.sqrt(horizon / actual))
            rho = min(max(rho, RHO_LIMITS[0]), RHO_LIMITS[1])
        # as likely either way: the band widens both ways, the median stays the fit's
        errors.extend((rho, 1.0 / (1.0 + rho) - 1.0))
    if cache is not None:
        for key in list(itertools.islice(cache, max(len(cache) - FORECAST_CACHE_SIZE, 0))):
            del cache[key]
    return np.array(errors)
