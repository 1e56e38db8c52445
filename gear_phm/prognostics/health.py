"""Health-level rules, filter-consistency and staleness checks (pure, time passed in).

Levels (diagnostic_msgs/DiagnosticStatus): OK 0, WARN 1, ERROR 2, STALE 3.

- ERROR: u - EOL_Z sigma_u >= u_eol, or the wear law fitted to the measurements crossed u_eol
  in 95 % of its draws and the newest measurements are past it too
  (:meth:`~gear_phm.prognostics.predictor.RulPredictor.law_past_eol`; end of life past
  reasonable doubt; includes
  self-locking u >= 1 when ``must_back_drive`` enables it; the message names the rule; it
  clears below u_eol (1 - hysteresis)), or the filter
  has lost the signal (:class:`DivergenceDetector`: sigma_u above ``max_u_sigma`` or not
  finite, or a median NIS above ``nis_lost``).
- WARN: "now self-locking: cannot be back-driven", a gearbox that back-drove when healthy
  whose aiding reading of u is past 1 (eta_I <= 0) by EOL_Z sigma_u (it clears below
  1 - hysteresis; ERROR "end of life (self_locking)" instead where ``must_back_drive`` says
  the drive must stay reversible); RUL median (operating time) < ``warn_horizon`` [s],
  cleared only once the RUL's 5 % bound is above
  :data:`~gear_phm.prognostics.config.RUL_CLEAR_FACTOR` times it; eta_D < ``eta_warn`` (by
  default derived from the healthy eta_D learned once the filter has settled,
  :class:`LevelTracker`); or a model mismatch (mean NIS above its chi-square bound
  while the estimate still tracks).
- STALE: no estimator input for ``stale_timeout`` [s], judged on the caller's clock (the
  diagnostics node's); it overrides the other levels because the estimate is no longer
  current.
- OK otherwise.

:class:`LevelTracker` applies hysteresis and a minimum dwell to every condition, so that one
real crossing gives one transition (the diagnostic_aggregator convention of not flapping).
"""
from __future__ import annotations

from collections import deque
import math
import statistics
from statistics import NormalDist
from typing import Any

from gear_phm.persistence import decode_float, decode_floats, encode_float, encode_floats
from gear_phm.prognostics.calibration import BAND_Z
from gear_phm.prognostics.config import (DEFAULTS, derived_eta_warn, HEALTHY_SETTLED_SHARE,
                                         RUL_CLEAR_FACTOR)
from gear_phm.prognostics.end_of_life import U_SELF_LOCKING
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
    """Judges the filter's consistency from its NIS and sigma_u: OK, mismatch or lost.

    - lost (ERROR): sigma_u above ``max_u_sigma`` or not finite (variance growing without
      bound), or the median of the last ``nis_window`` NIS values above ``nis_lost``: most
      innovations sqrt(nis_lost) times larger than the filter predicts mean the estimate no
      longer follows the measurements. The median, not the mean, so that the few huge
      innovations of a step the filter then follows (a sudden fault) are not a loss.
    - model mismatch (WARN): that mean above the chi-square bound
      :func:`chi_square_mean_bound` (at ``nis_probability``) but not above ``nis_lost``: the
      innovations are larger than predicted (a plant that is not the lever model, wear
      faster than the filter's random walk) while the estimate still tracks.

    NIS values are only counted when the innovation changes, because the estimator
    republishes the last innovation between filter updates.
    """

    def __init__(self, nis_window: int = int(DEFAULTS['nis_window']),
                 nis_probability: float = float(DEFAULTS['nis_probability']),
                 max_u_sigma: float = float(DEFAULTS['max_u_sigma']),
                 nis_lost: float = float(DEFAULTS['nis_lost'])) -> None:
        self.nis_window = int(nis_window)
        self.bound = chi_square_mean_bound(self.nis_window, nis_probability)
        self.max_u_sigma = float(max_u_sigma)
        self.nis_lost = float(nis_lost)
        self._nis: deque[float] = deque(maxlen=self.nis_window)
        self._last_innovation: tuple[float, float] | None = None
        #: the NIS window's verdict, kept until the window changes (None: to be judged)
        self._verdict: tuple[int, str] | None = None

    def reset(self) -> None:
        """Forget the NIS history."""
        self._nis.clear()
        self._last_innovation = None
        self._verdict = None

    def to_state(self) -> dict[str, Any]:
        """NIS window and the last innovation seen (JSON-safe)."""
        last = self._last_innovation
        return {'nis': encode_floats(self._nis),
                'last_innovation': None if last is None else encode_floats(last)}

    def from_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`to_state`; ValueError/KeyError/TypeError if malformed."""
        nis = decode_floats(state['nis'])
        last = state['last_innovation']
        pair = None if last is None else decode_floats(last)
        if pair is not None and len(pair) != 2:
            raise ValueError('last_innovation needs 2 values')
        self._nis = deque(nis, maxlen=self.nis_window)
        self._last_innovation = None if pair is None else (pair[0], pair[1])
        self._verdict = None

    @property
    def nis_mean(self) -> float:
        """Mean of the NIS window (NaN if empty)."""
        return sum(self._nis) / len(self._nis) if self._nis else math.nan

    @property
    def nis_median(self) -> float:
        """Median of the NIS window (NaN if empty)."""
        return statistics.median(self._nis) if self._nis else math.nan

    def update(self, innovation: float, innovation_variance: float, nis: float,
               u_sigma: float) -> tuple[int, str]:
        """Add one estimate; return (OK, ''), (WARN, mismatch reason) or (ERROR, lost reason)."""
        key = (innovation, innovation_variance)
        if math.isfinite(nis) and key != self._last_innovation:
            self._nis.append(float(nis))
            self._last_innovation = key
            self._verdict = None
        if not math.isfinite(u_sigma) or u_sigma > self.max_u_sigma:
            return ERROR, f'filter lost the signal: sigma_u {u_sigma:.3g} > {self.max_u_sigma:.3g}'
        if self._verdict is None:       # the window changed (most updates repeat the last)
            self._verdict = self._judged()
        return self._verdict

    def _judged(self) -> tuple[int, str]:
        """Return the NIS window's verdict (:meth:`update` without the sigma_u check)."""
        if len(self._nis) < self.nis_window or not self.nis_mean > self.bound:
            return OK, ''
        if self.nis_median > self.nis_lost:
            return ERROR, (f'filter lost the signal: median NIS {self.nis_median:.3g} over '
                           f'{self.nis_window} updates > {self.nis_lost:.3g}')
        return WARN, (f'model mismatch: mean NIS {self.nis_mean:.3g} over {self.nis_window} '
                      f'updates > {self.bound:.3g}')


#: End of life is entered when u's lower 95 % bound, u - EOL_Z sigma_u, reaches u_eol: an
#: ERROR "end of life" means the gearbox is past it with 95 % confidence, not that the
#: estimate's noise touched it (a 30 000 s life gave ERROR 6 s before the true end of life
#: on the point estimate). It costs EOL_Z sigma_u / (du/dt) of delay: ~1 s on
#: a 300 s life, ~90 s on a 30 000 s one. The band's one-sided 95 % quantile, defined there.
EOL_Z = BAND_Z


class Latch:
    """One threshold condition with hysteresis and minimum dwells, on stamp time [s].

    Inactive, it becomes active once ``enter`` has held for ``dwell`` seconds without a
    break; active, it clears once ``stay`` has been false for ``clear_dwell`` seconds
    (default ``dwell``). ``stay`` is the entry test with the threshold moved back by the
    hysteresis margin.
    """

    def __init__(self, dwell: float, clear_dwell: float | None = None) -> None:
        self.dwell = float(dwell)
        self.clear_dwell = self.dwell if clear_dwell is None else float(clear_dwell)
        self.active = False
        self._since: float | None = None

    def reset(self) -> None:
        """Inactive, nothing pending."""
        self.active = False
        self._since = None

    def to_state(self) -> dict[str, Any]:
        """Active flag and the stamp [s] a pending change started (None: none)."""
        return {'active': self.active,
                'since': None if self._since is None else encode_float(self._since)}

    def from_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`to_state`."""
        since = state['since']
        self.active = bool(state['active'])
        self._since = None if since is None else decode_float(since)

    def update(self, t: float, enter: bool, stay: bool) -> bool:
        """Feed the tests at stamp ``t`` [s]; return whether the condition is active."""
        wanted = stay if self.active else enter
        if wanted == self.active:
            self._since = None
        else:
            if self._since is None or t < self._since:
                self._since = t
            if t - self._since >= (self.clear_dwell if self.active else self.dwell):
                self.active = wanted
                self._since = None
        return self.active


class LevelTracker:
    """Health level of a stream of estimates by the rules of the module docstring.

    Every condition is a :class:`Latch`: it is entered when its value crosses the threshold
    and left when the value is back by ``level_hysteresis`` times the threshold's distance
    from a new gearbox's value (eta_D 1, or the learned eta_healthy, u 0): eta_D above
    eta_warn + h (1 - eta_warn), u below u_eol (1 - h). The RUL condition is entered on the
    RUL's median and left on its 5 % bound above :data:`RUL_CLEAR_FACTOR` warn_horizon: a
    hysteresis across the band as well, so that an early, wide band whose lower tail grazes
    the horizon (a fast law the data cannot exclude yet) does not warn and then clear.
    Entering must hold for ``level_dwell`` [s] of stamp time first, leaving for
    ``level_clear_dwell`` [s]: a value that hovers at its threshold (a mean NIS at its bound
    while wear outpaces the filter, an early RUL near the horizon) gives one WARN, not a
    WARN, OK, WARN flicker. The filter conditions (mismatch, lost) have the dwells only.

    ``eta_warn`` NaN (the default): the threshold is learned. The healthy eta_D,
    :attr:`eta_healthy`, is the first estimate's eta_D once the filter has settled (sigma_u
    at most HEALTHY_SETTLED_SHARE of u_eol - u, the filter check not ERROR); eta_warn is then
    :func:`~gear_phm.prognostics.config.derived_eta_warn` of it and ``eta_opposing_min``
    (WARN once 75 % of the budget between them is used), and the new gearbox of the
    hysteresis is eta_healthy. Until then there is no efficiency WARN. An explicit eta_warn is
    kept; eta_healthy is learned and reported all the same.

    ``watch_self_locking`` (set by the assessor for a gearbox that back-drove when healthy):
    the aiding reading of u past U_SELF_LOCKING by EOL_Z sigma_u WARNs "now self-locking".
    """

    def __init__(self, u_eol: float, eol_reason: str, eta_warn: float, warn_horizon: float,
                 level_hysteresis: float = float(DEFAULTS['level_hysteresis']),
                 level_dwell: float = float(DEFAULTS['level_dwell']),
                 level_clear_dwell: float = float(DEFAULTS['level_clear_dwell']),
                 eta_opposing_min: float = float(DEFAULTS['eta_opposing_min'])) -> None:
        self.u_eol, self.eol_reason = float(u_eol), eol_reason
        self.eta_warn, self.warn_horizon = float(eta_warn), float(warn_horizon)
        self.level_hysteresis, self.level_dwell = float(level_hysteresis), float(level_dwell)
        self.eta_opposing_min = float(eta_opposing_min)
        #: Whether eta_warn is learned (given as NaN); the healthy eta_D [-] (NaN until then).
        self.learns_eta_warn = math.isnan(self.eta_warn)
        self.eta_healthy = math.nan
        self.eta_clear = self.eta_warn + self.level_hysteresis * (1.0 - self.eta_warn)
        self.u_clear = self.u_eol * (1.0 - self.level_hysteresis)
        self.rul_clear = self.warn_horizon * RUL_CLEAR_FACTOR
        self.level_clear_dwell = float(level_clear_dwell)
        self.latches = {name: Latch(self.level_dwell, self.level_clear_dwell)
                        for name in ('eol', 'lost', 'eta', 'rul', 'mismatch', 'locked')}
        self.watch_self_locking = False

    def set_end_of_life(self, u_eol: float, eol_reason: str) -> None:
        """Apply a new end-of-life threshold u_eol [-] and the name of its rule."""
        self.u_eol, self.eol_reason = float(u_eol), eol_reason
        self.u_clear = self.u_eol * (1.0 - self.level_hysteresis)

    def reset(self) -> None:
        """Back to OK with nothing pending (a replay restarted); eta_healthy is learned anew."""
        for latch in self.latches.values():
            latch.reset()
        self._learn(math.nan)

    def _learn(self, eta_healthy: float) -> None:
        """Set the healthy eta_D [-] (NaN: not known) and, unless given, eta_warn from it."""
        self.eta_healthy = eta_healthy
        if not self.learns_eta_warn:
            return
        if math.isnan(eta_healthy):
            self.eta_warn = self.eta_clear = math.nan
            return
        self.eta_warn = derived_eta_warn(self.eta_opposing_min, eta_healthy)
        self.eta_clear = self.eta_warn + self.level_hysteresis * max(
            eta_healthy - self.eta_warn, 0.0)

    def to_state(self) -> dict[str, Any]:
        """Every latch's state and the learned healthy eta_D (JSON-safe)."""
        state: dict[str, Any] = {name: latch.to_state() for name, latch in self.latches.items()}
        state['eta_healthy'] = encode_float(self.eta_healthy)
        return state

    def from_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`to_state`; KeyError if a latch is missing.

        A state without ``eta_healthy`` (before it was learned) learns it anew; one without
        the ``locked`` latch (an older file) starts it inactive.
        """
        state = {'locked': Latch(0.0).to_state(), **state}
        for name in self.latches:            # check all before changing any
            if not isinstance(state[name], dict):
                raise ValueError(f'latch {name} state must be an object')
        eta_healthy = decode_float(state.get('eta_healthy', 'nan'))
        for name, latch in self.latches.items():
            latch.from_state(state[name])
        self._learn(eta_healthy)

    def update(self, t: float, u: float, eta_opposing: float, rul_p5: float,
               filter_check: tuple[int, str] = (OK, ''), u_sigma: float = 0.0,
               rul_median: float | None = None, law_past_eol: bool = False,
               u_aiding: float = math.nan) -> tuple[int, str]:
        """Return (level, message) at stamp ``t`` [s].

        Inputs: u [-], eta_D [-], the RUL's 5 % bound [s of operating time], the
        :meth:`DivergenceDetector.update` result, u's standard deviation [-] (end of life
        is entered on u - EOL_Z u_sigma), the RUL's median [s of operating time; None: a
        RUL without a band, the median is ``rul_p5``] and ``law_past_eol``: the wear law
        fitted to the measurements has crossed u_eol in 95 % of its draws
        (:meth:`~gear_phm.prognostics.predictor.RulPredictor.law_past_eol`), which also enters end
        of life (the filter's u lags accelerating wear that its measurements show).
        ``u_aiding``: u as the aiding windows read it [-], for the "now self-locking" WARN
        (with ``watch_self_locking``; NaN: not known).
        """
        median = rul_p5 if rul_median is None else rul_median
        filter_level, filter_reason = filter_check
        if not math.isfinite(u):
            filter_level, filter_reason = ERROR, 'filter lost the signal: u is not finite'
        latch = self.latches
        lost = latch['lost'].update(t, filter_level == ERROR, filter_level == ERROR)
        mismatch = latch['mismatch'].update(t, filter_level >= WARN, filter_level >= WARN)
        sigma = u_sigma if math.isfinite(u_sigma) and u_sigma > 0.0 else 0.0
        if math.isnan(self.eta_healthy) and filter_level != ERROR \
                and math.isfinite(eta_opposing) and math.isfinite(u_sigma) \
                and u_sigma <= HEALTHY_SETTLED_SHARE * (self.u_eol - u):
            self._learn(eta_opposing)
        eol = latch['eol'].update(t, u - EOL_Z * sigma >= self.u_eol or law_past_eol,
                                  u >= self.u_clear or law_past_eol)
        # NaN thresholds (not learned yet) compare False: no efficiency WARN
        eta = latch['eta'].update(t, eta_opposing < self.eta_warn, eta_opposing < self.eta_clear)
        rul = latch['rul'].update(t, median < self.warn_horizon, rul_p5 < self.rul_clear)
        watch = self.watch_self_locking and math.isfinite(u_aiding)
        locked = latch['locked'].update(
            t, watch and u_aiding - EOL_Z * sigma >= U_SELF_LOCKING,
            watch and u_aiding >= U_SELF_LOCKING * (1.0 - self.level_hysteresis))
        errors = []
        if eol:
            what = ('end of life (self_locking, must_back_drive): now self-locking, cannot be '
                    'back-driven' if self.eol_reason == 'self_locking'
                    else f'end of life ({self.eol_reason})')
            if u >= self.u_eol:
                errors.append(f'{what}: u {u:.4g} >= u_eol {self.u_eol:.4g}')
            elif law_past_eol:
                errors.append(f'{what}: the wear law of the measurements is past u_eol '
                              f'{self.u_eol:.4g} (95 % of its draws; the filter estimate u '
                              f'{u:.4g})')
            else:
                errors.append(f'{what}: u {u:.4g} reached u_eol {self.u_eol:.4g} '
                              f'(clears below {self.u_clear:.4g})')
        if lost:
            errors.append(filter_reason if filter_level == ERROR
                          else 'filter lost the signal (clearing)')
        if errors:
            return ERROR, '; '.join(errors)
        warnings = []
        if locked:
            warnings.append(f'now self-locking: cannot be back-driven (aiding reading u '
                            f'{u_aiding:.4g} >= {U_SELF_LOCKING:g}, eta_I <= 0)'
                            if u_aiding >= U_SELF_LOCKING
                            else f'now self-locking: cannot be back-driven (clearing, aiding '
                                 f'reading u {u_aiding:.4g})')
        if rul:
            warnings.append(f'RUL {median:.4g} s of operation < {self.warn_horizon:.4g} s'
                            if median < self.warn_horizon
                            else f'RUL {median:.4g} s of operation, p5 {rul_p5:.4g} s (WARN '
                                 f'while the median is below {self.warn_horizon:.4g} s, '
                                 f'clears when p5 is above {self.rul_clear:.4g} s)')
        if eta:
            warnings.append(f'eta_D {eta_opposing:.4g} < {self.eta_warn:.4g}'
                            if eta_opposing < self.eta_warn
                            else f'eta_D {eta_opposing:.4g} (WARN below {self.eta_warn:.4g}, '
                                 f'clears above {self.eta_clear:.4g})')
        if mismatch:
            warnings.append(filter_reason if filter_level >= WARN
                            else 'model mismatch (clearing)')
        if warnings:
            return WARN, '; '.join(warnings)
        return OK, 'ok'


__all__ = ['DivergenceDetector', 'Latch', 'LevelTracker', 'chi_square_mean_bound']
