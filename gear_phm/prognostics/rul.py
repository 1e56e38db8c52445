"""Remaining useful life from the whole history of the filter's window measurements.

History (:class:`WearHistory`): every measurement of u the filter fused (t, z, R), or, from a
stream without measurements, every posterior (t, u, P_uu), goes into one of at most
``max_points`` bins of equal width in time. When a new point falls past the last bin, the bins
are merged pairwise and the width doubles, so memory is bounded for any length of input and the
bins always cover the whole history, evenly. A bin is summarised by its precision-weighted
mean time and u, and the summed precision of its measurements (independent windows), or the
mean precision of its posteriors (not the sum: neighbouring Kalman posteriors are strongly
correlated, so averaging them does not make u more certain). Measurements are preferred: a
posterior lags accelerating wear and then catches up, a kink that the fit extrapolates.

Wear laws (:func:`fit_trend`), all written with the level u_end and the slope r = du/dt at the
newest bin time t_end (s = t - t_end <= 0, tau = t - t_start >= 0, T = t_end - t_start):

- linear:       u = u_end + r s
- exponential:  u = u_end + r (exp(k s) - 1) / k                 (u = c + a exp(k t), k > 0)
- power:        u = u_end + r T / p ((tau / T)^p - 1)            (u = c + a (t - t_start)^p)
- proportional: u = u_end exp(k s), r = k u_end                  (du/dt = k u, k > 0)

The proportional law is the exponential one without its offset c: wear whose rate grows with
the friction itself (progpy's exponential degradation model). It has two parameters
(u_end, k), like the line, so the data need not show the curvature before it can be chosen:
its curvature, r^2 / u, comes with the slope. The line and it are the two extrapolations a
short history cannot tell apart; their Akaike weights share the RUL until the data can
(a 300 s exponential life: from 0.04 of the life it is within 10 %; the line, 40 % long).

The shape (k or p) is found on a log grid (refined by a parabola through the three best grid
points) with u_end and r in closed form (weighted least squares with the bins' precisions).
The residual scale is the reduced chi-square, at least 1 (the residuals of a smooth fit
cannot show the filter's slowly wandering error, P_uu does). The residuals are autocorrelated,
so the effective number of points n_eff comes from their autocorrelation (Geyer's initial
positive sequence) and the parameter covariance is inflated by n / n_eff. The law is chosen by
AICc with that n_eff (``trend='auto'``), or fixed by ``trend``.

RUL (:class:`RulPredictor`): the parameters (u_end, r, shape) are drawn from their Gaussian
(fixed standard-normal draws from ``seed``: common random numbers, no jitter between fits),
each draw's first passage of u_eol after t_end is solved in closed form (inf where the draw
never reaches it, e.g. r <= 0), and the 5/50/95 % inverted-CDF quantiles of the crossing time
are kept. At time t the RUL quantiles are max(t_cross - t, 0), so between refits (at most
every 1/16 of the history's growth) the RUL costs a subtraction.

The curved laws held out of the median while their curvature is not significant
(``CURVATURE_Z``) still bound the band from below: p5 is the lower of the admitted laws' p5
and the p5 of all the fitted laws, each with its Akaike weight over them all. The data cannot
yet exclude that curvature, so the band must not either. On a spur-gear plant whose tooth
friction grows exponentially over a constant bearing friction (u = c + a exp(k t)), the line
and the proportional law hold the median for half the life while the offset exponential
cannot pass ``CURVATURE_Z``; their p5 stayed above the true RUL, and the band held it at 38 %
and 68 % of the times from 0.25 of the life on two such plants (58 % and 93 % now;
docs/prognostics.md). The median, and with it every alpha-lambda check and horizon, is
unchanged.

Two uncertainties that no residual of the fit shows are added to each draw's crossing:

- the history's resolution: wear accrues unseen between two points, so the crossing lies
  anywhere within one mean spacing of the points (uniform);
- a systematic error of the measured u, ``u_systematic`` [-] at end of life (a sensor
  calibration or model accuracy, the same for every window, so it does not average out):
  the crossing moves by u_systematic / (du/dt at the crossing), normal.

Without them the band of a long, well-fitted history narrowed to 0.3 % of the RUL (a fraction
of a second on a 300 s life at 1 kHz) and missed the truth, which the wear between two
windows, or a measurement bias of 0.05 % of u, moved by more.

Detection: a law enters the RUL's mixture only when its own slope at the newest time is
significant, r > detect_z sigma_r (half that once in; the Akaike weights are renormalised over
the laws in). The RUL is finite only when the growth of u is significant twice over:

1. the best such law's slope (the condition above);
2. the rise of u over the history against its own uncertainty (:func:`rise_sigma`;
   posteriors: rise > detect_z sqrt(sigma_start^2 + sigma_end^2), sigma_end from the newest
   bin's P_uu, sigma_start from the first quarter of the history); the rise is the
   smaller of the fitted law's u_end - u(t_start) and the data's last-quarter minus
   first-quarter mean (:func:`rise`: a law fitted to a few points can extrapolate a steep
   start that the data do not show).

Before a history of measurements has ``DETECT_MIN_POINTS`` effective points, growth is first
detected only at detect_z DETECT_MIN_POINTS / n_eff sigma (a steep rise is plain from a dozen
windows, a marginal one is not). Otherwise every quantile is inf (model 'none'). Once
detected, growth is dropped only when the tests fail at ``DETECT_RELEASE`` (0.5) times
detect_z: a hysteresis, so that the RUL does not toggle between finite and inf (and the
RUL-based WARN with it) while the evidence hovers at the threshold (3 of 18 matrix runs did,
2026-11-24). Test 2 is needed early in a history: a few seconds of a filter settling from
its prior or wandering within its sigma are a "significant" slope to a fit of a handful of
correlated points (bags/healthy gave a RUL p5 of 4 s, hence a false WARN, at 5 s). The rise
of each law over the span T: r T (linear), r (1 - exp(-k T)) / k (exponential and
proportional), r T / p (power). Already worn (the filter's u >= u_eol): every quantile is 0.
"""
from __future__ import annotations

from dataclasses import dataclass, fields, replace
import math
from typing import Any

import numpy as np

from gear_phm.persistence import decode_float, decode_floats, encode_float, encode_floats
from gear_phm.prognostics.config import DEFAULTS
from gear_phm.prognostics.laws import (EXPONENTIAL, EXPONENTIAL_FORM, LINEAR, MODELS, NONE,
                                       POWER, PROPORTIONAL, SHAPED)

#: Shape grids: k span (dimensionless growth over the history) and power-law exponents.
#: Both laws accelerate (k > 0, p >= P_FLOOR): see P_FLOOR.
K_SPAN_GRID = np.geomspace(0.02, 30.0, 80)
#: The proportional law's k span grid: from growth too slow to see (k -> 0 is a constant u,
#: not the line) to the exponential's limit.
K_PROPORTIONAL_GRID = np.geomspace(1e-4, 30.0, 100)
#: Smallest power-law exponent fitted or drawn. Wear-out does not decelerate: a running-in
#: or a filter settling from its prior early in a history fits p < 1 and extrapolates an
#: asymptote, i.e. RULs of 1e6 s at 6-13 % of a 300 s exponential life (2026-11-25), and a
#: WARN -> OK -> WARN. A truly decelerating history is extrapolated as linear: conservative.
P_FLOOR = 1.0
P_GRID = np.geomspace(P_FLOOR, 10.0, 60)
#: Once growth is detected, it is dropped only when both tests fall below this fraction of
#: detect_z (hysteresis: one WARN per real crossing, docs/prognostics.md).
DETECT_RELEASE = 0.5
#: Effective points (n_eff) of a history of measurements below which growth is first
#: detected only at detect_z DETECT_MIN_POINTS / n_eff sigma (posteriors: no such rule; their
#: n_eff is small by their correlation). With fewer, a 2-sigma slope is a noise excursion
#: often enough to be found, lost and found again within seconds (a 3000 s linear matrix
#: run, seed 1, 2026-11-25: detected at 14 points, released at 19, detected again at 29), and
#: the RUL-based WARN with it. A hard minimum of 24 points (until 2026-11-26) kept the RUL of
#: a 300 s life inf for its first 0.1, while its rise was at 6 sigma from 0.04.
DETECT_MIN_POINTS = 24.0
#: A curved law joins the RUL's mixture only when it fits better than the line by this many
#: sigma (likelihood ratio): before, its extrapolation is unconstrained. On a 30 000 s linear
#: life (2026-11-25) exponential and power fits of the first 150 s (Akaike weights 0.24
#: each) put the RUL's p5 at 186 s against a true 29 850 s: a WARN at once, OK 500 s later.
CURVATURE_Z = 2.0
#: The RUL draws a curved law's shape only where its profile rss is within this many sigma
#: of the best fit (:func:`_shape_range`).
SHAPE_PROFILE_Z = 3.0
#: Smallest exponent a power-law draw may take (keeps u increasing in tau).
P_MIN = 0.05


@dataclass(frozen=True)
class Trend:
    """Fitted wear law at the newest history time ``t_end`` [s].

    u_end [-], slope r [1/s] and shape (k [1/s] or p [-], 0 for linear); ``covariance`` of
    (u_end, r, shape), row-major (proportional: rank 2, r = k u_end to first order).
    """

    model: str = NONE
    t_end: float = 0.0
    u_end: float = 0.0
    slope: float = 0.0
    slope_sigma: float = math.inf
    shape: float = 0.0
    #: t_end - t_start [s] (the power law's T)
    span: float = 0.0
    covariance: tuple[float, ...] = ()
    points: int = 0
    effective_points: float = 0.0
    #: Akaike weight of this law among those fitted (1 when only one)
    weight: float = 1.0
    #: variance scale of the points: reduced chi-square (>= 1) times n / n_eff [-]
    scale: float = 1.0
    #: the shapes the data allow (profile of the fit within SHAPE_PROFILE_Z sigma): the
    #: RUL's shape draws are clipped to them
    shape_low: float = 0.0
    shape_high: float = math.inf


@dataclass(frozen=True)
class RulEstimate:
    """RUL quantiles [s] (inf allowed) and the trend model used ('none' if no degradation).

    The time base is the one the history was fed: operating time in
    :class:`~gear_phm.prognostics.HealthAssessor`; :meth:`in_elapsed_time` converts.
    """

    median: float
    p5: float
    p95: float
    model: str

    def in_elapsed_time(self, utilisation: float) -> RulEstimate:
        """Return this RUL of operating time as elapsed time [s] at ``utilisation`` [-].

        ``utilisation`` is operating over elapsed time: each quantile is divided by it; a
        positive RUL at utilisation 0 is inf (no wear while it stands still), 0 stays 0.
        """
        def scaled(value: float) -> float:
            if value == 0.0 or math.isnan(value):
                return value
            return value / utilisation if utilisation > 0.0 else math.inf
        return RulEstimate(scaled(self.median), scaled(self.p5), scaled(self.p95), self.model)


class Utilisation:
    """Operating time over elapsed (stamp) time [-], accumulated over a history of updates.

    Each :meth:`add` of (stamp time t, operating time s) [s] adds the increments since the
    previous one: elapsed t - t_prev and operating s - s_prev. An increment where either time
    went back is not counted. :attr:`fraction` is 1 until some time has elapsed (a RUL then
    means the same in both time bases), and at most 1.
    """

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget the accumulated times."""
        self.operating = 0.0
        self.elapsed = 0.0
        self._last: tuple[float, float] | None = None

    def add(self, t: float, s: float) -> None:
        """Add the update at stamp time ``t`` [s] with operating time ``s`` [s]."""
        if not (math.isfinite(t) and math.isfinite(s)):
            return
        if self._last is not None:
            dt, ds = t - self._last[0], s - self._last[1]
            if dt >= 0.0 and ds >= 0.0:
                self.elapsed += dt
                self.operating += ds
        self._last = (t, s)

    @property
    def fraction(self) -> float:
        """Operating over elapsed time [-] (1 before any time elapsed)."""
        return min(self.operating / self.elapsed, 1.0) if self.elapsed > 0.0 else 1.0

    def to_state(self) -> dict[str, Any]:
        """Return the accumulated times and the last update (JSON-safe)."""
        return {'operating': encode_float(self.operating), 'elapsed': encode_float(self.elapsed),
                'last': None if self._last is None else encode_floats(self._last)}

    def from_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`to_state`; ValueError/KeyError/TypeError if malformed."""
        last = None if state['last'] is None else decode_floats(state['last'])
        if last is not None and len(last) != 2:
            raise ValueError('utilisation: last needs 2 values')
        operating, elapsed = decode_float(state['operating']), decode_float(state['elapsed'])
        self.operating, self.elapsed = operating, elapsed
        self._last = None if last is None else (last[0], last[1])


def trend_to_state(trend: Trend) -> dict[str, Any]:
    """Return a :class:`Trend` as a JSON-safe dict (floats via :func:`encode_float`)."""
    state: dict[str, Any] = {}
    for item in fields(Trend):
        value = getattr(trend, item.name)
        if isinstance(value, tuple):
            state[item.name] = encode_floats(value)
        elif isinstance(value, float):
            state[item.name] = encode_float(value)
        else:
            state[item.name] = value
    return state


def trend_from_state(state: dict[str, Any]) -> Trend:
    """Inverse of :func:`trend_to_state`; ValueError/KeyError/TypeError if malformed."""
    model = state['model']
    if model not in (*MODELS, NONE):
        raise ValueError(f'unknown trend model {model!r}')
    return Trend(model, *(decode_float(state[key]) for key in
                          ('t_end', 'u_end', 'slope', 'slope_sigma', 'shape', 'span')),
                 tuple(decode_floats(state['covariance'])), int(state['points']),
                 decode_float(state['effective_points']), decode_float(state['weight']),
                 decode_float(state.get('scale', 1.0)),
                 decode_float(state.get('shape_low', 0.0)),
                 decode_float(state.get('shape_high', 'inf')))


class WearHistory:
    """At most ``max_points`` equal-width time bins of (t, u, 1/P_uu) (module docstring)."""

    def __init__(self, max_points: int = 256, initial_width: float = 0.01) -> None:
        if max_points < 8 or max_points % 2:
            raise ValueError(f'max_points must be even and >= 8, got {max_points!r}')
        if not initial_width > 0.0:
            raise ValueError(f'initial_width must be > 0 s, got {initial_width!r}')
        self.max_points = int(max_points)
        self.initial_width = float(initial_width)
        #: Points are independent measurements (a bin's precision is their sum), not
        #: correlated posteriors (their mean); set while the history is empty.
        self.independent = False
        self.reset()

    def reset(self) -> None:
        """Forget the history (e.g. after the filter re-initialised)."""
        m = self.max_points
        self.t_start = math.nan
        self.t_last = math.nan
        self.width = self.initial_width
        self._w = [0.0] * m          # sum of 1/P
        self._wt = [0.0] * m         # sum of (t - t_start)/P
        self._wu = [0.0] * m         # sum of u/P
        self._n = [0] * m
        #: bins opened so far (counts up, also across merges: the refit clock)
        self.opened = 0
        self._occupied = 0

    def __len__(self) -> int:
        return self._occupied

    def add(self, t: float, u: float, u_variance: float) -> None:
        """Record a posterior at time t [s]; a time before the last one restarts the history."""
        if not (math.isfinite(t) and math.isfinite(u) and math.isfinite(u_variance)
                and u_variance > 0.0):
            return
        if self.t_last == self.t_last and t < self.t_last:
            self.reset()
        if self.t_start != self.t_start:
            self.t_start = t
        self.t_last = t
        dt = t - self.t_start
        index = int(dt / self.width)
        while index >= self.max_points:
            self._merge()
            index = int(dt / self.width)
        w = 1.0 / u_variance
        if not self._n[index]:
            self.opened += 1
            self._occupied += 1
        self._w[index] += w
        self._wt[index] += w * dt
        self._wu[index] += w * u
        self._n[index] += 1

    def shift(self, offset: float) -> None:
        """Move the history by ``offset`` [s] in time (onto another time axis)."""
        self.t_start += offset
        self.t_last += offset

    def to_state(self) -> dict[str, Any]:
        """Return the bins and their clock (JSON-safe, see :mod:`gear_phm.persistence`)."""
        return {'max_points': self.max_points, 't_start': encode_float(self.t_start),
                't_last': encode_float(self.t_last), 'width': encode_float(self.width),
                'w': encode_floats(self._w), 'wt': encode_floats(self._wt),
                'wu': encode_floats(self._wu), 'n': list(self._n), 'opened': self.opened,
                'independent': self.independent}

    def from_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`to_state` (same max_points); ValueError/KeyError/TypeError if bad."""
        m = self.max_points
        columns = [decode_floats(state[key]) for key in ('w', 'wt', 'wu')]
        n = [int(v) for v in state['n']]
        if int(state['max_points']) != m or any(len(c) != m for c in (*columns, n)):
            raise ValueError(f'history state must have {m} bins')
        width = decode_float(state['width'])
        if not width > 0.0:
            raise ValueError(f'history bin width must be > 0, got {width!r}')
        self.t_start, self.t_last = decode_float(state['t_start']), decode_float(state['t_last'])
        self.width = width
        self._w, self._wt, self._wu = columns
        self._n = n
        self.opened = int(state['opened'])
        self._occupied = sum(1 for k in n if k)
        self.independent = bool(state.get('independent', False))

    @property
    def spacing(self) -> float:
        """Mean time between the points added [s] (0 before two)."""
        added = sum(self._n)
        return (self.t_last - self.t_start) / (added - 1) if added > 1 else 0.0

    def _merge(self) -> None:
        half = self.max_points // 2
        for name in ('_w', '_wt', '_wu', '_n'):
            values = getattr(self, name)
            merged = [values[2 * i] + values[2 * i + 1] for i in range(half)]
            setattr(self, name, merged + [type(values[0])(0)] * half)
        self.width *= 2.0
        self._occupied = sum(1 for n in self._n if n)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Occupied bins: mean time since t_start [s], mean u [-], precision [1/-^2].

        The precision of a bin's u: the sum of independent measurements', the mean of
        posteriors'.
        """
        n = np.asarray(self._n, dtype=float)
        keep = n > 0
        w = np.asarray(self._w)[keep]
        precision = w if self.independent else w / n[keep]
        return (np.asarray(self._wt)[keep] / w, np.asarray(self._wu)[keep] / w, precision)


def _profile(basis: np.ndarray, u: np.ndarray, w: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fit u ~ b0 + b1 g by closed-form WLS for every row g of ``basis`` (m, n).

    Returns the weighted RSS, b0 and b1 (RSS inf where degenerate).
    """
    sw, su, suu = w.sum(), w @ u, w @ (u * u)
    sg, sgg, sgu = basis @ w, (basis * basis) @ w, basis @ (w * u)
    det = sw * sgg - sg * sg
    valid = det > 1e-12 * sw * sgg
    with np.errstate(divide='ignore', invalid='ignore'):
        b1 = (sw * sgu - sg * su) / det
        b0 = (su - b1 * sg) / sw
        rss = suu - b0 * su - b1 * sgu
    rss = np.where(valid, np.maximum(rss, 0.0), np.inf)
    return rss, np.where(valid, b0, 0.0), np.where(valid, b1, 0.0)


def _basis(model: str, shape: np.ndarray, s: np.ndarray, x: np.ndarray, span: float
           ) -> tuple[np.ndarray, np.ndarray]:
    """Return the rows g(s; shape), one per shape, and their derivatives in shape.

    See the module docstring; s = t - t_end [s], x = tau / T [-].
    """
    shape = np.asarray(shape, dtype=float)[:, None]
    with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
        if model in EXPONENTIAL_FORM:
            ks = shape * s
            e = np.exp(ks)
            g = np.expm1(ks) / shape
            dg = (ks * e - np.expm1(ks)) / (shape * shape)
        else:
            xp = np.power(x, shape)
            logx = np.log(np.where(x > 0.0, x, 1.0))
            g = span / shape * (xp - 1.0)
            dg = span * (xp * logx * shape - (xp - 1.0)) / (shape * shape)
    return g, dg


def _effective_points(residuals: np.ndarray) -> float:
    """Return n over the integrated autocorrelation time of the standardised residuals.

    Geyer's initial positive sequence. The autocovariances are divided by the larger of the
    residuals' own variance and 1 (the filter's P_uu): a misfit far below the filter's noise is not
    evidence of correlated noise. n when the residuals are all zero.
    """
    n = residuals.size
    centred = residuals - residuals.mean()
    c0 = max(float(centred @ centred), float(n))
    rho = np.correlate(centred, centred, 'full')[n - 1:] / c0
    rho[0] = 1.0
    tau = -1.0
    for m in range(0, (n - 1) // 2):
        pair = rho[2 * m] + rho[2 * m + 1]
        if not pair > 0.0:
            break
        tau += 2.0 * pair
    return float(min(max(n / max(tau, 1.0), 1.0), n))


@dataclass(frozen=True)
class _Fit:
    model: str
    params: np.ndarray           # u_end, r (, shape)
    rss: float
    jacobian: np.ndarray         # (n, free): in u_end, r (, shape); proportional: u_end, k
    #: curved laws: the shape grid and its profile rss (prior penalty included)
    profile: tuple[np.ndarray, np.ndarray] | None = None
    #: number of free parameters
    free: int = 2

    def expanded(self, cov: np.ndarray) -> np.ndarray:
        """Return the covariance ``cov`` of the free parameters as one of (u_end, r, shape).

        Proportional: r = k u_end, to first order.
        """
        if self.model != PROPORTIONAL:
            return cov
        u_end, _, k = (float(v) for v in self.params)
        a = np.array([[1.0, 0.0], [k, u_end], [0.0, 1.0]])
        return np.asarray(a @ cov @ a.T)


def _refined(grid: np.ndarray, rss: np.ndarray, best: int) -> float:
    """Return the shape at the vertex of a parabola in log(shape) through the 3 best points."""
    shape = float(grid[best])
    if 0 < best < grid.size - 1:
        y0, y1, y2 = rss[best - 1], rss[best], rss[best + 1]
        denominator = y0 - 2.0 * y1 + y2
        if denominator > 0.0:
            step = math.log(grid[best + 1] / grid[best])
            shape = float(grid[best] * math.exp(0.5 * step * (y0 - y2) / denominator))
    return shape


def _fit_proportional(s: np.ndarray, span: float, u: np.ndarray, w: np.ndarray,
                      prior: tuple[ShapePrior, float] | None = None) -> _Fit | None:
    """Best fit of u = u_end exp(k s): closed form in u_end, a grid in k.

    ``prior``: as in :func:`_fit_model`.
    """
    grid = K_PROPORTIONAL_GRID / span

    def profile(k: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        with np.errstate(over='ignore', invalid='ignore'):
            g = np.exp(np.asarray(k, dtype=float)[:, None] * s)
            sgg, sgu = (g * g) @ w, g @ (w * u)
            b = np.where(sgg > 0.0, sgu / np.where(sgg > 0.0, sgg, 1.0), 0.0)
            rss = np.where(sgg > 0.0, np.maximum(w @ (u * u) - b * sgu, 0.0), np.inf)
        if prior is not None:
            rss = rss + prior[1] * prior[0].penalty(np.asarray(k, dtype=float))
        return rss, b, g
    rss, _, _ = profile(grid)
    best = int(np.argmin(rss))
    if not math.isfinite(rss[best]):
        return None
    candidates = np.array([_refined(grid, rss, best), float(grid[best])])
    rss2, b, g = profile(candidates)
    i = 0 if rss2[0] <= rss2[1] else 1
    k, u_end = float(candidates[i]), float(b[i])
    if not u_end > 0.0:
        return None
    jacobian = np.column_stack([g[i], u_end * s * g[i]])
    return _Fit(PROPORTIONAL, np.array([u_end, k * u_end, k]), float(rss2[i]), jacobian,
                (grid, rss), free=2)


@dataclass(frozen=True)
class ShapePrior:
    """A population prior on a wear law's shape (issue 13): log-normal on k or p.

    Units that reached their end of life teach the fleet its wear law
    (:func:`gear_phm.offline.fleet.population_prior`): ``model`` (exponential, power or
    proportional) is then the only law fitted, and its shape has the prior log(shape) ~
    N(``log_mean``, ``log_sigma``^2), combined with the history's likelihood (a MAP shape, and
    the prior's information added to the parameter covariance). The exponential's and the
    proportional law's k are in 1/s of the time axis; the power law's p is dimensionless, so
    it carries over between units of different wear speeds.
    """

    model: str
    log_mean: float
    log_sigma: float

    def __post_init__(self) -> None:
        if self.model not in SHAPED:
            raise ValueError(f'a shape prior needs exponential, power or proportional, got '
                             f'{self.model!r}')
        if not (math.isfinite(self.log_mean) and self.log_sigma > 0.0):
            raise ValueError(f'prior log mean must be finite and log sigma > 0, got '
                             f'{self.log_mean!r}, {self.log_sigma!r}')

    def penalty(self, shape: np.ndarray) -> np.ndarray:
        """Return ((log shape - log_mean) / log_sigma)^2 [-]."""
        with np.errstate(divide='ignore', invalid='ignore'):
            z = (np.log(shape) - self.log_mean) / self.log_sigma
        return np.where(np.isfinite(z), z * z, np.inf)


def _fit_model(model: str, s: np.ndarray, x: np.ndarray, span: float, u: np.ndarray,
               w: np.ndarray, prior: tuple[ShapePrior, float] | None = None) -> _Fit | None:
    """Best fit of one law on the history (None when degenerate).

    ``prior``: (shape prior, residual scale): the shape then minimises rss + scale * penalty.
    """
    if model == PROPORTIONAL:
        return _fit_proportional(s, span, u, w, prior)
    if model == LINEAR:
        rss, b0, b1 = _profile(s[None, :], u, w)
        if not math.isfinite(rss[0]):
            return None
        return _Fit(LINEAR, np.array([b0[0], b1[0]]), float(rss[0]),
                    np.column_stack([np.ones_like(s), s]))
    grid = K_SPAN_GRID / span if model == EXPONENTIAL else P_GRID
    g, _ = _basis(model, grid, s, x, span)
    rss, _, _ = _profile(g, u, w)
    if prior is not None:
        rss = rss + prior[1] * prior[0].penalty(grid)
    best = int(np.argmin(rss))
    if not math.isfinite(rss[best]):
        return None
    shape = _refined(grid, rss, best)
    g, dg = _basis(model, np.array([shape, float(grid[best])]), s, x, span)
    rss2, b0, b1 = _profile(g, u, w)
    if prior is not None:
        rss2 = rss2 + prior[1] * prior[0].penalty(np.array([shape, float(grid[best])]))
    i = 0 if rss2[0] <= rss2[1] else 1
    shape = shape if i == 0 else float(grid[best])
    jacobian = np.column_stack([np.ones_like(s), g[i], b1[i] * dg[i]])
    return _Fit(model, np.array([b0[i], b1[i], shape]), float(rss2[i]), jacobian,
                (grid, rss), free=3)


def _covariance(jacobian: np.ndarray, w: np.ndarray, scale: float,
                shape_information: float = 0.0) -> np.ndarray | None:
    """Return scale (J^T W J + scale P)^-1, with column equilibration; None when singular.

    P is zero but for ``shape_information`` [1/shape^2] on the shape (the last parameter: a
    prior's).
    """
    m = jacobian.T @ (jacobian * w[:, None])
    if shape_information > 0.0:
        m[-1, -1] += scale * shape_information
    d = np.sqrt(np.diag(m))
    if not np.all(d > 0.0):
        return None
    normalised = m / np.outer(d, d)
    if not np.linalg.cond(normalised) < 1e12:
        return None
    return np.asarray(scale * np.linalg.inv(normalised) / np.outer(d, d))


def fit_laws(t: np.ndarray, u: np.ndarray, precision: np.ndarray,
             trend: str = str(DEFAULTS['trend']), min_points: int = 8,
             prior: ShapePrior | None = None,
             admitted: frozenset[str] = frozenset(),
             held_out: list[Trend] | None = None) -> tuple[Trend, ...]:
    """Fit the wear laws to a history: times since its start [s], u [-], 1/P_uu.

    The law ``trend`` names, or all of them for 'auto', best AICc first, each with its Akaike
    weight (module docstring); () if too few points. With a shape ``prior`` only its law is
    fitted, with its shape drawn towards the prior (:class:`ShapePrior`). With 'auto', a
    curved law is kept only when it fits significantly better than the line (CURVATURE_Z;
    half that for the laws ``admitted`` by the previous fit: a hysteresis); the laws it keeps
    out are appended to ``held_out`` (if given) with their Akaike weights over all the laws.
    """
    n = t.size
    if n < min_points or not t[-1] > t[0]:
        return ()
    t_end = float(t[-1])
    s, span = t - t_end, t_end
    x = np.clip(t / span, 0.0, None)
    models = (prior.model,) if prior is not None else MODELS if trend == 'auto' else (trend,)
    fits = {m: f for m in models if (f := _fit_model(m, s, x, span, u, precision)) is not None}
    if not fits:
        return ()
    flexible = min(fits.values(), key=lambda f: (-f.free, f.rss))
    residuals = np.sqrt(precision) * (u - _fitted_values(flexible, s, x, span))
    n_eff = _effective_points(residuals)
    sigma2 = max(flexible.rss / max(n - flexible.free, 1), 1.0)
    information = 0.0
    if prior is not None:       # the MAP shape, at the likelihood fit's residual scale
        fitted = _fit_model(prior.model, s, x, span, u, precision,
                            (prior, sigma2 * n / n_eff))
        if fitted is None:
            return ()
        fits = {prior.model: fitted}
        information = 1.0 / (float(fitted.params[2]) * prior.log_sigma) ** 2
    laws = []
    for name, fit in fits.items():
        k = fit.free
        if not n_eff > k + 1.0:
            continue
        aicc = n_eff / n * fit.rss / sigma2 + 2.0 * k + 2.0 * k * (k + 1.0) / (n_eff - k - 1.0)
        scale = max(fit.rss / max(n - k, 1), 1.0) * n / n_eff
        cov = _covariance(fit.jacobian, precision, scale, information)
        low, high = _shape_range(fit, scale)
        if cov is not None:
            cov = fit.expanded(cov)
            laws.append((aicc, Trend(name, t_end, float(fit.params[0]), float(fit.params[1]),
                                     math.sqrt(max(float(cov[1, 1]), 0.0)),
                                     float(fit.params[2]) if name != LINEAR else 0.0, span,
                                     tuple(float(v) for v in cov.ravel()), n, n_eff,
                                     scale=scale, shape_low=low, shape_high=high)))
    if not laws:
        return ()
    if LINEAR in fits and len(laws) > 1:
        # a curved law extends the line (k -> 0, p = 1): it is extrapolated only once its
        # curvature is significant (its fit better than the line's by CURVATURE_Z^2 sigma^2).
        # The proportional law does not extend the line: its curvature is not a free parameter
        line = fits[LINEAR].rss

        def shown(law: Trend) -> bool:
            z = CURVATURE_Z * (DETECT_RELEASE if law.model in admitted else 1.0)
            return law.model in (LINEAR, PROPORTIONAL) or (
                line - fits[law.model].rss) > z ** 2 * sigma2
        if held_out is not None:
            weights = _akaike_weights([aicc for aicc, _ in laws])
            held_out.extend(replace(law, weight=float(w))
                            for (_, law), w in zip(laws, weights) if not shown(law))
        laws = [entry for entry in laws if shown(entry[1])]
    laws.sort(key=lambda law: law[0])
    weights = _akaike_weights([aicc for aicc, _ in laws])
    return tuple(replace(law, weight=float(w)) for (_, law), w in zip(laws, weights))


def _akaike_weights(aicc: list[float]) -> np.ndarray:
    """Return the Akaike weights exp(-AICc / 2), normalised, of the laws in that order."""
    values = np.array(aicc)
    weights = np.exp(-0.5 * (values - values.min()))
    return weights / weights.sum()


def _renormalised(laws: tuple[Trend, ...]) -> tuple[Trend, ...]:
    """Return ``laws`` with their Akaike weights scaled to sum to 1."""
    total = sum(law.weight for law in laws)
    return tuple(replace(law, weight=law.weight / total) for law in laws) if total > 0 else ()


def _shape_range(fit: _Fit, scale: float) -> tuple[float, float]:
    """Return the shapes whose profile rss is within SHAPE_PROFILE_Z^2 ``scale`` of the best.

    One grid step wider on each side (the grid is coarse); (0, inf) for a linear law. The
    Gaussian covariance of a shape that the data barely pin down reaches shapes the data
    exclude (an e-folding time of seconds under a history of minutes of steady rise).
    """
    if fit.profile is None:
        return 0.0, math.inf
    grid, rss = fit.profile
    inside = np.flatnonzero(rss <= fit.rss + SHAPE_PROFILE_Z ** 2 * scale)
    if inside.size == 0:
        return 0.0, math.inf
    lo, hi = int(inside[0]), int(inside[-1])
    low = float(grid[lo - 1]) if lo > 0 else 0.0
    high = float(grid[hi + 1]) if hi + 1 < grid.size else math.inf
    return min(low, float(fit.params[2])), max(high, float(fit.params[2]))


def fit_trend(t: np.ndarray, u: np.ndarray, precision: np.ndarray,
              trend: str = str(DEFAULTS['trend']), min_points: int = 8) -> Trend:
    """Return the AICc-best law of :func:`fit_laws` (Trend() when none could be fitted)."""
    laws = fit_laws(t, u, precision, trend, min_points)
    return laws[0] if laws else Trend(points=t.size)


def _fitted_values(fit: _Fit, s: np.ndarray, x: np.ndarray, span: float) -> np.ndarray:
    """Return the fit's u at the history's times."""
    if fit.model == LINEAR:
        return np.asarray(fit.params[0] + fit.params[1] * s)
    g, _ = _basis(fit.model, np.array([fit.params[2]]), s, x, span)
    return np.asarray(fit.params[0] + fit.params[1] * g[0])


def crossing_offsets(model: str, gap: np.ndarray, rate: np.ndarray, shape: np.ndarray,
                     span: float) -> np.ndarray:
    """Return, per draw, the time after t_end [s] at which u_end + r g(s) reaches u_end + gap.

    inf where it never does (r <= 0, or a saturating exponential), -inf where gap <= 0
    (already there).
    """
    with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
        ratio = gap / rate
        if model in EXPONENTIAL_FORM:
            growth = shape * ratio
            offset = np.where(np.abs(growth) < 1e-9, ratio, np.log1p(growth) / shape)
            offset = np.where(growth > -1.0, offset, np.inf)
        elif model == POWER:
            p = np.maximum(shape, P_MIN)
            offset = span * (np.power(1.0 + p * ratio / span, 1.0 / p) - 1.0)
        else:
            offset = ratio
    offset = np.where(rate > 0.0, offset, np.inf)
    offset = np.where(np.isnan(offset), np.inf, offset)
    return np.asarray(np.where(gap > 0.0, offset, -np.inf))


def crossing_slopes(model: str, offset: np.ndarray, rate: np.ndarray, shape: np.ndarray,
                    span: float) -> np.ndarray:
    """Return du/dt [1/s] of each draw at its crossing ``offset`` after t_end [s].

    linear r, exponential and proportional r exp(k s), power r (1 + s / T)^(p - 1); inf where
    the offset is not finite (a time shift of an infinite crossing is no shift).
    """
    finite = np.isfinite(offset)
    s = np.where(finite, np.maximum(offset, 0.0), 0.0)
    with np.errstate(over='ignore', invalid='ignore'):
        if model in EXPONENTIAL_FORM:
            slope = rate * np.exp(shape * s)
        elif model == POWER:
            slope = rate * np.power(1.0 + s / span, np.maximum(shape, P_MIN) - 1.0)
        else:
            slope = rate * np.ones_like(s)
    return np.asarray(np.where(finite & (slope > 0.0), slope, np.inf))


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


def inverted_cdf_quantiles(values: np.ndarray, probabilities: tuple[float, ...]
                           ) -> list[float]:
    """Return ``np.quantile(values, probabilities, method='inverted_cdf')`` from one sort.

    numpy's vectorised sort beats ``np.quantile``, and ``np.partition`` with several ranks,
    for a few thousand draws; the tests check they agree. NaN-free input.
    """
    n = values.size
    ordered = np.sort(values)
    return [float(ordered[max(math.ceil(p * n) - 1, 0)]) for p in probabilities]


class RulPredictor:
    """RUL quantiles from the whole posterior history (module docstring).

    Fixed seeded draws; a refit each time the history gained 1/``refit_fraction`` of its bins.
    """

    def __init__(self, u_eol: float, detect_z: float = float(DEFAULTS['detect_z']),
                 mc_samples: int = int(DEFAULTS['mc_samples']),
                 seed: int = int(DEFAULTS['seed']), trend: str = str(DEFAULTS['trend']),
                 max_points: int = 256, min_points: int = 8, refit_fraction: int = 16,
                 prior: ShapePrior | None = None, u_systematic: float = 0.0) -> None:
        if not math.isfinite(u_eol):
            raise ValueError(f'u_eol must be finite, got {u_eol!r}')
        if mc_samples < 2:
            raise ValueError(f'mc_samples must be >= 2, got {mc_samples!r}')
        if trend != 'auto' and trend not in MODELS:
            raise ValueError(f'trend must be auto or one of {MODELS}, got {trend!r}')
        if not (math.isfinite(u_systematic) and u_systematic >= 0.0):
            raise ValueError(f'u_systematic must be >= 0, got {u_systematic!r}')
        self.u_eol = float(u_eol)
        #: systematic uncertainty of the measured u at end of life [-] (does not average out)
        self.u_systematic = float(u_systematic)
        self.detect_z = float(detect_z)
        self.trend_choice = trend
        self.prior = prior
        self.min_points = int(min_points)
        self.refit_fraction = int(refit_fraction)
        self.history = WearHistory(max_points)
        rng = np.random.default_rng(seed)
        self._normals = rng.standard_normal((3, int(mc_samples)))
        self._uniforms = rng.random(int(mc_samples))
        self._phases = rng.random(int(mc_samples)) - 0.5
        self._systematic = rng.standard_normal(int(mc_samples))
        #: number of fits so far (the cost is bounded: tests count them)
        self.fits = 0
        self.reset()

    def reset(self) -> None:
        """Forget the history and the fit."""
        self.history.reset()
        self._trend = Trend()
        self._crossing = (math.inf, math.inf, math.inf)
        self._fitted_at = 0
        self._due = 1
        self.detected = False
        #: curved laws in the last fit's mixture (their admission has a hysteresis)
        self._curved: frozenset[str] = frozenset()

    def add(self, t: float, u: float, u_variance: float, independent: bool = False) -> None:
        """Record a posterior (t [s], u [-], P_uu [-^2]) or an ``independent`` measurement.

        A measurement of u comes with its variance. A history holds one kind: the other kind
        restarts it.
        """
        if independent != self.history.independent:
            self.reset()
            self.history.independent = independent
        opened = self.history.opened
        self.history.add(t, u, u_variance)
        if self.history.opened < opened:        # time went backwards: the history restarted
            self._trend, self._crossing, self._fitted_at = Trend(), (math.inf,) * 3, 0
            self._due = 1
            self.detected = False
            self._curved = frozenset()

    def shift(self, offset: float) -> None:
        """Move the history and the fit by ``offset`` [s] in time (onto another time axis)."""
        self.history.shift(offset)
        self._trend = replace(self._trend, t_end=self._trend.t_end + offset)
        self._crossing = (self._crossing[0] + offset, self._crossing[1] + offset,
                          self._crossing[2] + offset)

    def to_state(self) -> dict[str, Any]:
        """Return the history, fit and refit clock (JSON-safe); the draws come from the seed."""
        return {'history': self.history.to_state(), 'trend': trend_to_state(self._trend),
                'crossing': encode_floats(self._crossing), 'fitted_at': self._fitted_at,
                'due': self._due, 'fits': self.fits, 'detected': self.detected,
                'curved': sorted(self._curved)}

    def from_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`to_state`; ValueError/KeyError/TypeError if malformed."""
        crossing = decode_floats(state['crossing'])
        if len(crossing) != 3:
            raise ValueError('crossing needs 3 quantiles')
        trend = trend_from_state(state['trend'])
        history = WearHistory(self.history.max_points, self.history.initial_width)
        history.from_state(state['history'])
        self.history, self._trend = history, trend
        self._crossing = (crossing[0], crossing[1], crossing[2])
        self._fitted_at, self._due = int(state['fitted_at']), int(state['due'])
        self.fits = int(state['fits'])
        self.detected = bool(state.get('detected', math.isfinite(crossing[1])))
        self._curved = frozenset(str(m) for m in state.get('curved', ()) if m in MODELS)

    @property
    def trend(self) -> Trend:
        """Return the current fit, refitted when due."""
        history = self.history
        if history.opened - self._fitted_at >= self._due:
            self._refit()
            self._due = max(1, len(history) // self.refit_fraction)
        return self._trend

    def _refit(self) -> None:
        history = self.history
        self._fitted_at = history.opened
        t, u, precision = history.arrays()
        if t.size < self.min_points:
            return
        self.fits += 1
        held: list[Trend] = []
        laws = tuple(replace(law, t_end=law.t_end + history.t_start)
                     for law in fit_laws(t, u, precision, self.trend_choice, self.min_points,
                                         self.prior, self._curved, held))
        # a law extrapolates only once its own slope now is significant (a curved law's slope
        # is uncertain with its shape); hysteresis: half that for the laws already in
        admitted = (self._curved | {LINEAR}) if self.detected else self._curved
        fitted = laws
        laws = _renormalised(tuple(
            law for law in laws if law.slope > self.detect_z * law.slope_sigma
            * (DETECT_RELEASE if law.model in admitted else 1.0)))
        self._curved = frozenset(law.model for law in laws if law.model != LINEAR)
        # the trend reported: the RUL's best law, else the best fitted one (no growth seen)
        self._trend = (laws or fitted or (Trend(points=t.size),))[0]
        # hysteresis: once growth was seen, it is dropped only below half the threshold
        z = self.detect_z * (DETECT_RELEASE if self.detected else 1.0)
        if laws and history.independent and not self.detected:
            z *= max(DETECT_MIN_POINTS / laws[0].effective_points, 1.0)
        self.detected = bool(laws) and rise(laws[0], t, u, precision) > z * rise_sigma(
            t, precision, history.independent, laws[0].scale)
        self._crossing = self._crossing_quantiles(laws) if self.detected \
            else (math.inf, math.inf, math.inf)
        if self.detected and held:
            # the band's lower bound also counts the curved laws held out of the median, with
            # their Akaike weights over all the laws (module docstring)
            share = 1.0 - sum(law.weight for law in held)
            every = tuple(replace(law, weight=law.weight * share) for law in laws) + tuple(
                replace(law, t_end=law.t_end + history.t_start) for law in held)
            p5 = self._crossing_quantiles(_renormalised(every))[0]
            self._crossing = (min(self._crossing[0], p5), self._crossing[1], self._crossing[2])

    def _crossing_quantiles(self, laws: tuple[Trend, ...]) -> tuple[float, float, float]:
        """Return the 5/50/95 % quantiles of the absolute time [s] of reaching u_eol.

        inf: never. Over the laws' parameter draws, each law taking its Akaike weight's share
        of the draws.
        """
        crossing = np.empty(self._uniforms.size)
        edges = np.cumsum([law.weight for law in laws])
        edges[-1] = 1.0
        lower = 0.0
        for law, upper in zip(laws, edges):
            chosen = (self._uniforms >= lower) & (self._uniforms < upper)
            lower = upper
            if not chosen.any():
                continue
            k = 3 if law.model != LINEAR else 2
            cov = np.asarray(law.covariance).reshape(k, k)
            values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
            root = vectors * np.sqrt(np.maximum(values, 0.0))
            draws = root @ self._normals[:k, chosen]
            rate = law.slope + draws[1]
            shape = law.shape + draws[2] if k == 3 else np.zeros_like(rate)
            if k == 3:
                shape = np.clip(shape, law.shape_low, law.shape_high)
            if law.model == POWER:
                shape = np.maximum(shape, P_FLOOR)
            elif law.model == PROPORTIONAL:     # r = k u_end exactly, not to first order
                rate = (law.u_end + draws[0]) * shape
            offsets = crossing_offsets(
                law.model, self.u_eol - (law.u_end + draws[0]), rate, shape, law.span)
            if self.u_systematic > 0.0:
                with np.errstate(invalid='ignore'):
                    offsets = offsets + self.u_systematic * self._systematic[chosen] \
                        / crossing_slopes(law.model, offsets, rate, shape, law.span)
            crossing[chosen] = law.t_end + offsets
        # the resolution of the history: wear accrues between two points unseen, so the
        # crossing lies anywhere within one spacing
        crossing += self.history.spacing * self._phases
        p5, median, p95 = inverted_cdf_quantiles(crossing, (0.05, 0.5, 0.95))
        return (p5, median, p95)

    def law_past_eol(self, t: float) -> bool:
        """Whether the fitted law crossed u_eol before time t [s] in 95 % of its draws.

        From the fit alone (the filter's u, which :meth:`predict` also checks, does not count).
        """
        return bool(self._crossing[2] <= t)

    def predict(self, t: float, u: float) -> RulEstimate:
        """RUL [s] at time t [s] given the filter's current u [-] (0 once u >= u_eol)."""
        trend = self.trend
        if u >= self.u_eol:
            return RulEstimate(0.0, 0.0, 0.0, trend.model)
        c5, c50, c95 = self._crossing
        p5, median, p95 = max(c5 - t, 0.0), max(c50 - t, 0.0), max(c95 - t, 0.0)
        model = trend.model if math.isfinite(median) or math.isfinite(p5) else NONE
        return RulEstimate(median, p5, p95, model)
