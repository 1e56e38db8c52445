"""Wear laws fitted to the wear history (:func:`fit_laws`), their crossing of u_eol.

All laws are written with the level u_end and the slope r = du/dt at the newest bin time
t_end (s = t - t_end <= 0, tau = t - t_start >= 0, T = t_end - t_start):

- linear:       u = u_end + r s
- exponential:  u = u_end + r (exp(k s) - 1) / k                 (u = c + a exp(k t), k > 0)
- power:        u = u_end + r T / p ((tau / T)^p - 1)            (u = c + a (t - t_start)^p)
- proportional: u = u_end exp(k s), r = k u_end                  (du/dt = k u, k > 0)

The proportional law is the exponential one without its offset c: wear whose rate grows with
the friction itself (progpy's exponential degradation model). It has two parameters
(u_end, k), like the line, so the data need not show the curvature before it can be chosen:
its curvature, r^2 / u, comes with the slope. The line and it are the two extrapolations a
short history cannot tell apart; their Akaike weights share the RUL until the data can.

The shape (k or p) is found on a log grid (refined by a parabola through the three best grid
points) with u_end and r in closed form (weighted least squares with the bins' precisions).
The residual scale is the reduced chi-square, at least 1 (the residuals of a smooth fit
cannot show the filter's slowly wandering error, P_uu does). The residuals are autocorrelated,
so the effective number of points n_eff comes from their autocorrelation (Geyer's initial
positive sequence) and the parameter covariance is inflated by n / n_eff. The law is chosen by
AICc with that n_eff (``trend='auto'``), or fixed by ``trend``. A curved law joins the
mixture only once its curvature is significant (``CURVATURE_Z``); the laws held out are
returned apart, for the band's lower bound (:mod:`gear_phm.prognostics.calibration`).
"""
from __future__ import annotations

from dataclasses import dataclass, fields
import math
from typing import Any, TypeVar

import numpy as np

from gear_phm.persistence import decode_float, decode_floats, encode_float, encode_floats
from gear_phm.prognostics.config import DEFAULTS
from gear_phm.prognostics.laws import (EXPONENTIAL, EXPONENTIAL_FORM, LINEAR, MODELS, NONE,
                                       POWER, PROPORTIONAL, SHAPED)

_T = TypeVar('_T')

#: Shape grids: k span (dimensionless growth over the history) and power-law exponents.
#: Both laws accelerate (k > 0, p >= P_FLOOR): see P_FLOOR.
K_SPAN_GRID = np.geomspace(0.02, 30.0, 80)
#: The proportional law's k span grid: from growth too slow to see (k -> 0 is a constant u,
#: not the line) to the exponential's limit.
K_PROPORTIONAL_GRID = np.geomspace(1e-4, 30.0, 100)
#: Smallest power-law exponent fitted or drawn. Wear-out does not decelerate: a running-in
#: or a filter settling from its prior early in a history fits p < 1 and extrapolates an
#: asymptote, i.e. RULs of 1e6 s at 6-13 % of a 300 s exponential life, and a
#: WARN -> OK -> WARN. A truly decelerating history is extrapolated as linear: conservative.
P_FLOOR = 1.0
P_GRID = np.geomspace(P_FLOOR, 10.0, 60)
#: Once growth is detected, it is dropped only when both tests fall below this fraction of
#: detect_z (hysteresis: one WARN per real crossing, docs/prognostics.md).
DETECT_RELEASE = 0.5
#: A curved law joins the RUL's mixture only when it fits better than the line by this many
#: sigma (likelihood ratio): before, its extrapolation is unconstrained. On a 30 000 s linear
#: life, exponential and power fits of the first 150 s (Akaike weights 0.24
#: each) put the RUL's p5 at 186 s against a true 29 850 s: a WARN at once, OK 500 s later.
CURVATURE_Z = 2.0
#: The RUL draws a curved law's shape only where its profile rss is within this many sigma
#: of the best fit (:func:`_shape_range`).
SHAPE_PROFILE_Z = 3.0
#: Smallest exponent a power-law draw may take (keeps u increasing in tau).
P_MIN = 0.05


def frozen_instance(cls: type[_T], values: dict[str, Any]) -> _T:
    """Return an instance of the frozen dataclass ``cls`` with the field ``values``, all given.

    Equal to ``cls(**values)`` without its per-field ``object.__setattr__`` (a frozen
    dataclass's ``__init__`` costs microseconds, paid per estimate); for classes without a
    ``__post_init__``.
    """
    instance = object.__new__(cls)
    instance.__dict__.update(values)
    return instance


def replaced(instance: _T, **changes: Any) -> _T:
    """Return ``dataclasses.replace(instance, **changes)`` (:func:`frozen_instance`'s terms)."""
    return frozen_instance(type(instance), {**instance.__dict__, **changes})


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
    t_end, u_end, slope, slope_sigma, shape, span = (
        decode_float(state[key])
        for key in ('t_end', 'u_end', 'slope', 'slope_sigma', 'shape', 'span'))
    return Trend(model, t_end, u_end, slope, slope_sigma, shape, span,
                 tuple(decode_floats(state['covariance'])), int(state['points']),
                 decode_float(state['effective_points']), decode_float(state['weight']),
                 decode_float(state.get('scale', 1.0)),
                 decode_float(state.get('shape_low', 0.0)),
                 decode_float(state.get('shape_high', 'inf')))


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


def _basis(model: str, shape: np.ndarray, s: np.ndarray, x: np.ndarray, span: float,
           derivative: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """Return the rows g(s; shape), one per shape, and their derivatives in shape.

    See the module docstring; s = t - t_end [s], x = tau / T [-]. Not ``derivative``: no
    derivatives (None; a shape grid's profile needs only g).
    """
    shape = np.asarray(shape, dtype=float)[:, None]
    dg = None
    with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
        if model in EXPONENTIAL_FORM:
            ks = shape * s
            growth = np.expm1(ks)
            g = growth / shape
            if derivative:
                dg = (ks * np.exp(ks) - growth) / (shape * shape)
        else:
            xp = np.power(x, shape)
            g = span / shape * (xp - 1.0)
            if derivative:
                logx = np.log(np.where(x > 0.0, x, 1.0))
                dg = span * (xp * logx * shape - (xp - 1.0)) / (shape * shape)
    return g, dg


def _grid_rows(model: str, grid: np.ndarray, s: np.ndarray, x: np.ndarray,
               span: float) -> np.ndarray:
    """Return :func:`_basis`'s rows g for a grid of shapes, for the grid's profile only.

    exp(k s) - 1 for expm1(k s) and exp(p log x) for x^p: a fifth of their cost (numpy's
    expm1 and power with an array of exponents are slow), within about 1e-14 of them
    relative to the rows' scale (k s >= k min(s), the grid's smallest growth 0.02, and
    |p log x| <= 10 |log x|). The fit at the chosen shape uses :func:`_basis`.
    """
    shape = np.asarray(grid, dtype=float)[:, None]
    if model in EXPONENTIAL_FORM:
        with np.errstate(over='ignore', invalid='ignore'):
            rows: np.ndarray = (np.exp(shape * s) - 1.0) / shape
        return rows
    with np.errstate(divide='ignore', over='ignore', invalid='ignore'):
        rows = span / shape * (np.exp(shape * np.log(x)) - 1.0)        # x = 0: exp(-inf) = 0
    return rows


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
    """A population prior on a wear law's shape: log-normal on k or p.

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
    rss, _, _ = _profile(_grid_rows(model, grid, s, x, span), u, w)
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
    assert dg is not None
    jacobian = np.column_stack([np.ones_like(s), g[i], b1[i] * dg[i]])
    return _Fit(model, np.array([b0[i], b1[i], shape]), float(rss2[i]), jacobian,
                (grid, rss), free=3)


def _covariance(jacobian: np.ndarray, w: np.ndarray, scale: float,
                shape_information: float = 0.0, inverse: bool = True) -> np.ndarray | None:
    """Return scale (J^T W J + scale P)^-1, with column equilibration; None when singular.

    P is zero but for ``shape_information`` [1/shape^2] on the shape (the last parameter: a
    prior's). Not ``inverse``: the equilibrated matrix only (None as well when singular).
    """
    m = jacobian.T @ (jacobian * w[:, None])
    if shape_information > 0.0:
        m[-1, -1] += scale * shape_information
    d = np.sqrt(np.diag(m))
    if not np.all(d > 0.0):
        return None
    outer = np.outer(d, d)
    normalised: np.ndarray = m / outer
    singular = np.linalg.svd(normalised, compute_uv=False)     # np.linalg.cond's 2-norm
    largest, smallest = float(singular[0]), float(singular[-1])
    if not (smallest > 0.0 and largest / smallest < 1e12):
        return None
    if not inverse:
        return normalised
    return np.asarray(scale * np.linalg.inv(normalised) / outer)


def _scored_law(name: str, fit: _Fit, precision: np.ndarray,
                stats: tuple[int, float, float, float], t_end: float, span: float
                ) -> tuple[float, Trend] | None:
    """Return the AICc of law ``name``'s ``fit`` and its :class:`Trend` (None: too few points).

    ``stats``: the points, the effective points, the residual scale sigma^2 of the most
    flexible fit and the shape prior's information (0 without one); ``t_end``: the history's
    last time [s], ``span`` [s].
    """
    n, n_eff, sigma2, information = stats
    k = fit.free
    if not n_eff > k + 1.0:
        return None
    aicc = n_eff / n * fit.rss / sigma2 + 2.0 * k + 2.0 * k * (k + 1.0) / (n_eff - k - 1.0)
    scale = max(fit.rss / max(n - k, 1), 1.0) * n / n_eff
    cov = _covariance(fit.jacobian, precision, scale, information)
    low, high = _shape_range(fit, scale)
    if cov is None:
        return None
    cov = fit.expanded(cov)
    params = fit.params.tolist()
    return aicc, frozen_instance(Trend, {
        'model': name, 't_end': t_end, 'u_end': params[0], 'slope': params[1],
        'slope_sigma': math.sqrt(max(float(cov[1, 1]), 0.0)),
        'shape': params[2] if name != LINEAR else 0.0, 'span': span,
        'covariance': tuple(cov.ravel().tolist()), 'points': n,
        'effective_points': n_eff, 'weight': 1.0, 'scale': scale, 'shape_low': low,
        'shape_high': high})


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
    laws = [law for name, fit in fits.items()
            if (law := _scored_law(name, fit, precision, (n, n_eff, sigma2, information),
                                   t_end, span)) is not None]
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
            held_out.extend(replaced(law, weight=float(w))
                            for (_, law), w in zip(laws, weights) if not shown(law))
        laws = [entry for entry in laws if shown(entry[1])]
    laws.sort(key=lambda law: law[0])
    weights = _akaike_weights([aicc for aicc, _ in laws])
    return tuple(replaced(law, weight=float(w)) for (_, law), w in zip(laws, weights))


def forecast_law(t: np.ndarray, u: np.ndarray, precision: np.ndarray, model: str,
                 min_points: int = 8) -> Trend | None:
    """Return the law ``model`` as :func:`fit_laws` fits it alone, without its covariance.

    Its model, t_end, u_end, slope, shape and span only (for a forecast); None where
    :func:`fit_laws` returns no law.
    """
    n = t.size
    if n < min_points or not t[-1] > t[0]:
        return None
    t_end = float(t[-1])
    s, span = t - t_end, t_end
    x = np.clip(t / span, 0.0, None)
    fit = _fit_model(model, s, x, span, u, precision)
    if fit is None:
        return None
    residuals = np.sqrt(precision) * (u - _fitted_values(fit, s, x, span))
    n_eff = _effective_points(residuals)
    scale = max(fit.rss / max(n - fit.free, 1), 1.0) * n / n_eff
    if not n_eff > fit.free + 1.0 or _covariance(fit.jacobian, precision, scale,
                                                 inverse=False) is None:
        return None
    return Trend(model, t_end, float(fit.params[0]), float(fit.params[1]),
                 shape=float(fit.params[2]) if model != LINEAR else 0.0, span=span)


def _akaike_weights(aicc: list[float]) -> np.ndarray:
    """Return the Akaike weights exp(-AICc / 2), normalised, of the laws in that order."""
    values = np.array(aicc)
    weights = np.exp(-0.5 * (values - values.min()))
    normalised: np.ndarray = weights / weights.sum()
    return normalised


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
    g, _ = _basis(fit.model, np.array([fit.params[2]]), s, x, span, derivative=False)
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
