"""Load-independent (no-load) losses learned jointly with each direction's gain (no ROS imports).

A real gearbox loses more than the load-proportional Coulomb friction of the paper's model:
oil churning, seal drag and the viscous part of bearing drag (ISO/TR 14179) cost a torque at
the motor that does not scale with the load and falls as the oil warms. With the mesh loss
of the lever model and that no-load torque, the motor torque is

    T_m = T_u / (R eta_dir(u)) + T_0 sign(w_m) + c_v w_m + d + J_m dw_m/dt

where ``d`` is a torque offset that does not flip with the motion (a motor torque sensor's
offset; a load torque sensor's offset o_l enters as d = -o_l / (R eta), the same term).
Integrated over an energy window of one power-flow direction and one sense of motion s::

    E_m = g L + (T_0 + s d) A + c_v B          L = -E_l, A = int |w_m| dt, B = int w_m^2 dt

with g = 1 / eta_D (opposing) or eta_I (aiding). Written about the typical motor speed W
(the median B / A of the first windows), (T_0 + s d) A + c_v B = a_s A + c_v (B - W A) with
a_s = T_0 + s d + c_v W, the no-load torque at W: windows of one speed profile then measure
a_s well even though they cannot split it into its Coulomb and viscous parts. The rotor
inertia that ``motor_inertia`` leaves costs dJ K more (K = (w_m,end^2 - w_m,start^2) / 2), a
nuisance of the ramps' windows. Divided by |L|, each window is one linear measurement of the
state x = [g_D, g_I, a_+, a_-, c_v, dJ], which filterpy's ``KalmanFilter`` tracks: the gains
walk with the wear (by the friction filter's wear rate), the no-load part with the oil
temperature, dJ is constant. The no-load part is identifiable only from windows
whose ratio L / A differs, i.e. a load that varies: under one constant load the gain and the
no-load torque are collinear and the filter's covariance says so.

:meth:`NoLoadLearner.observe` returns, for each window, the no-load energy to remove from its
motor energy, computed from the state before that window, with its variance, and whether it
is *identified*: its standard deviation, relative to |L| (the efficiency's scale), at most
``tolerance``. The estimator fuses only identified windows into u; the others are held
(``windows_rejected_not_identifiable``), so a constant load never turns a drag into wear.
After an idle gap longer than ``cool_gap`` in stamp time the no-load part starts again from
its cold value (the first one identified after a start), not from the last warm one.
"""
from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Any

import numpy as np

from gear_phm.estimation.filterpy_light import KalmanFilter
from gear_phm.persistence import decode_float, decode_floats, encode_float, encode_floats

#: State size: g_D, g_I, a_+, a_-, c_v, dJ; the no-load part is x[NO_LOAD].
DIM = 6
NO_LOAD = slice(2, 5)
#: Windows whose medians set the scales before the filter starts.
START_WINDOWS = 8
#: Prior std dev of each direction's gain g [-] (eta from 0 to 2 within one sigma of 1).
GAIN_SIGMA = 1.0
#: Prior std dev of T_0 and of c_v times the typical speed, as shares of the typical motor
#: torque of the first windows [-]; of the offset d.
NO_LOAD_SHARE = 0.3
OFFSET_SHARE = 0.05
#: Prior std dev of the rotor inertia left: this share of the first windows' median motor
#: energy over their largest |K| [-].
INERTIA_SHARE = 0.5
#: Random-walk spectral densities per second of operation: the gains' floor [1/s] (the
#: gains also move by the wear rate the caller gives, :meth:`NoLoadLearner.observe`), T_0 and
#: c_v w_typ as shares of the typical motor torque [1/s], the offset [1/s].
GAIN_WALK = 2e-8
NO_LOAD_WALK = 2.5e-7
OFFSET_WALK = 2.5e-9
#: A window whose NIS exceeds this is not fused into the no-load state; after
#: ``GATED_RESET`` in a row the gains' covariance is reset (a step in the friction).
GATE = 25.0
GATED_RESET = 3
#: Most windows one correction error is taken to be shared by.
MAX_SHARED = 200.0
#: Memory of the learned extra window scatter (covariance matching) [windows], and its
#: floor [-^2]: no two windows agree better than about 0.1 % of the efficiency.
SCATTER_MEMORY = 50.0
SCATTER_FLOOR = 1e-6


@dataclass(frozen=True)
class NoLoadCorrection:
    """What a window's motor energy holds of the no-load loss, as known before that window.

    ``energy`` [J] and its ``variance`` [J^2]; ``identified``: its std dev relative to the
    window's load energy is within the tolerance (the window may be fused into u).
    ``shared``: how many windows in a row share its error (the no-load state's memory): to
    the friction filter, which takes each window's error as independent, the correction
    weighs ``shared`` times its variance, so that averaging those windows does not make u
    surer than the no-load part is.
    """

    energy: float
    variance: float
    identified: bool
    shared: float = 1.0


@dataclass(frozen=True)
class NoLoadEstimate:
    """The learned no-load loss at the motor shaft.

    ``coulomb`` T_0 [N m], ``viscous`` c_v [N m s/rad], ``offset`` d [N m] (does not flip with
    the motion), ``reference_speed`` [rad/s] and ``torque`` T_0 + c_v w_ref [N m] there with
    its ``torque_sigma`` [N m]; ``identified``: a window's correction has been within the
    tolerance since the last start (the no-load part is known); ``cold_torque``: the torque
    learned first after the last start (NaN before any).
    """

    coulomb: float
    viscous: float
    offset: float
    reference_speed: float
    torque: float
    torque_sigma: float
    identified: bool
    cold_torque: float

    def total_efficiency(self, eta: float, ratio: float, load_torque: float,
                         load_speed: float) -> float:
        """Return the efficiency at a rated point with this no-load loss [-].

        ``eta``: the load-dependent efficiency, ``load_torque`` [N m] and ``load_speed``
        [rad/s] at the output: eta_total = 1 / (1 / eta + R T_nl(R w_l) / T_l) (opposing).
        NaN without a rated point.
        """
        if not (load_torque > 0.0 and load_speed > 0.0 and eta > 0.0):
            return math.nan
        drag = self.coulomb + self.viscous * ratio * load_speed + self.offset
        return 1.0 / (1.0 / eta + ratio * drag / load_torque)


class NoLoadLearner:
    """Kalman filter on the gains and the no-load loss (module docstring)."""

    def __init__(self, tolerance: float = 0.004, cool_gap: float = 3600.0,
                 reference_speed: float = 0.0) -> None:
        #: largest std dev of a window's correction relative to |L| that is identified [-]
        self.tolerance = float(tolerance)
        #: an idle gap longer than this in stamp time [s] starts from the cold value
        self.cool_gap = float(cool_gap)
        #: speed at which the no-load torque is reported [rad/s]; 0: the typical speed
        self.reference_speed = float(reference_speed)
        self.reset()

    def reset(self) -> None:
        """Forget everything learned."""
        self.kf: Any = None             # filterpy's KalmanFilter once the first window came
        #: typical motor torque [N m] and speed [rad/s] (scales of the prior and walks)
        self.torque_scale = math.nan
        self.speed_scale = math.nan
        self.inertia_scale = math.nan   # prior std dev of the rotor inertia left [kg m^2]
        self._t_end = math.nan          # stamp time of the newest window's end [s]
        self._operating = math.nan      # operating time of the newest window [s]
        self.scatter = SCATTER_FLOOR    # learned extra variance of z [-^2]
        self.gated = 0                  # windows in a row the state did not take
        self.cold: np.ndarray | None = None     # [a_+, a_-, c_v] first identified after start
        self._seek_cold = True
        self.identified = False         # the newest correction's verdict
        self.known = False              # a correction was identified since the last start
        #: the first windows, kept until the scales are known (:meth:`observe`)
        self._first: list[tuple[float, ...]] = []
        self._estimate: NoLoadEstimate | None = None     # estimate() until the next window

    # --- the filter ------------------------------------------------------------------------
    def _prior(self) -> np.ndarray:
        t_sigma = NO_LOAD_SHARE * self.torque_scale
        d_sigma = OFFSET_SHARE * self.torque_scale
        p = np.zeros((DIM, DIM))
        p[0, 0] = p[1, 1] = GAIN_SIGMA ** 2
        p[2:4, 2:4] = t_sigma ** 2 * np.ones((2, 2)) + d_sigma ** 2 * np.array(
            [[1.0, -1.0], [-1.0, 1.0]])
        p[4, 4] = (NO_LOAD_SHARE * self.torque_scale / self.speed_scale) ** 2
        p[5, 5] = self.inertia_scale ** 2
        return p

    def _start(self, torque: float, speed: float, inertia: float) -> None:
        self.torque_scale, self.speed_scale, self.inertia_scale = torque, speed, inertia
        kf = KalmanFilter(dim_x=DIM, dim_z=1)
        kf.x = np.array([[1.0], [1.0], [0.0], [0.0], [0.0], [0.0]])
        kf.P = self._prior()
        kf.F = np.eye(DIM)
        self.kf = kf

    def _walk(self, dt: float, gain_rates: tuple[float, float]) -> np.ndarray:
        t2 = self.torque_scale ** 2
        dt = max(dt, 0.0)
        q = np.zeros((DIM, DIM))
        # the wear the gains follow: a drift of rate r over dt adds (r dt)^2, both gains at once
        drift = np.array(gain_rates) * dt
        q[:2, :2] = np.outer(drift, drift) / max(dt, 1e-12)
        q[0, 0] += GAIN_WALK
        q[1, 1] += GAIN_WALK
        q[2:4, 2:4] = NO_LOAD_WALK * t2 * np.ones((2, 2)) + OFFSET_WALK * t2 * np.array(
            [[1.0, -1.0], [-1.0, 1.0]])
        q[4, 4] = NO_LOAD_WALK * t2 / self.speed_scale ** 2
        return q * dt

    def _cool(self) -> None:
        """Start the no-load part again from its cold value (or the prior), after a gap."""
        prior = self._prior()
        self.kf.P[NO_LOAD, :] = 0.0
        self.kf.P[:, NO_LOAD] = 0.0
        self.kf.P[NO_LOAD, NO_LOAD] = prior[NO_LOAD, NO_LOAD]
        self.kf.x[NO_LOAD, 0] = 0.0 if self.cold is None else self.cold
        self.known = False
        self._seek_cold = self.cold is None

    # --- per window ------------------------------------------------------------------------
    def observe(self, direction: int, t_start: float, t_end: float, operating: float,
                motor_energy: float, load_energy: float, motor_variance: float,
                load_variance: float, travel: float, travel_square: float,
                motion: int, gain_rates: tuple[float, float] = (0.0, 0.0),
                kinetic: float = 0.0) -> NoLoadCorrection:
        """Return the correction of one window, then learn from it.

        ``direction`` 0 opposing, 1 aiding; stamp times ``t_start``, ``t_end`` and the
        operating time at its end [s]; motor and load energies [J] (the motor's less any rotor
        inertia) and their variances [J^2]; ``travel`` A = int |w_m| dt [rad], ``travel_square``
        B = int w_m^2 dt [rad^2/s], ``motion`` the sign of w_m; ``gain_rates``: how fast wear
        moves g_D and g_I [1/s] (from the friction filter's rate), so that the gains follow
        the wear and the no-load part the oil; ``kinetic`` K = (w_m,end^2 - w_m,start^2) / 2
        [rad^2/s^2]: the rotor inertia dJ left in the motor energy costs dJ K, learned as a
        nuisance (windows of a ramp would otherwise pass it into the no-load part). A window
        without travel is returned as not identified and not learned from.
        """
        self._estimate = None
        load = -load_energy
        values = (t_start, t_end, operating, motor_energy, load, motor_variance,
                  load_variance, travel, travel_square)
        if not (all(math.isfinite(v) for v in values) and travel > 0.0
                and travel_square > 0.0 and load != 0.0):
            return NoLoadCorrection(0.0, math.inf, False)
        row = (direction, t_start, t_end, operating, motor_energy, load, motor_variance,
               load_variance, travel, travel_square, motion, *gain_rates, kinetic)
        if self.kf is None:
            # the scales (the prior's, the walks' and the typical speed W) are the medians of
            # the first START_WINDOWS windows, which are then learned from in order
            self._first.append(row)
            if len(self._first) < START_WINDOWS:
                return NoLoadCorrection(0.0, math.inf, False)
            first = np.array(self._first)
            largest = float(np.max(np.abs(first[:, 13])))
            self._start(float(np.median(np.abs(first[:, 4]) / first[:, 8])),
                        float(np.median(first[:, 9] / first[:, 8])),
                        INERTIA_SHARE * float(np.median(np.abs(first[:, 4]))) / largest
                        if largest > 0.0 else 0.0)
            for kept in self._first:
                self._step(*kept)
            self._first = []
            return NoLoadCorrection(0.0, math.inf, False)
        if t_start - self._t_end > self.cool_gap:
            self._cool()
        return self._step(*row)

    def _step(self, direction: float, t_start: float, t_end: float, operating: float,
              motor_energy: float, load: float, motor_variance: float, load_variance: float,
              travel: float, travel_square: float, motion: float, rate_d: float,
              rate_i: float, kinetic: float) -> NoLoadCorrection:
        """Return one window's correction from the state before it, then learn from it."""
        gain_rates = (rate_d, rate_i)
        kf = self.kf
        kf.Q = self._walk(operating - self._operating if math.isfinite(self._operating)
                          else 0.0, gain_rates)
        kf.predict()
        scale = abs(load)
        h = np.zeros((1, DIM))
        column = int(direction)
        h[0, column] = math.copysign(1.0, load)
        h[0, 2 if motion >= 0 else 3] = travel / scale
        h[0, 4] = (travel_square - self.speed_scale * travel) / scale
        h[0, 5] = kinetic / scale
        phi = h[0, NO_LOAD]
        p_theta = kf.P[NO_LOAD, NO_LOAD]
        z_corr = float(phi @ kf.x[NO_LOAD, 0])
        var_corr = max(float(phi @ p_theta @ phi), 0.0)
        walk = float(phi @ kf.Q[NO_LOAD, NO_LOAD] @ phi)
        self.identified = math.sqrt(var_corr) <= self.tolerance
        self.known = self.known or self.identified
        if self.identified and self._seek_cold:
            self.cold = kf.x[NO_LOAD, 0].copy()
            self._seek_cold = False
        gain = float(kf.x[column, 0])
        sensor = (motor_variance + gain * gain * load_variance) / (scale * scale)
        y = motor_energy / scale - float((h @ kf.x)[0, 0])
        hph = float((h @ kf.P @ h.T)[0, 0])
        gated = y * y / (hph + sensor + self.scatter) > GATE
        # covariance matching on every window, so that a scatter the sensors do not explain
        # widens the gate instead of gating every window
        excess = min(y * y, GATE * (hph + sensor + self.scatter)) - hph - sensor
        self.scatter = max(self.scatter + (excess - self.scatter) / SCATTER_MEMORY,
                           SCATTER_FLOOR)
        if gated and self.gated + 1 < GATED_RESET:
            self.gated += 1
        else:
            if gated:                   # a step in the friction: the gains start again
                kf.P[:2, :] = 0.0
                kf.P[:, :2] = 0.0
                kf.P[0, 0] = kf.P[1, 1] = GAIN_SIGMA ** 2
            self.gated = 0
            kf.update(np.array([[motor_energy / scale]]), R=np.array(
                [[sensor + self.scatter]]), H=h)
        self._t_end, self._operating = t_end, operating
        # the state's memory in windows, sqrt(r / q) of a random walk seen through noise r
        shared = min(max(math.sqrt((sensor + self.scatter) / walk), 1.0), MAX_SHARED) \
            if walk > 0.0 else MAX_SHARED
        return NoLoadCorrection(z_corr * scale, var_corr * scale * scale, self.identified,
                                shared)

    # --- reporting -------------------------------------------------------------------------
    def estimate(self) -> NoLoadEstimate:
        """Return the learned no-load loss (NaN before the first window)."""
        if self._estimate is None:
            self._estimate = self._estimated()
        return self._estimate

    def _estimated(self) -> NoLoadEstimate:
        if self.kf is None:
            nan = math.nan
            return NoLoadEstimate(nan, nan, nan, self.reference_speed, nan, nan, False, nan)
        a_pos, a_neg, viscous = (float(v) for v in self.kf.x[NO_LOAD, 0])
        speed = self.reference_speed if self.reference_speed > 0.0 else self.speed_scale
        at_typical, offset = 0.5 * (a_pos + a_neg), 0.5 * (a_pos - a_neg)
        coulomb = at_typical - viscous * self.speed_scale
        phi = np.array([0.5, 0.5, speed - self.speed_scale])
        sigma = math.sqrt(max(float(phi @ self.kf.P[NO_LOAD, NO_LOAD] @ phi), 0.0))
        cold = math.nan if self.cold is None else float(
            0.5 * (self.cold[0] + self.cold[1]) + self.cold[2] * (speed - self.speed_scale))
        return NoLoadEstimate(coulomb, viscous, offset, speed, coulomb + viscous * speed,
                              sigma, self.known, cold)

    def to_state(self) -> dict[str, Any]:
        """Return the filter, its scales, the cold value and the counters (JSON-safe)."""
        kf = self.kf
        return {
            'x': None if kf is None else encode_floats(kf.x[:, 0].tolist()),
            'P': None if kf is None else encode_floats(kf.P.ravel().tolist()),
            'scales': encode_floats([self.torque_scale, self.speed_scale,
                                     self.inertia_scale]),
            'times': encode_floats([self._t_end, self._operating]),
            'scatter': encode_float(self.scatter), 'gated': self.gated,
            'cold': None if self.cold is None else encode_floats(self.cold.tolist()),
            'seek_cold': self._seek_cold, 'identified': self.identified, 'known': self.known,
            'first': [encode_floats(list(row)) for row in self._first]}

    def from_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`to_state`; ValueError/KeyError/TypeError if malformed."""
        x = None if state['x'] is None else np.array(decode_floats(state['x']))
        p = None if state['P'] is None else np.array(decode_floats(state['P']))
        scales, times = decode_floats(state['scales']), decode_floats(state['times'])
        cold = None if state['cold'] is None else np.array(decode_floats(state['cold']))
        shapes_ok = (x is None and p is None) or (
            x is not None and p is not None and x.size == DIM and p.size == DIM * DIM)
        if not shapes_ok or len(scales) != 3 or len(times) != 2 \
                or (cold is not None and cold.size != 3):
            raise ValueError('no_load: malformed state')
        self.reset()
        self.torque_scale, self.speed_scale, self.inertia_scale = scales
        if x is not None and p is not None:
            self._start(self.torque_scale, self.speed_scale, self.inertia_scale)
            self.kf.x = x.reshape(DIM, 1)
            self.kf.P = p.reshape(DIM, DIM)
        self._t_end, self._operating = times
        self.scatter = decode_float(state['scatter'])
        self.gated = int(state['gated'])
        self.cold = cold
        self._seek_cold = bool(state['seek_cold'])
        self.identified = bool(state['identified'])
        self.known = bool(state['known'])
        self._first = [tuple(decode_floats(row)) for row in state['first']]
        if any(len(row) != 14 for row in self._first):
            raise ValueError('no_load: malformed state')


class NoLoadBand:
    """The no-load loss's own health indicator: its healthy band, learned, then watched.

    For its first ``learn_time`` [s] of operation the band is the highest no-load torque
    identified (a cold start's included: a cold start is not a fault). After that, a torque
    whose lower 2-sigma bound exceeds ``factor`` times that is *above its healthy band*: drag
    that grew (a seal, the lubrication), not wear; it is reported, never end of life.
    """

    def __init__(self, learn_time: float = 3600.0, factor: float = 1.5) -> None:
        self.learn_time = float(learn_time)
        self.factor = float(factor)
        self.start = math.nan       # operating time of the first identified torque [s]
        self.highest = math.nan     # highest healthy torque [N m]
        self.above = False

    def add(self, operating: float, estimate: NoLoadEstimate) -> None:
        """Take the estimate after an identified window at operating time ``operating`` [s]."""
        if not (estimate.identified and math.isfinite(estimate.torque)):
            return
        if not math.isfinite(self.start):
            self.start = operating
        if operating - self.start <= self.learn_time:
            self.highest = estimate.torque if not math.isfinite(self.highest) else max(
                self.highest, estimate.torque)
            return
        self.above = estimate.torque - 2.0 * estimate.torque_sigma > self.factor * max(
            self.highest, 0.0)

    def message(self, torque: float) -> str:
        """Return the status text when above the band ('' otherwise)."""
        if not self.above:
            return ''
        return (f'no-load loss {torque:.4g} N m above its healthy band (up to '
                f'{self.factor * self.highest:.4g} N m): drag grew (seal, lubrication), not '
                f'wear')

    def to_state(self) -> dict[str, Any]:
        """Return the band (JSON-safe)."""
        return {'start': encode_float(self.start), 'highest': encode_float(self.highest),
                'above': self.above}

    def from_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`to_state`; KeyError/ValueError/TypeError if malformed."""
        start, highest = decode_float(state['start']), decode_float(state['highest'])
        self.start, self.highest, self.above = start, highest, bool(state['above'])
