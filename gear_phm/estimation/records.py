"""The estimator's records: a sample in, an update out. No ROS, SI units.

A sample in is a :class:`JointSample`, an update out a :class:`FrictionEstimate`.
"""
from __future__ import annotations

from dataclasses import dataclass
import math


@dataclass(frozen=True, slots=True)
class JointSample:
    """One synchronised sample of both shafts. Angles [rad], speeds [rad/s], torques [N m]."""

    stamp_ns: int
    motor_position: float
    motor_velocity: float
    motor_effort: float
    load_position: float
    load_velocity: float
    load_effort: float

    @property
    def t(self) -> float:
        """Sample time [s]."""
        return self.stamp_ns * 1e-9


@dataclass(frozen=True, slots=True)
class FrictionEstimate:
    """The posterior on x = [u, du/dt] at the newest sample it used, with its evidence.

    ``stamp_ns`` is that sample's stamp [ns]; u [-], rate du/dt [1/s]; ``covariance`` is
    (P_uu, P_ur, P_rr) [-, 1/s, 1/s^2]; ``eta_opposing``/``eta_aiding`` [-] are eqs 10/12 at
    u plus each direction's learned bias (its windows' reading; the bias is 0 without a
    mismatch between directions); ``measured_efficiency`` [-] is the newest window's (NaN
    before the first);
    ``innovation`` [-], its variance ``innovation_variance`` S and ``nis`` come from the last
    filter update; ``samples_used``/``samples_rejected`` count samples so far;
    ``power_flow`` is the code (:mod:`gear_phm.models.power_flow`) of the newest sample;
    ``samples_missing`` counts the samples the stamps show lost so far; ``process_noise``
    [1/s^3] is the filter's current (adapted) q and ``mismatch_variance`` [-] the learned
    model-mismatch variance of (opposing, aiding) windows; ``operating_time`` [s] is the
    cumulative operating time (time with motion, across recordings and restarts) at the
    stamp: the time axis of the filter's rate and of the RUL (NaN when unknown, e.g. read
    from an older recording; users then fall back to the stamp time). ``measurement`` [-]
    and ``measurement_variance`` [-^2]: the pseudo-measurement of u (eq 13 or its aiding
    counterpart) that the filter fused for this estimate, carried from its window's mid-time
    to this estimate's operating time with the filter's rate, and its variance (window noise
    plus learned mismatch); NaN on estimates without a new window. The RUL's wear history
    fits these, not the posteriors (docs/prognostics.md). ``direction_offset`` d [-]: the
    filter's learned offset between the load directions (aiding windows' reading of u minus
    the opposing ones'); ``measurement_direction`` h [-]: the measurement's share of it (-1/2
    for an opposing window, +1/2 for an aiding one, their inverse-variance mean for windows
    merged into one estimate); ``measurement_bias`` [-]: the bias h d subtracted from the
    measurement with d as it was then. With the offset learned since, the measurement reads
    ``measurement + measurement_bias - h d`` (the RUL's history re-corrects it so,
    :class:`~gear_phm.prognostics.history.WearHistory`). With the no-load model
    (:mod:`gear_phm.estimation.no_load`): ``no_load_torque`` [N m] at the motor at the
    reference speed, its std dev ``no_load_sigma`` [N m], and ``total_efficiency`` [-] at the
    rated point (NaN without one); NaN without the model.
    """

    stamp_ns: int
    u: float
    rate: float
    covariance: tuple[float, float, float]
    eta_opposing: float = math.nan
    eta_aiding: float = math.nan
    measured_efficiency: float = math.nan
    innovation: float = math.nan
    innovation_variance: float = math.nan
    nis: float = math.nan
    samples_used: int = 0
    samples_rejected: int = 0
    power_flow: int = 0
    samples_missing: int = 0
    process_noise: float = math.nan
    mismatch_variance: tuple[float, float] = (math.nan, math.nan)
    operating_time: float = math.nan
    measurement: float = math.nan
    measurement_variance: float = math.nan
    direction_offset: float = math.nan
    measurement_direction: float = math.nan
    measurement_bias: float = math.nan
    no_load_torque: float = math.nan
    no_load_sigma: float = math.nan
    total_efficiency: float = math.nan

    @property
    def t(self) -> float:
        """Time of the newest sample the estimate used [s]."""
        return self.stamp_ns * 1e-9

    @property
    def u_sigma(self) -> float:
        """Return the standard deviation of u [-]."""
        return math.sqrt(max(self.covariance[0], 0.0))

    @property
    def p_uu(self) -> float:
        """Variance of u [-] (``covariance[0]``)."""
        return self.covariance[0]

    @property
    def p_ur(self) -> float:
        """Covariance of u and its rate [1/s] (``covariance[1]``)."""
        return self.covariance[1]

    @property
    def p_rr(self) -> float:
        """Variance of the rate [1/s^2] (``covariance[2]``)."""
        return self.covariance[2]
