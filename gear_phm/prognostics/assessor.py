"""Health assessment of a stream of friction estimates.

Shared by the diagnostics node and ``gear-phm analyze`` (no ROS).

Feed every :class:`~gear_phm.estimation.FrictionEstimate` to :meth:`HealthAssessor.on_estimate`;
it returns the :class:`HealthState` of that update: end of life, RUL with its 5 %/95 % bounds,
divergence and the level. STALE is applied by the caller's clock with
:meth:`HealthState.as_stale`.

Time bases: wear accrues while the gearbox moves, so the wear history and its RUL
run on the estimates' operating time (``FrictionEstimate.operating_time``; an estimate without
it, e.g. from an older recording, uses its stamp time). That RUL, ``rul_operating``, is in
seconds of operation, and the level's WARN horizon applies to it. ``rul`` is the same RUL in
elapsed (stamp) time at the utilisation seen so far: rul_operating / utilisation, utilisation
= operating time / elapsed stamp time accumulated over the history
(:class:`~gear_phm.prognostics.history.Utilisation`), about 1 with continuous motion.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
import math
from typing import Any

import numpy as np

from gear_phm.estimation.records import FrictionEstimate
from gear_phm.models.lever import efficiencies, efficiencies_array, readings, readings_array
from gear_phm.parameters import refuse_read_only_changes
from gear_phm.persistence import decode_float, encode_float
from gear_phm.prognostics.config import HealthConfig, PARAMETERS
from gear_phm.prognostics.end_of_life import (end_of_life_thresholds, healthy_self_locking,
                                              u_accuracy)
from gear_phm.prognostics.fits import (frozen_instance, ShapePrior, Trend, trend_from_state,
                                       trend_to_state)
from gear_phm.prognostics.health import DivergenceDetector, EOL_Z, LevelTracker
from gear_phm.prognostics.history import Utilisation
from gear_phm.prognostics.predictor import RulEstimate, RulPredictor
from gear_phm.status import ERROR, OK, STALE

#: |eta_D(u, own ratio) - reported eta_D| above which the two ratios differ [-]; float noise
#: of eq 10 is ~1e-16, a 0.1 % ratio error at u = 0.05 moves eta_D by ~4e-5.
RATIO_TOLERANCE = 1e-9
#: The settings the RUL fit depends on besides end of life: a change refits
#: (:meth:`HealthAssessor.reconfigure`).
_FIT_SETTINGS = ('trend', 'detect_z', 'eta_accuracy', 'mc_samples', 'seed')


@dataclass(frozen=True)
class HealthState:
    """Health at one estimate: level (OK/WARN/ERROR/STALE) and its reason (``message``).

    Also the estimate's u [-] and sigma, efficiencies [-], RUL [s] with bounds, power-flow code,
    sample counts, the end-of-life u [-] and the trend used.

    ``rul_operating`` is the RUL in seconds of operation, ``rul`` the same in elapsed (stamp)
    time, ``rul_operating`` / ``utilisation`` [-]; ``operating_time`` [s] is the estimate's
    (NaN if it had none); see the module docstring. ``eta_healthy`` [-] is the healthy eta_D
    learned at the start and ``eta_warn`` [-] the WARN efficiency in force (NaN: not learned
    yet; :class:`~gear_phm.prognostics.health.LevelTracker`). ``eol_rule`` names the
    end-of-life rule that sets ``u_eol`` (``eta_opposing_min``, ``self_locking`` or
    ``u_max``; '' in a state from before it was kept).
    """

    stamp_ns: int
    level: int
    message: str
    u: float
    u_sigma: float
    eta_opposing: float
    eta_aiding: float
    rul: RulEstimate
    power_flow: int
    samples_used: int
    samples_rejected: int
    u_eol: float
    trend: Trend
    samples_missing: int = 0
    rul_operating: RulEstimate = RulEstimate(math.nan, math.nan, math.nan, 'none')
    operating_time: float = math.nan
    utilisation: float = math.nan
    eta_healthy: float = math.nan
    eta_warn: float = math.nan
    eol_rule: str = ''

    def as_stale(self, silence: float) -> HealthState:
        """Return this status turned STALE after ``silence`` [s] without input."""
        return replace(self, level=STALE,
                       message=f'no estimator input for {silence:.3g} s (last: {self.message})')


def waiting_state(stamp_ns: int, u_eol: float, eol_rule: str = '') -> HealthState:
    """OK state before any estimate arrived: nothing is known to be wrong yet."""
    nan = math.nan
    return HealthState(stamp_ns, OK, 'waiting for data', nan, nan, nan, nan,
                       RulEstimate(nan, nan, nan, 'none'), 0, 0, 0, u_eol, Trend(),
                       eol_rule=eol_rule)


_RUL_FIELDS = ('median', 'p5', 'p95')
_STATE_FLOATS = ('u', 'u_sigma', 'eta_opposing', 'eta_aiding', 'u_eol', 'operating_time',
                 'utilisation')
#: Added later: absent in an older state file (NaN then).
_STATE_FLOATS_LATER = ('eta_healthy', 'eta_warn')
_STATE_INTS = ('stamp_ns', 'level', 'power_flow', 'samples_used', 'samples_rejected',
               'samples_missing')


def health_state_to_state(state: HealthState) -> dict[str, Any]:
    """Return a :class:`HealthState` as a JSON-safe dict."""
    out: dict[str, Any] = {key: int(getattr(state, key)) for key in _STATE_INTS}
    out.update({key: encode_float(getattr(state, key))
                for key in _STATE_FLOATS + _STATE_FLOATS_LATER})
    out['message'] = state.message
    out['eol_rule'] = state.eol_rule
    for name in ('rul', 'rul_operating'):
        rul = getattr(state, name)
        out[name] = {key: encode_float(getattr(rul, key)) for key in _RUL_FIELDS}
        out[name]['model'] = rul.model
    out['trend'] = trend_to_state(state.trend)
    return out


def health_state_from_state(state: dict[str, Any]) -> HealthState:
    """Inverse of :func:`health_state_to_state`; KeyError/ValueError/TypeError if bad."""
    values: dict[str, Any] = {key: int(state[key]) for key in _STATE_INTS}
    values.update({key: decode_float(state[key]) for key in _STATE_FLOATS})
    values.update({key: decode_float(state.get(key, 'nan')) for key in _STATE_FLOATS_LATER})
    for name in ('rul', 'rul_operating'):
        rul = state[name]
        median, p5, p95 = (decode_float(rul[k]) for k in _RUL_FIELDS)
        values[name] = RulEstimate(median, p5, p95, str(rul['model']))
    return HealthState(message=str(state['message']), trend=trend_from_state(state['trend']),
                       eol_rule=str(state.get('eol_rule', '')), **values)


class HealthAssessor:
    """End of life, RUL, divergence and level for a stream of estimates (see module doc)."""

    def __init__(self, config: HealthConfig, prior: ShapePrior | None = None) -> None:
        """``prior``: a population prior on the wear law's shape (:class:`ShapePrior`)."""
        self.config = config
        #: Whether the gearbox is self-locking when healthy (None: not known yet,
        #: :func:`~gear_phm.prognostics.end_of_life.healthy_self_locking`).
        self.self_locking_when_healthy: bool | None = None
        self.u_eol, self.eol_reason = self._end_of_life()
        self.predictor = RulPredictor(
            self.u_eol, detect_z=config.detect_z, mc_samples=int(config.mc_samples),
            seed=int(config.seed), trend=config.trend, prior=prior,
            u_systematic=u_accuracy(self.u_eol, config.ratio, config.eta_accuracy))
        self.divergence = DivergenceDetector(
            nis_window=config.nis_window, nis_probability=config.nis_probability,
            max_u_sigma=config.max_u_sigma, nis_lost=config.nis_lost)
        self.levels = LevelTracker(self.u_eol, self.eol_reason, config.effective_eta_warn(),
                                   config.warn_horizon, level_hysteresis=config.level_hysteresis,
                                   level_dwell=config.level_dwell,
                                   level_clear_dwell=config.level_clear_dwell,
                                   eta_opposing_min=config.eta_opposing_min)
        self.utilisation = Utilisation(config.utilisation_window)
        self.latest: HealthState | None = None
        self.rejected: dict[str, int] = {}

    def _end_of_life(self) -> tuple[float, str]:
        """Return the end-of-life u [-] and its rule's name in force.

        The configured criteria; self-locking (u = 1) only with ``must_back_drive`` and once
        the gearbox is known to back-drive when healthy: a gearbox self-locking by design has
        no end of life by it, and one not judged yet none either.
        """
        config = self.config
        thresholds = end_of_life_thresholds(
            config.ratio, config.eta_opposing_min,
            config.must_back_drive and self.self_locking_when_healthy is False, config.u_max)
        name = min(thresholds, key=thresholds.__getitem__)
        return thresholds[name], name

    def _learn_self_locking(self, locking: bool | None) -> None:
        """Record whether the healthy gearbox self-locks and apply the end of life it gives."""
        self.self_locking_when_healthy = locking
        self.levels.watch_self_locking = locking is False
        u_eol, reason = self._end_of_life()
        if (u_eol, reason) != (self.u_eol, self.eol_reason):
            self.u_eol, self.eol_reason = u_eol, reason
            self.levels.set_end_of_life(u_eol, reason)
            self.predictor.u_systematic = u_accuracy(u_eol, self.config.ratio,
                                                     self.config.eta_accuracy)
            self.predictor.refit_soon()

    def on_estimate(self, estimate: FrictionEstimate) -> HealthState | None:
        """Process one update; None (counted in ``rejected``) if it is unusable."""
        return self.on_estimates([estimate])[0]

    def on_estimates(self, estimates: Sequence[FrictionEstimate]
                     ) -> list[HealthState | None]:
        """:meth:`on_estimate` of each update in order, the same states.

        The per-update quantities that depend on the update alone (u's sigma, eq 13's
        readings of the reported efficiencies, the ratio check) are computed for the whole
        sequence at once, with numpy's element-wise operations (the same float operations);
        the history, the fit, the NIS window and the level latches then follow the updates
        one by one.
        """
        n = len(estimates)
        if n == 0:
            return []
        ratio = self.config.ratio
        columns = np.array([(e.u, e.rate, *e.covariance, e.eta_opposing, e.eta_aiding)
                            for e in estimates], dtype=float).reshape(n, 7)
        usable = np.isfinite(columns[:, :5]).all(axis=1).tolist()
        sigmas = np.sqrt(np.maximum(columns[:, 2], 0.0)).tolist()
        u_d, u_i = readings_array(columns[:, 5], columns[:, 6], ratio)
        centre = 0.5 * (u_d + u_i)
        with np.errstate(invalid='ignore'):
            expected = efficiencies_array(columns[:, 0], ratio)[0]
            reported = np.where(np.isfinite(centre), efficiencies_array(centre, ratio)[0],
                                columns[:, 5])
            suspect = (np.abs(expected - reported) > RATIO_TOLERANCE).tolist()
        readings_of = list(zip(u_d.tolist(), u_i.tolist()))
        states: list[HealthState | None] = []
        for i, estimate in enumerate(estimates):
            if usable[i]:
                states.append(self._assess(estimate, sigmas[i], readings_of[i], suspect[i]))
            else:
                self._reject('non_finite_estimate')
                states.append(None)
        return states

    def _reject(self, reason: str) -> None:
        """Count an unusable update."""
        self.rejected[reason] = self.rejected.get(reason, 0) + 1

    def _assess(self, estimate: FrictionEstimate, u_sigma: float,
                read: tuple[float, float], suspect: bool) -> HealthState:
        """Assess one finite update (:meth:`on_estimates`).

        ``u_sigma`` [-], ``read`` eq 13's readings (u_D, u_I) [-] of its efficiencies, ``suspect``:
        its efficiencies may not match this assessor's ratio (:meth:`_ratio_mismatch` decides).
        """
        estimate, read, suspect = self._prepared(estimate, read, suspect)
        operating = self._operating_time(estimate)
        predictor = self.predictor
        # end of life on the reading its criterion is about (eta_D: the opposing windows')
        u = estimate.u
        t = estimate.stamp_ns * 1e-9                # estimate.t
        u_d, u_i = read
        if self.self_locking_when_healthy is None and u_sigma <= self.config.max_u_sigma:
            self._learn_self_locking(healthy_self_locking(u_i, u_sigma))
        reading = self._reading_offset(u, u_d, u_i)
        predictor.u_eol = self.u_eol - reading
        self._add_to_history(estimate, operating)
        self.utilisation.add(t, operating)
        filter_check = self.divergence.update(estimate.innovation,
                                              estimate.innovation_variance, estimate.nis,
                                              u_sigma)
        # worn (RUL 0) on u's lower 95 % bound, as end of life is entered: an unsettled
        # filter's first u above u_eol is no end of life (random healthy lives 61 and 45 read
        # RUL 0 at 1-2 s, from the initial state, where u_eol is near the healthy u)
        rul_operating = predictor.predict(operating, u - EOL_Z * u_sigma)
        utilisation = self.utilisation.fraction
        rul = rul_operating.in_elapsed_time(self.utilisation)
        levels = self.levels
        level, message = levels.update(t, u + reading, estimate.eta_opposing,
                                       rul_operating.p5, filter_check, u_sigma,
                                       rul_operating.median, predictor.law_past_eol(operating),
                                       u_i)
        if level == 0 and rul.model != 'none':
            recent = (rul_operating.median / rul.median
                      if 0.0 < rul.median < math.inf else utilisation)
            message = (f'ok; {rul.model} trend, RUL {rul_operating.median:.4g} s of operation '
                       f'({rul.median:.4g} s at utilisation {recent:.3g})')
        if level == 0 and self.self_locking_when_healthy:
            message += '; self-locking when healthy (by design): no end of life by it'
        mismatch = self._ratio_mismatch(estimate, 0.5 * (u_d + u_i)) if suspect else ''
        if mismatch:
            level, message = ERROR, mismatch
        self.latest = frozen_instance(HealthState, {
            'stamp_ns': estimate.stamp_ns, 'level': level, 'message': message, 'u': u,
            'u_sigma': u_sigma, 'eta_opposing': estimate.eta_opposing,
            'eta_aiding': estimate.eta_aiding, 'rul': rul, 'power_flow': estimate.power_flow,
            'samples_used': estimate.samples_used,
            'samples_rejected': estimate.samples_rejected, 'u_eol': self.u_eol,
            'trend': predictor.trend, 'samples_missing': estimate.samples_missing,
            'rul_operating': rul_operating,
            'operating_time': operating if self._on_operating_time(estimate) else math.nan,
            'utilisation': utilisation, 'eta_healthy': levels.eta_healthy,
            'eta_warn': levels.eta_warn, 'eol_rule': self.eol_reason})
        return self.latest

    def _prepared(self, estimate: FrictionEstimate, read: tuple[float, float], suspect: bool
                  ) -> tuple[FrictionEstimate, tuple[float, float], bool]:
        """Return the update as assessed, and restart or move the history where it must.

        A replay that restarted (an earlier stamp) restarts the assessment; an estimate
        without efficiencies gets eqs 10 and 12's at its u (then ``suspect``); a stream that
        gained operating time moves the history onto that axis.
        """
        if self.latest is not None and estimate.stamp_ns < self.latest.stamp_ns:
            self.predictor.reset()                         # replay restarted
            self.divergence.reset()
            self.levels.reset()
            self.utilisation.reset()
            self._learn_self_locking(None)
        if not math.isfinite(estimate.eta_opposing) or not math.isfinite(estimate.eta_aiding):
            # an estimate without efficiencies (an older recording): eqs 10 and 12 at u
            eta_d, eta_i = efficiencies(estimate.u, self.config.ratio)
            estimate = replace(estimate, eta_opposing=eta_d, eta_aiding=eta_i)
            read = readings(eta_d, eta_i, self.config.ratio)
            suspect = True
        if math.isfinite(estimate.operating_time) and self.latest is not None \
                and not math.isfinite(self.latest.operating_time):
            # the stream gained operating time (its first updates came without: the topic
            # matched late, or a newer estimator): the history so far moves onto the
            # operating axis, as if the gearbox had moved throughout it; the utilisation is
            # measured from here on (taking that motion as real made a live node's 0.5 come
            # out 0.5013 when its first update lost its operating time to a callback race)
            offset = estimate.operating_time - estimate.t
            self.predictor.shift(offset)
            self.utilisation.reset()
        return estimate, read, suspect

    def _add_to_history(self, estimate: FrictionEstimate, operating: float) -> None:
        """Add the update's measurement (or, without any, its posterior) to the RUL's history."""
        predictor = self.predictor
        measurement = estimate.measurement
        if math.isfinite(estimate.direction_offset):
            # the history's measurements, each with the offset between the load directions
            # learned so far (gear_phm.prognostics.history)
            predictor.history.offset = estimate.direction_offset
        if math.isfinite(measurement) and estimate.measurement_variance > 0.0:
            # the window's measurement: independent of the others, no filter lag
            predictor.add(operating, measurement, estimate.measurement_variance,
                          independent=True, direction=estimate.measurement_direction,
                          bias=estimate.measurement_bias)
        elif not predictor.history.independent:
            # a stream without measurements (an older estimator or recording): posteriors
            predictor.add(operating, estimate.u, estimate.covariance[0])

    def _reading_offset(self, u: float, u_d: float, u_i: float) -> float:
        """Return the end-of-life criterion's reading of u minus u [-] (0 without one).

        The estimator reports each efficiency as its direction's windows read it (u plus the
        direction's learned bias, :meth:`~gear_phm.estimation.kalman.FrictionFilter.
        direction_bias`); u itself is the midpoint of the two. ``eta_opposing_min`` is about
        the opposing windows' reading, self-locking about the aiding ones', ``u_max`` about u.
        On a plant without mismatch (and for an older stream) the offset is 0. ``u_d``,
        ``u_i``: the readings of u that the reported eta_D and eta_I give (eq 13).
        """
        if self.eol_reason == 'eta_opposing_min':
            read = u_d
        elif self.eol_reason == 'self_locking':
            read = u_i
        else:
            return 0.0
        offset = read - u
        return offset if math.isfinite(offset) else 0.0

    def _on_operating_time(self, estimate: FrictionEstimate) -> bool:
        """Whether the stream carries operating time: this estimate or the latest state."""
        return math.isfinite(estimate.operating_time) or (
            self.latest is not None and math.isfinite(self.latest.operating_time))

    def _operating_time(self, estimate: FrictionEstimate) -> float:
        """Return the wear history's time [s] of ``estimate``.

        Its operating time; without one, the latest state's in a stream that has it (an
        update assembled before its operating time arrived, e.g. the first after a restart:
        no operation assumed since), else the stamp (an older estimator or recording).
        """
        if math.isfinite(estimate.operating_time):
            return estimate.operating_time
        if self.latest is not None and math.isfinite(self.latest.operating_time):
            return self.latest.operating_time
        return estimate.t

    def reconfigure(self, config: HealthConfig) -> None:
        """Apply new settings and keep what was learned.

        The RUL history and fit, the utilisation, the NIS window, the level latches, the
        learned healthy eta_D and the latest state go on (:meth:`to_state`, rebuilt with
        ``config``, :meth:`from_state`); end of life, the thresholds, dwells and windows are
        the new ones from the next estimate on (the latest state shows the new end-of-life u
        and eta_warn at once), an eta_warn left NaN is derived anew from the learned
        eta_healthy, and a change of what the fit depends on (end of life, trend,
        detect_z, eta_accuracy, the draws) refits at the next estimate. Raises ValueError
        when the ratio differs: the history is of one gearbox (:meth:`reset` instead).
        """
        old = self.config
        refuse_read_only_changes(PARAMETERS, old.as_dict(), config.as_dict(),
                                 'start a new assessor')
        fresh = HealthAssessor(config, self.predictor.prior)
        fresh.from_state(self.to_state())
        if any(getattr(old, name) != getattr(config, name) for name in _FIT_SETTINGS) \
                or fresh.u_eol != self.u_eol:
            fresh.predictor.refit_soon()
        if fresh.latest is not None:        # the status shows the thresholds in force
            fresh.latest = replace(fresh.latest, u_eol=fresh.u_eol,
                                   eta_warn=fresh.levels.eta_warn)
        self.config, self.u_eol, self.eol_reason = config, fresh.u_eol, fresh.eol_reason
        self.predictor, self.divergence, self.levels = (fresh.predictor, fresh.divergence,
                                                        fresh.levels)
        self.utilisation, self.latest, self.rejected = (fresh.utilisation, fresh.latest,
                                                        fresh.rejected)
        self.self_locking_when_healthy = fresh.self_locking_when_healthy

    def reset(self) -> None:
        """Forget what was learned, on purpose (a new gearbox on the rig).

        The RUL history and fit, the utilisation, the NIS window, the level latches, the
        healthy eta_D and the latest state; the rejected counts stay.
        """
        self.predictor.reset()
        self.divergence.reset()
        self.levels.reset()
        self.utilisation.reset()
        self.latest = None

    def to_state(self) -> dict[str, Any]:
        """Return what a restart needs (JSON-safe, see :mod:`gear_phm.persistence`).

        The RUL history and fit (on operating time), the utilisation, the NIS window, the level
        latches and the latest state.
        """
        latest = self.latest
        return {'predictor': self.predictor.to_state(), 'divergence': self.divergence.to_state(),
                'levels': self.levels.to_state(), 'utilisation': self.utilisation.to_state(),
                'rejected': dict(self.rejected),
                'self_locking_when_healthy': self.self_locking_when_healthy,
                'latest': None if latest is None else health_state_to_state(latest)}

    def from_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`to_state` into an assessor of the same configuration.

        KeyError/ValueError/TypeError on a malformed dict (the assessor is then unchanged).
        """
        fresh = HealthAssessor(self.config, self.predictor.prior)
        fresh.predictor.from_state(state['predictor'])
        fresh.divergence.from_state(state['divergence'])
        fresh.levels.from_state(state['levels'])
        fresh.utilisation.from_state(state['utilisation'])
        rejected = {str(k): int(v) for k, v in dict(state['rejected']).items()}
        locking = state.get('self_locking_when_healthy')    # absent in an older file
        if locking is not None and not isinstance(locking, bool):
            raise TypeError(f'self_locking_when_healthy must be a bool or null, got {locking!r}')
        fresh._learn_self_locking(locking)
        latest = state['latest']
        self.latest = None if latest is None else health_state_from_state(latest)
        self.predictor, self.divergence, self.levels = (fresh.predictor, fresh.divergence,
                                                        fresh.levels)
        self.utilisation = fresh.utilisation
        self.rejected = rejected
        self.self_locking_when_healthy = fresh.self_locking_when_healthy
        self.u_eol, self.eol_reason = fresh.u_eol, fresh.eol_reason

    def _ratio_mismatch(self, estimate: FrictionEstimate, centre: float) -> str:
        """'' or why the estimator's ratio differs from this assessor's.

        The estimator reports eta_D and eta_I with its own ratio at u plus and minus its
        direction bias (0 on a plant without mismatch): with this assessor's ratio, eq 13
        must map them back to two readings whose midpoint is u. Eq 10 inverted for R gives
        the implied ratio R = u / (1 - eta_D (1 + u)) (exact without a bias). End of life is a
        u computed with this assessor's ratio, so two different ratios would put it at the
        wrong u, silently. Not decidable at u ~ 0, where eta_D = 1 for every R. ``centre``: the
        midpoint of the readings that eq 13 gives for the reported efficiencies.
        """
        ratio = self.config.ratio
        expected, _ = efficiencies(estimate.u, ratio)
        reported = efficiencies(centre, ratio)[0] if math.isfinite(centre) \
            else estimate.eta_opposing
        if not (math.isfinite(expected) and math.isfinite(reported)) \
                or abs(expected - reported) <= RATIO_TOLERANCE:
            return ''
        denominator = 1.0 - estimate.eta_opposing * (1.0 + estimate.u)
        implied = estimate.u / denominator if denominator != 0.0 else math.inf
        return (f"ratio mismatch: the estimator's efficiencies imply ratio {implied:.6g}, "
                f'the diagnostics ratio is {self.config.ratio:.6g}; set the same ratio on both')
