"""The Kalman filter on u and what corrects its measurements: inertia and no-load loss.

:class:`WindowFusion` turns each closed energy window into a pseudo-measurement of u
(:func:`~gear_phm.estimation.windows.to_measurement`), with the learned motor inertia
(:mod:`gear_phm.estimation.inertia`) and, with ``no_load_model``, the no-load loss
(:mod:`gear_phm.estimation.no_load`) removed as known before the window, and fuses it into the
filter (:mod:`gear_phm.estimation.kalman`). It makes the :class:`FrictionEstimate` of each
update and the :class:`~gear_phm.estimation.predictions.PredictionBase` of the estimates
published between two updates. The time axis (operating time), the stamps and the counters
of the samples are the pipeline's, passed in.
"""
from __future__ import annotations

from collections.abc import Callable
import math

from gear_phm.estimation.config import EstimatorConfig
from gear_phm.estimation.inertia import InertiaLearner
from gear_phm.estimation.kalman import Adaptation, FrictionFilter
from gear_phm.estimation.no_load import NoLoadBand, NoLoadLearner
from gear_phm.estimation.predictions import PredictionBase
from gear_phm.estimation.quality import DataQuality
from gear_phm.estimation.records import FrictionEstimate
from gear_phm.estimation.state import Carry
from gear_phm.estimation.windows import Measurement, to_measurement, Window
from gear_phm.models.lever import efficiencies
from gear_phm.models.power_flow import OPPOSING

#: The no-load filter's gains walk by this multiple of the wear rate (:meth:`_gain_rates`).
GAIN_RATE_MARGIN = 3.0

#: What :meth:`WindowFusion._measure` made of a window: the measurement (or why none), the
#: inertia correction and its variance, whether it may adapt the filter, and the no-load
#: energy and its variance.
_Measured = tuple[Measurement | str, tuple[float, float], bool, tuple[float, float]]


class WindowFusion:
    """The filter, the learned inertia and no-load loss; see the module docstring.

    ``last_eta``: the efficiency of the newest window fused (NaN before).
    """

    def __init__(self, config: EstimatorConfig) -> None:
        c = self.config = config
        self.filter = FrictionFilter(c.initial_u, c.initial_u_sigma, c.initial_rate_sigma,
                                     c.process_noise, c.gate_threshold,
                                     c.max_consecutive_gated, Adaptation(
                                         adaptive=c.adaptive, adapt_memory=c.adapt_memory,
                                         adapt_gain=c.adapt_gain, adapt_pull=c.adapt_pull,
                                         mismatch_memory=c.mismatch_memory))
        self.inertia = InertiaLearner(c.motor_inertia)
        self.no_load = NoLoadLearner(c.no_load_tolerance, c.no_load_cool_gap,
                                     c.no_load_reference_speed)
        self.no_load_band = NoLoadBand(c.no_load_band_time, c.no_load_band_factor)
        self.last_eta = math.nan

    def fuse(self, window: Window, operating: float, counts: dict[str, int],
             quality: DataQuality,
             on_measurement: Callable[[Measurement, bool], None] | None = None
             ) -> Carry | None:
        """Fuse a closed window into the filter at operating time ``operating`` [s].

        Returns the measurement as fused: (u less its direction's learned offset d/2 [-], its
        variance, the operating time it measures u at [s], its direction share h [-], the
        bias subtracted [-]); None for a window that gave none or was gated (counted by
        reason into ``counts``). ``quality`` counts each measured window's efficiency;
        ``on_measurement`` is called with each measurement and whether the filter took it.
        """
        c = self.config
        measured = self._measure(window, operating, counts)
        if measured is None:
            return None
        result, inertia, informative, no_load = measured
        if isinstance(result, str):
            counts[result] += 1
            return None
        quality.add_window(result.eta, result.eta_variance)
        direction = 0 if result.code == OPPOSING else 1
        update = self.filter.update(result.u, result.u_variance, operating, direction,
                                    0.5 * window.duration, informative)
        self.last_eta = result.eta
        if on_measurement is not None:
            on_measurement(result, update.accepted)
        if not update.accepted:
            counts['gated'] += 1
            return None
        if update.reinitialised:
            counts['gated'] += 1
            counts['reinitialised'] += 1
        if c.learn_motor_inertia:       # gear_phm.estimation.inertia
            # less the no-load energy: a drag costs energy along the travel, which differs
            # between a ramp's windows and a cruise's as K does, and was read as inertia
            self.inertia.add(direction, window.t_end, window.motor_energy - no_load[0],
                             window.load_energy, window.motor_kinetic,
                             window.motor_energy_variance, window.load_energy_variance)
        variance = self._applied_variance(window, result, inertia, no_load) \
            + self.filter.mismatch_variance(direction)
        # the measurement as fused: less its direction's learned offset d/2. The error of d is
        # common to all windows, + for one direction and - for the other: it averages out of
        # the wear trend, and is not added to each window's variance (adding it cut the RUL
        # band's coverage on a spur wear life from 0.88 to 0.62, test_analyze_cli; adding it
        # only while d was unsettled hid the first 14 s of wear of bags/fleet/unit_00)
        return (result.u - update.bias, variance, operating - 0.5 * window.duration,
                0.5 if direction else -0.5, update.bias)

    def _measure(self, window: Window, operating: float, counts: dict[str, int]
                 ) -> _Measured | None:
        """Return what ``window`` measures, with the inertia and no-load corrections known now.

        None for a window held because the no-load loss is not identified (counted).
        """
        c = self.config
        inertia, informative = (0.0, 0.0), True
        if c.learn_motor_inertia:       # the inertia not removed yet is in the variance
            inertia = (self.inertia.correction[0],
                       self.inertia.left_variance(window.motor_energy, window.motor_kinetic))
            prior = self.inertia.prior(window.motor_energy, window.motor_kinetic)
            # a window whose variance is mostly the inertia's prior does not adapt the filter
            informative = prior is None \
                or prior * window.motor_kinetic ** 2 <= window.motor_energy_variance
        result = to_measurement(window, c.ratio, c.min_window, c.min_energy, c.model_sigma,
                                inertia)
        no_load = (0.0, 0.0)
        if c.no_load_model and isinstance(result, Measurement):
            # the no-load part as known before this window (gear_phm.estimation.no_load); a
            # window where it is not identified is held: it would read drag as friction
            correction = self.no_load.observe(
                0 if window.code == OPPOSING else 1, window.t_start, window.t_end, operating,
                window.motor_energy - inertia[0] * window.motor_kinetic, window.load_energy,
                window.motor_energy_variance, window.load_energy_variance,
                window.motor_travel, window.motor_travel_square,
                window.motion, self._gain_rates(), window.motor_kinetic)
            if not correction.identified:
                counts['not_identifiable'] += 1
                return None
            no_load = (correction.energy, correction.shared * correction.variance)
            self.no_load_band.add(operating, self.no_load.estimate())
            result = to_measurement(window, c.ratio, c.min_window, c.min_energy,
                                    c.model_sigma, inertia, no_load)
        return result, inertia, informative, no_load

    def _applied_variance(self, window: Window, result: Measurement,
                          inertia: tuple[float, float], no_load: tuple[float, float]) -> float:
        """Return the u variance of ``result`` with the inertia correction applied since."""
        u_variance = result.u_variance
        if inertia[1] != self.inertia.correction[1]:
            # the RUL's history takes the window with the applied correction's variance only:
            # the inertia not applied yet is an error common to the windows of one position in
            # the stroke, not an independent one, and weighing those windows down there hid
            # the wear of a unit's first 14 s of operation (bags/fleet/unit_00: WARN at 16 s
            # became WARN a week later, at its next recording)
            c = self.config
            applied = to_measurement(window, c.ratio, c.min_window, c.min_energy,
                                     c.model_sigma, self.inertia.correction, no_load)
            if isinstance(applied, Measurement):
                u_variance = applied.u_variance
        return u_variance

    def _gain_rates(self) -> tuple[float, float]:
        """Return how fast the filter's wear rate moves 1 / eta_D and eta_I [1/s].

        :data:`GAIN_RATE_MARGIN` times the filter's |du/dt|: the rate lags a wear that speeds
        up, and a gain that cannot follow the wear passes it into the no-load part.
        """
        u, rate = float(self.filter.x[0]), GAIN_RATE_MARGIN * float(self.filter.x[1])
        r = self.config.ratio
        if not (math.isfinite(u) and math.isfinite(rate) and u > -1.0):
            return 0.0, 0.0
        # d(1/eta_D)/du = R (R + 1) / (R - u)^2, d(eta_I)/du = -R (R + 1) / (R + u)^2
        return (abs(rate) * r * (r + 1.0) / max(r - u, 1e-6) ** 2,
                -abs(rate) * r * (r + 1.0) / (r + u) ** 2)

    def estimate(self, stamp_ns: int, used: int, rejected: int, power_flow: int,
                 operating_time: float, measurement: Carry | None = None) -> FrictionEstimate:
        """Return the record at ``stamp_ns``, of the filter's state now.

        ``used``, ``rejected``: the sample counts at its sample; ``power_flow``: the newest
        sample's code; ``operating_time`` [s]: its time on the filter's axis; ``measurement``:
        what :meth:`fuse` returned for it, carried here with the rate.
        """
        x, p = self.filter.x, self.filter.P
        u, rate = float(x[0]), float(x[1])
        # each efficiency as its direction's windows read it: u plus that direction's bias
        eta_d = efficiencies(u + self.filter.direction_bias(0), self.config.ratio)[0]
        eta_i = efficiencies(u + self.filter.direction_bias(1), self.config.ratio)[1]
        last = self.filter.last
        z = variance = h = bias = math.nan
        if measurement is not None:
            z, variance = measurement[0] + rate * (operating_time - measurement[2]), measurement[1]
            h, bias = measurement[3], measurement[4]
        torque, sigma, total = self.no_load_fields()
        return FrictionEstimate(
            stamp_ns, u, rate, (float(p[0, 0]), float(p[0, 1]), float(p[1, 1])), eta_d, eta_i,
            self.last_eta, last.innovation, last.innovation_variance, last.nis,
            used, rejected, power_flow,
            process_noise=self.filter.process_noise,
            mismatch_variance=(self.filter.mismatch_variance(0),
                               self.filter.mismatch_variance(1)),
            operating_time=operating_time, measurement=z, measurement_variance=variance,
            direction_offset=self.filter.direction_offset, measurement_direction=h,
            measurement_bias=bias, no_load_torque=torque, no_load_sigma=sigma,
            total_efficiency=total)

    def prediction_base(self) -> PredictionBase:
        """Return what the estimates published before the next filter update are predicted from."""
        f = self.filter
        last = f.last
        return PredictionBase(
            f.x, f.P, math.inf if f.t is None else f.t,
            f.process_noise, (f.direction_bias(0), f.direction_bias(1)),
            (self.last_eta, last.innovation, last.innovation_variance, last.nis),
            (f.mismatch_variance(0), f.mismatch_variance(1)), self.no_load_fields())

    def no_load_fields(self) -> tuple[float, float, float]:
        """Return an estimate's no-load torque, its std dev and the total efficiency (NaN off)."""
        c = self.config
        if not c.no_load_model:
            return math.nan, math.nan, math.nan
        learned = self.no_load.estimate()
        eta_d = efficiencies(float(self.filter.x[0]) + self.filter.direction_bias(0),
                             c.ratio)[0]
        return (learned.torque, learned.torque_sigma,
                learned.total_efficiency(eta_d, c.ratio, c.rated_load_torque, c.rated_speed))

    def no_load_summary(self, eta_opposing: float) -> dict[str, float | bool | str]:
        """Return the no-load loss and the total efficiency at the rated point (summary keys)."""
        c = self.config
        learned = self.no_load.estimate()
        return {
            'no_load_torque': learned.torque, 'no_load_torque_sigma': learned.torque_sigma,
            'no_load_coulomb': learned.coulomb, 'no_load_viscous': learned.viscous,
            'no_load_offset': learned.offset,
            'no_load_reference_speed': learned.reference_speed,
            'no_load_cold_torque': learned.cold_torque,
            'no_load_identified': learned.identified,
            'no_load_band': self.no_load_band.message(learned.torque),
            'total_efficiency': learned.total_efficiency(eta_opposing, c.ratio,
                                                         c.rated_load_torque, c.rated_speed)}
