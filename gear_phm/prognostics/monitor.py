"""ROS-free health monitor shared by the diagnostics node and ``gear-phm analyze``.

Feed every estimator update to :meth:`HealthMonitor.on_estimate` (it returns the
:class:`HealthStatus` of that update); turn a status into the published records with
:meth:`HealthStatus.outputs`. STALE is applied by the caller's clock with
:meth:`HealthStatus.as_stale` / :func:`gear_phm.prognostics.health.is_stale`.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
import math
from typing import Any

from gear_phm.interfaces import (DiagnosticsOut, format_value, HEALTH_EFFICIENCY, HEALTH_RUL,
                                 LEVEL_NAMES, STALE, StatusOut, Vector3Out)
from gear_phm.models import eta_aiding, eta_opposing
from gear_phm.prognostics.config import HealthConfig
from gear_phm.prognostics.end_of_life import end_of_life_u
from gear_phm.prognostics.health import DivergenceMonitor, health_level
from gear_phm.prognostics.rul import RulEstimate, RulPredictor, Trend, TrendDetector

#: KeyValue keys of the /diagnostics status, in this order (test benches rely on them).
STATUS_KEYS = ('u', 'u_sigma', 'eta_opposing', 'eta_aiding', 'rul_s', 'rul_p5_s', 'rul_p95_s',
               'power_flow', 'samples_used', 'samples_rejected')


@dataclass(frozen=True)
class Estimate:
    """One estimator update (the five estimator topics with one stamp), SI units.

    u [-], rate du/dt [1/s], covariance (P_uu, P_ur, P_rr), efficiencies [-], innovation [-],
    its variance S [-], NIS [-], counts, power-flow code of the newest sample.
    """

    stamp_ns: int
    u: float
    rate: float
    covariance: tuple[float, float, float]
    eta_opposing: float = math.nan
    eta_aiding: float = math.nan
    innovation: float = math.nan
    innovation_variance: float = math.nan
    nis: float = math.nan
    samples_used: int = 0
    samples_rejected: int = 0
    power_flow: int = 0

    @property
    def t(self) -> float:
        """Time of the newest sample the estimate used [s]."""
        return self.stamp_ns * 1e-9

    @classmethod
    def from_vectors(cls, stamp_ns: int, friction: Any, covariance: Any,
                     efficiency: Any = None, innovation: Any = None,
                     counts: Any = None) -> Estimate:
        """Build from the Vector3 fields (objects with .x .y .z) of the estimator topics."""
        nan3 = (math.nan, math.nan, math.nan)

        def xyz(v: Any, default: tuple[float, float, float] = nan3
                ) -> tuple[float, float, float]:
            return default if v is None else (float(v.x), float(v.y), float(v.z))

        fx, fy, _ = xyz(friction)
        eff, inn = xyz(efficiency), xyz(innovation)
        cnt = xyz(counts, (0.0, 0.0, 0.0))
        return cls(int(stamp_ns), fx, fy, xyz(covariance), eff[0], eff[1], inn[0], inn[1],
                   inn[2], _count(cnt[0]), _count(cnt[1]), _count(cnt[2]))


def _count(value: float) -> int:
    return int(value) if math.isfinite(value) else 0


@dataclass(frozen=True)
class HealthStatus:
    """Health of one estimate: level (OK/WARN/ERROR/STALE), message and the reported values."""

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

    def key_values(self) -> tuple[tuple[str, str], ...]:
        """KeyValue pairs with exactly :data:`STATUS_KEYS` (decimal strings, ``inf``)."""
        values = (self.u, self.u_sigma, self.eta_opposing, self.eta_aiding, self.rul.median,
                  self.rul.p5, self.rul.p95, self.power_flow, self.samples_used,
                  self.samples_rejected)
        return tuple((key, format_value(value)) for key, value in zip(STATUS_KEYS, values))

    def as_stale(self, silence: float) -> HealthStatus:
        """This status turned STALE after ``silence`` [s] without input."""
        return replace(self, level=STALE,
                       message=f'no estimator input for {silence:.3g} s (last: {self.message})')

    def outputs(self, transmission_name: str, hardware_id: str
                ) -> tuple[DiagnosticsOut, Vector3Out, Vector3Out]:
        """/diagnostics array, gear_phm/health/rul and gear_phm/health/efficiency records."""
        return (self.diagnostics(transmission_name, hardware_id), *self.vectors())

    def diagnostics(self, transmission_name: str, hardware_id: str) -> DiagnosticsOut:
        """The /diagnostics array of this status alone."""
        status = StatusOut(self.level, f'gear_phm: {transmission_name}', self.message,
                           hardware_id, self.key_values())
        return DiagnosticsOut(self.stamp_ns, (status,))

    def vectors(self) -> tuple[Vector3Out, Vector3Out]:
        """gear_phm/health/rul and gear_phm/health/efficiency records alone (no text
        formatting: the per-update path; /diagnostics is built at its own rate)."""
        return (Vector3Out(HEALTH_RUL, self.stamp_ns, self.rul.median, self.rul.p5,
                           self.rul.p95),
                Vector3Out(HEALTH_EFFICIENCY, self.stamp_ns, self.eta_opposing,
                           self.eta_aiding, float(self.level)))

    @property
    def level_name(self) -> str:
        return LEVEL_NAMES[self.level]


def waiting_status(stamp_ns: int, u_eol: float) -> HealthStatus:
    """STALE status before any estimate arrived."""
    nan = math.nan
    return HealthStatus(stamp_ns, STALE, 'waiting for estimator output', nan, nan, nan, nan,
                        RulEstimate(nan, nan, nan, 'none'), 0, 0, 0, u_eol, Trend())


class HealthMonitor:
    """End of life, RUL, divergence and level for a stream of estimates (see module doc)."""

    def __init__(self, config: HealthConfig) -> None:
        self.config = config
        self.u_eol, self.eol_reason = end_of_life_u(
            config.ratio, config.eta_opposing_min, config.self_locking_eol, config.u_max)
        self.predictor = RulPredictor(self.u_eol, config.detect_z, int(config.mc_samples),
                                      int(config.seed))
        self.trend_detector = TrendDetector(config.trend_window, config.accel_z,
                                            config.min_growth)
        self.divergence = DivergenceMonitor(int(config.nis_window), config.nis_probability,
                                            config.max_u_sigma)
        self.latest: HealthStatus | None = None
        self.rejected: dict[str, int] = {}

    def _trend(self) -> Trend:
        if self.config.trend == 'linear':
            return Trend()
        fitted = self.trend_detector.fit()
        if self.config.trend == 'exponential' and fitted.model != 'exponential':
            return Trend('exponential', max(fitted.k, 0.0), fitted.k_sigma,
                         fitted.curvature_z, fitted.growth)
        return fitted

    def on_estimate(self, estimate: Estimate) -> HealthStatus | None:
        """Process one update; None (counted in ``rejected``) if it is unusable."""
        p_uu = estimate.covariance[0]
        if not (math.isfinite(estimate.u) and math.isfinite(estimate.rate)
                and all(math.isfinite(p) for p in estimate.covariance)):
            self.rejected['non_finite_estimate'] = self.rejected.get('non_finite_estimate',
                                                                     0) + 1
            return None
        if self.latest is not None and estimate.stamp_ns < self.latest.stamp_ns:
            self.trend_detector.reset()                    # replay restarted
            self.divergence.reset()
        u_sigma = math.sqrt(max(p_uu, 0.0))
        if not math.isfinite(estimate.eta_opposing) or not math.isfinite(estimate.eta_aiding):
            estimate = replace(estimate,
                               eta_opposing=float(eta_opposing(estimate.u, self.config.ratio)),
                               eta_aiding=float(eta_aiding(estimate.u, self.config.ratio)))
        self.trend_detector.add(estimate.t, estimate.u, p_uu)
        divergence = self.divergence.update(estimate.innovation, estimate.innovation_variance,
                                            estimate.nis, u_sigma)
        trend = self._trend()
        rul = self.predictor.predict_from(estimate.u, estimate.rate, *estimate.covariance,
                                          trend)
        level, message = health_level(estimate.u, self.u_eol, self.eol_reason,
                                      estimate.eta_opposing, self.config.eta_warn, rul.p5,
                                      self.config.warn_horizon, divergence)
        if level == 0 and rul.model != 'none':
            message = f'ok; {rul.model} trend, RUL {rul.median:.4g} s'
        self.latest = HealthStatus(estimate.stamp_ns, level, message, estimate.u, u_sigma,
                                   estimate.eta_opposing, estimate.eta_aiding, rul,
                                   estimate.power_flow, estimate.samples_used,
                                   estimate.samples_rejected, self.u_eol, trend)
        return self.latest
