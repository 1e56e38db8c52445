"""Remaining useful life from the whole history of the filter's window measurements.

:class:`RulPredictor` keeps the wear history (:mod:`gear_phm.prognostics.history`), finds
where the current wear regime starts (:func:`~gear_phm.prognostics.changepoint.regime_start`,
measurement histories), refits the wear laws from there (:mod:`gear_phm.prognostics.fits`)
when due, decides whether growth is seen and keeps the quantiles of the time of reaching
u_eol, the band widened by the history's own rolling-origin forecast errors
(:mod:`gear_phm.prognostics.calibration`). At time t the RUL quantiles are
max(t_cross - t, 0), so between refits (every 1/64 of the history's growth) the RUL costs a
subtraction. See docs/prognostics.md.

Detection: a law enters the RUL's mixture only when its own slope at the newest time is
significant, r > detect_z sigma_r (half that once in; the Akaike weights are renormalised over
the laws in), and the rise of u over the history must be significant too
(:mod:`gear_phm.prognostics.changepoint`). Before a history of measurements has
``DETECT_MIN_POINTS`` effective points, growth is first detected only at
detect_z DETECT_MIN_POINTS / n_eff sigma. Otherwise every quantile is inf (model 'none'). Once
detected, growth is dropped only when the tests fail at ``DETECT_RELEASE`` (0.5) times
detect_z: a hysteresis, so that the RUL does not toggle between finite and inf (and the
RUL-based WARN with it) while the evidence hovers at the threshold. The curved laws held out of
the median while their curvature is not significant (``CURVATURE_Z``) still bound the band
from below: p5 is the lower of the admitted laws' p5 and the p5 of all the fitted laws, each
with its Akaike weight over them all. Already worn (the filter's u >= u_eol): every quantile
is 0.
"""
from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Any

import numpy as np

from gear_phm.persistence import decode_floats, encode_floats
from gear_phm.prognostics.calibration import (BAND_Z, crossing_quantiles, Draws,
                                              forecast_errors, ForecastCache, law_draws,
                                              LawDraws, MODEL_FORM_SIGMA, widened)
from gear_phm.prognostics.changepoint import (DETECT_MIN_POINTS, regime_start, RegimeStart, rise,
                                              rise_sigma)
from gear_phm.prognostics.config import DEFAULTS
from gear_phm.prognostics.fits import (DETECT_RELEASE, fit_laws, frozen_instance, replaced,
                                       ShapePrior, Trend, trend_from_state, trend_to_state)
from gear_phm.prognostics.history import Utilisation, WearHistory
from gear_phm.prognostics.laws import LINEAR, MODELS, NONE


def _renormalised(laws: tuple[Trend, ...]) -> tuple[Trend, ...]:
    """Return ``laws`` with their Akaike weights scaled to sum to 1."""
    total = sum(law.weight for law in laws)
    return tuple(replaced(law, weight=law.weight / total) for law in laws) if total > 0 else ()


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

    def in_elapsed_time(self, utilisation: Utilisation) -> RulEstimate:
        """Return this RUL of operating time as elapsed time [s] at ``utilisation``'s duty.

        The median and p95 through :meth:`Utilisation.elapsed_for
        <gear_phm.prognostics.history.Utilisation.elapsed_for>`, at the utilisation of the
        recent past (a positive RUL at utilisation 0 is inf, 0 and NaN stay as they are). The
        p5 stays the operating time's: the lower bound assumes that the gearbox runs without
        a pause from now on, the fastest it can wear, whatever its past duty.
        """
        median, p95 = utilisation.elapsed_for(self.median), utilisation.elapsed_for(self.p95)
        return frozen_instance(RulEstimate, {'median': median, 'p5': self.p5, 'p95': p95,
                                             'model': self.model})


class RulPredictor:
    """RUL quantiles from the whole posterior history (module docstring).

    Fixed seeded draws; a refit each time the history gained 1/``refit_fraction`` of its bins.
    ``regimes``: fit from the start of the current wear regime; ``calibrated``: widen the band
    by the history's own forecast errors (both on measurement histories only) and, with
    ``trend`` 'auto', by the model-form uncertainty.
    """

    def __init__(self, u_eol: float, detect_z: float = float(DEFAULTS['detect_z']),
                 mc_samples: int = int(DEFAULTS['mc_samples']),
                 seed: int = int(DEFAULTS['seed']), trend: str = str(DEFAULTS['trend']),
                 max_points: int = 256, min_points: int = 8, refit_fraction: int = 64,
                 prior: ShapePrior | None = None, u_systematic: float = 0.0,
                 regimes: bool = True, calibrated: bool = True) -> None:
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
        #: fit from the start of the current wear regime (:func:`regime_start`), else the
        #: whole history
        self.regimes = bool(regimes)
        #: widen the band by the history's own rolling-origin forecast errors
        self.calibrated = bool(calibrated)
        self._errors: np.ndarray | None = None
        #: the laws fitted at the forecast origins of the last refit (:func:`forecast_errors`)
        self._forecasts: ForecastCache = {}
        self.history = WearHistory(max_points)
        self._draws = Draws.seeded(seed, int(mc_samples))
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
        #: the start of the current wear regime found by the last fit
        self.regime = RegimeStart()
        #: curved laws in the last fit's mixture (their admission has a hysteresis)
        self._curved: frozenset[str] = frozenset()

    def add(self, t: float, u: float, u_variance: float, independent: bool = False,
            direction: float = 0.0, bias: float = 0.0) -> None:
        """Record a posterior (t [s], u [-], P_uu [-^2]) or an ``independent`` measurement.

        A measurement of u comes with its variance, and its load direction's share h [-] of
        the offset between the directions and the bias [-] subtracted from it
        (:class:`~gear_phm.prognostics.history.WearHistory`). A history holds one kind: the
        other kind restarts it.
        """
        if independent != self.history.independent:
            self.reset()
            self.history.independent = independent
        opened = self.history.opened
        self.history.add(t, u, u_variance, direction, bias)
        if self.history.opened < opened:        # time went backwards: the history restarted
            self._trend, self._crossing, self._fitted_at = Trend(), (math.inf,) * 3, 0
            self._due = 1
            self.detected = False
            self._curved = frozenset()

    def refit_soon(self) -> None:
        """Refit at the next :attr:`trend` (new settings: end of life, law, draws)."""
        self._fitted_at, self._due = self.history.opened, 0

    def shift(self, offset: float) -> None:
        """Move the history and the fit by ``offset`` [s] in time (onto another time axis)."""
        self.history.shift(offset)
        self._trend = replaced(self._trend, t_end=self._trend.t_end + offset)
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
        if self.regimes and history.independent:
            # fit the current wear regime only: from its start on (a plateau, a running-in or
            # an earlier regime before it is not the law that will reach u_eol). Measurements
            # only: a history of posteriors has kinks of its own, the filter's lag and
            # catching up, that are no change of regime
            self.regime = regime_start(t, u, precision, self.min_points)
            start = self.regime.index
            origin = float(t[start])
            t, u, precision = t[start:] - origin, u[start:], precision[start:]
        else:
            origin = 0.0
        held: list[Trend] = []
        laws = tuple(replaced(law, t_end=law.t_end + history.t_start + origin)
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
        # the laws' parameter draws, made once for the median and the calibrated band
        shares = law_draws(laws, self._draws, self.u_eol) if self.detected else None
        self._crossing = self._crossing_quantiles(shares) if shares is not None \
            else (math.inf, math.inf, math.inf)
        # the history's own forecast errors, grown to the horizon of the median
        self._errors = forecast_errors(
            t, u, precision, laws[0], self.min_points,
            self._crossing[1] - laws[0].t_end, self._forecasts) \
            if self.detected and self.calibrated and history.independent else None
        if self._errors is not None and self._errors.size > 1:
            # the band also holds the history's own forecast errors; the median is the fit's
            p5, _, p95 = crossing_quantiles(laws if shares is None else shares, self._draws,
                                            self.u_eol, self.u_systematic,
                                            self.history.spacing, self._errors)
            self._crossing = (min(self._crossing[0], p5), self._crossing[1],
                              max(self._crossing[2], p95))
        if self.detected and held:
            # the band's lower bound also counts the curved laws held out of the median, with
            # their Akaike weights over all the laws (module docstring)
            share = 1.0 - sum(law.weight for law in held)
            every = tuple(replaced(law, weight=law.weight * share) for law in laws) + tuple(
                replaced(law, t_end=law.t_end + history.t_start + origin) for law in held)
            p5 = self._crossing_quantiles(_renormalised(every))[0]
            self._crossing = (min(self._crossing[0], p5), self._crossing[1], self._crossing[2])

    def _crossing_quantiles(self, laws: tuple[Trend, ...] | LawDraws
                            ) -> tuple[float, float, float]:
        """Return the 5/50/95 % quantiles of the absolute time [s] of reaching u_eol.

        inf: never (:func:`~gear_phm.prognostics.calibration.crossing_quantiles`).
        """
        return crossing_quantiles(laws, self._draws, self.u_eol, self.u_systematic,
                                  self.history.spacing)

    def law_past_eol(self, t: float) -> bool:
        """Whether the fitted law crossed u_eol before time t [s] in 95 % of its draws.

        And the newest bin of the history is past u_eol too, by BAND_Z of its sigma: the
        measurements show the end of life that the filter's u, lagging accelerating wear, does
        not yet. The law alone is no witness: random life 92 (wear that slowed in mid-life)
        had a straight line over the concave history whose end stood 0.01 above the newest
        measurements, and "past u_eol" 987 s before the truth; with the newest bin not
        contradicting it, still 217 s before. From the fit and the history (the filter's u,
        which :meth:`predict` also checks, does not count).
        """
        if not self._crossing[2] <= t:
            return False
        _, u, precision = self.history.arrays()
        return bool(u.size and precision[-1] > 0.0
                    and u[-1] - BAND_Z / math.sqrt(precision[-1]) >= self.u_eol)

    def predict(self, t: float, u: float) -> RulEstimate:
        """RUL [s] at time t [s] given u [-]: 0 once u >= u_eol.

        The assessor passes u's lower 95 % bound. With ``calibrated`` and ``trend`` 'auto' the
        band holds the model-form uncertainty (:data:`calibration.MODEL_FORM_SIGMA`).
        """
        trend = self.trend
        if u >= self.u_eol:
            return frozen_instance(RulEstimate, {'median': 0.0, 'p5': 0.0, 'p95': 0.0,
                                                 'model': trend.model})
        c5, c50, c95 = self._crossing
        median = max(c50 - t, 0.0)
        p5, p95 = max(c5 - t, 0.0), max(c95 - t, 0.0)
        if self.calibrated and self.trend_choice == 'auto':
            # the band holds the model-form uncertainty too (calibration.MODEL_FORM_SIGMA);
            # not when the law is given (``trend``): then its form is the user's
            p5 = widened(median, p5, MODEL_FORM_SIGMA[0], upper=False)
            p95 = widened(median, p95, MODEL_FORM_SIGMA[1], upper=True)
        model = trend.model if math.isfinite(median) or math.isfinite(p5) else NONE
        return frozen_instance(RulEstimate, {'median': median, 'p5': p5, 'p95': p95,
                                             'model': model})
