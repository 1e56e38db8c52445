"""Kalman filter on the friction parameter: x = [u, du/dt], filterpy underneath.

The filter adapts itself to the data (docs/estimation.md, "Adaptation"):

- process noise q [1/s^3]: log q follows a whiteness test of the normalised innovations
  (an exponentially weighted sum of them: a filter that lags makes them persist in sign, one
  that is too nervous makes them alternate), with a slow pull towards small q; q never falls
  below the wear-law floor ``r^3 / u`` (r: the part of |du/dt| beyond 2 sigma;
  acceleration ~ rate^2/u over a time scale u/rate
  for linear, exponential and power-law wear);
- measurement side: per power-flow direction, a bias (half the offset between the two
  directions' mean innovations, shrunk by two standard errors) taken off each measurement,
  and an additive model-mismatch variance learned by covariance matching on the innovations
  around it (their mean common to both directions, which is lag, taken out), so a systematic
  disagreement between opposing and aiding windows becomes a reported bias and variance and
  not divergence.
"""
from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Any

import numpy as np

from gear_phm.estimation.config import DEFAULTS
from gear_phm.estimation.filterpy_light import KalmanFilter
from gear_phm.persistence import decode_float, decode_floats, encode_float, encode_floats


@dataclass(frozen=True)
class UpdateResult:
    """Outcome of one pseudo-measurement: innovation y [-], its variance S, NIS [-].

    ``bias`` [-]: the direction's learned systematic error taken off the measurement
    (:meth:`FrictionFilter.direction_bias`).
    """

    accepted: bool
    innovation: float
    innovation_variance: float
    nis: float
    reinitialised: bool = False
    bias: float = 0.0


@dataclass(frozen=True)
class Adaptation:
    """Settings of the adaptation (see the module docstring); ``adaptive`` False: fixed q, R.

    The estimator parameters of the same names (:data:`gear_phm.estimation.config.PARAMETERS`):
    ``adapt_memory`` [updates]: length of the whiteness test (weight lambda =
    1 - 1/adapt_memory); ``adapt_gain`` [-]: step of log q per unit of test statistic;
    ``adapt_pull`` [-]: decrease of log q per update towards small q; ``mismatch_memory``
    [updates per direction]: window of the mismatch covariance matching. ``q_min``, ``q_max``
    [1/s^3]: limits of q.
    """

    adaptive: bool = bool(DEFAULTS['adaptive'])
    adapt_memory: float = float(DEFAULTS['adapt_memory'])
    adapt_gain: float = float(DEFAULTS['adapt_gain'])
    adapt_pull: float = float(DEFAULTS['adapt_pull'])
    mismatch_memory: float = float(DEFAULTS['mismatch_memory'])
    q_min: float = 1e-22
    q_max: float = 1e-4


def transition(dt: float) -> np.ndarray:
    """Constant-rate transition matrix over ``dt`` [s]."""
    return np.array([[1.0, dt], [0.0, 1.0]])


def process_covariance(dt: float, spectral_density: float) -> np.ndarray:
    """Discretised continuous white noise on d2u/dt2 over ``dt`` [s] (q [1/s^3]).

    q [[dt^3/3, dt^2/2], [dt^2/2, dt]], the matrix of filterpy's ``Q_continuous_white_noise``
    (dim=2) written out, which is 50 times cheaper per call (the tests check they agree).
    """
    if dt <= 0.0 or spectral_density == 0.0:
        return np.zeros((2, 2))
    q = float(spectral_density)
    dt2 = dt * dt
    return np.array([[q * dt2 * dt / 3.0, q * dt2 / 2.0], [q * dt2 / 2.0, q * dt]])


def predicted_stacked(x: np.ndarray, p: np.ndarray, t_filter: np.ndarray, q: np.ndarray,
                      t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return :meth:`FrictionFilter.predicted` of n filter states at once.

    Row k: state ``x[k]`` (n, 2) and covariance ``p[k]`` (n, 2, 2) at time ``t_filter[k]``
    [s] (inf: a filter without time), process noise ``q[k]`` [1/s^3], predicted to
    ``t[k]`` [s]; at or before ``t_filter[k]`` the state as it is. The numpy operations of
    one call, stacked: bit-identical to one call each.
    """
    ahead = t > t_filter
    dt = np.where(ahead, t - t_filter, 0.0)
    f = np.zeros((t.size, 2, 2))
    f[:, 0, 0] = 1.0
    f[:, 0, 1] = dt
    f[:, 1, 1] = 1.0
    x_out = (f @ x[:, :, None])[:, :, 0]
    p_out = f @ p @ f.transpose(0, 2, 1)
    noisy = ahead & (q != 0.0)              # process_covariance, element by element
    q, dt = q[noisy], dt[noisy]
    dt2 = dt * dt
    half = q * dt2 / 2.0
    p_out[noisy, 0, 0] += q * dt2 * dt / 3.0
    p_out[noisy, 0, 1] += half
    p_out[noisy, 1, 0] += half
    p_out[noisy, 1, 1] += q * dt
    x_out[~ahead] = x[~ahead]
    p_out[~ahead] = p[~ahead]
    return x_out, p_out


class FrictionFilter:
    """filterpy ``KalmanFilter`` on [u, du/dt] with H = [1, 0] and Mahalanobis gating.

    ``predict(t)`` moves the state to time ``t`` [s]; ``update(z, r, t)`` gates and fuses a
    pseudo-measurement ``z`` of u with variance ``r``. After ``max_consecutive_gated``
    rejections in a row the filter re-initialises on the measurement (a step fault).
    """

    def __init__(self, initial_u: float, initial_u_sigma: float, initial_rate_sigma: float,
                 process_noise: float, gate_threshold: float,
                 max_consecutive_gated: int, adaptation: Adaptation | None = None) -> None:
        self.initial_u_sigma = float(initial_u_sigma)
        self.initial_rate_sigma = float(initial_rate_sigma)
        self.process_noise = float(process_noise)
        self.adaptation = Adaptation(adaptive=False) if adaptation is None else adaptation
        #: q from the whiteness test alone [1/s^3] (process_noise is this or the floor).
        self.q_test = self.process_noise
        self._sum = 0.0               # weighted sum of normalised innovations
        self._power = 1.0             # weighted mean of their squares
        #: Per direction (0 opposing, 1 aiding/self-locking): updates seen, mean innovation
        #: [-], mismatch variance before clipping at 0 [-].
        self._n = [0, 0]
        self._mean = [0.0, 0.0]
        self._excess = [0.0, 0.0]
        self._num = [0.0, 0.0]         # weighted sums of the covariance matching
        self._den = [0.0, 0.0]
        self._mean_den = [0.0, 0.0]
        self.gate_threshold = float(gate_threshold)
        self.max_consecutive_gated = int(max_consecutive_gated)
        self.kf = KalmanFilter(dim_x=2, dim_z=1)
        self.kf.H = np.array([[1.0, 0.0]])
        self._initialise(float(initial_u), self.initial_u_sigma ** 2)
        self.t: float | None = None
        self.consecutive_gated = 0
        self.updates = 0
        self.last = UpdateResult(False, math.nan, math.nan, math.nan)

    def _initialise(self, u: float, u_variance: float) -> None:
        self.kf.x = np.array([[u], [0.0]])
        self.kf.P = np.diag([u_variance, self.initial_rate_sigma ** 2])

    def mismatch_variance(self, direction: int) -> float:
        """Learned model-mismatch variance [-] of direction 0 (opposing) or 1 (aiding)."""
        return max(self._excess[direction], 0.0) if self.adaptation.adaptive else 0.0

    def direction_bias(self, direction: int) -> float:
        """Learned systematic error [-] of direction 0 (opposing) or 1 (aiding) windows.

        Half the direction offset, signed per direction (opposing +, aiding -), shrunk by two
        standard errors of the two means towards 0 (so noise on a plant without mismatch
        moves nothing). Measurements are fused as z - bias: u is the midpoint of the two
        directions' readings.
        """
        if not (self.adaptation.adaptive and self._n[0] and self._n[1]
                and self._mean_den[0] > 0.0 and self._mean_den[1] > 0.0):
            return 0.0
        half = 0.5 * (self._mean[0] - self._mean[1])
        error = 0.5 * math.sqrt(1.0 / self._mean_den[0] + 1.0 / self._mean_den[1])
        bias = math.copysign(max(abs(half) - 2.0 * error, 0.0), half)
        return bias if direction == 0 else -bias

    @property
    def direction_offset(self) -> float:
        """Mean innovation of opposing minus aiding windows [-] (0 until both are seen)."""
        if not (self.adaptation.adaptive and self._n[0] and self._n[1]):
            return 0.0
        return self._mean[0] - self._mean[1]

    @property
    def x(self) -> np.ndarray:
        """Posterior state [u, du/dt] (copy, shape (2,))."""
        return self.kf.x[:, 0].copy()

    @property
    def P(self) -> np.ndarray:  # noqa: N802 (filterpy naming)
        """Posterior covariance (copy, 2x2)."""
        return self.kf.P.copy()

    def predict(self, t: float) -> None:
        """Propagate to time ``t`` [s]; earlier times leave the state unchanged."""
        if self.t is None:
            self.t = t
            return
        dt = t - self.t
        if dt > 0.0:
            self.kf.predict(F=transition(dt), Q=process_covariance(dt, self.process_noise))
            self.t = t

    def predicted(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """State and covariance predicted to ``t`` [s] without changing the filter."""
        if self.t is None or t <= self.t:
            return self.x, self.P
        dt = t - self.t
        f = transition(dt)
        x = f @ self.kf.x[:, 0]
        p = f @ self.kf.P @ f.T + process_covariance(dt, self.process_noise)
        return x, p

    def predicted_many(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return :meth:`predicted` at each time of ``t`` [s] at once.

        States (n, 2) and covariances (n, 2, 2), from the same numpy operations stacked
        (bit-identical to one call each, :func:`predicted_stacked`).
        """
        t = np.asarray(t, dtype=float)
        n = t.size
        return predicted_stacked(np.tile(self.kf.x[:, 0], (n, 1)), np.tile(self.kf.P, (n, 1, 1)),
                                 np.full(n, math.inf if self.t is None else self.t),
                                 np.full(n, self.process_noise), t)

    def update(self, z: float, r: float, t: float, direction: int = 0,
               age: float = 0.0) -> UpdateResult:
        """Predict to ``t`` [s], gate on NIS and fuse ``z`` (variance ``r``) if it passes.

        ``direction``: 0 for an opposing-load window, 1 for aiding (or self-locking); with
        adaptation its learned mismatch variance is added to ``r``. ``age`` [s]: ``z``
        measures u at ``t - age`` (a window's mid-time), H = [1, -age]; without it a window
        of length T lags growing u by T/2 (docs/estimation.md).
        """
        if not (math.isfinite(z) and math.isfinite(r) and r > 0.0):
            raise ValueError(f'measurement must be finite with variance > 0, got z={z!r}, '
                             f'r={r!r}')
        self.predict(t)
        h = np.array([[1.0, -float(age)]])
        bias = self.direction_bias(direction)
        raw = z - float((h @ self.kf.x)[0, 0])
        z, y = z - bias, raw - bias
        p_uu = float((h @ self.kf.P @ h.T)[0, 0])
        r_total = r + self.mismatch_variance(direction)
        s = p_uu + r_total
        nis = y * y / s
        if self.adaptation.adaptive:
            self._adapt(raw, bias, p_uu, r, s, direction, nis > self.gate_threshold)
        r = r_total
        if nis > self.gate_threshold:
            self.consecutive_gated += 1
            if self.consecutive_gated < self.max_consecutive_gated:
                self.last = UpdateResult(False, y, s, nis, bias=bias)
                return self.last
            self._initialise(z, r)
            self._sum, self._power = 0.0, 1.0
            self.consecutive_gated = 0
            self.updates += 1
            self.last = UpdateResult(True, y, s, nis, reinitialised=True, bias=bias)
            return self.last
        self.consecutive_gated = 0
        self.kf.update(np.array([[z]]), R=r, H=h)
        self.updates += 1
        self.last = UpdateResult(True, float(self.kf.y[0, 0]), float(self.kf.S[0, 0]), nis,
                                 bias=bias)
        if self.adaptation.adaptive:
            u, rate = float(self.kf.x[0, 0]), float(self.kf.x[1, 0])
            # only a significant rate (beyond 2 sigma) sets the floor: no feedback from noise
            rate = max(abs(rate) - 2.0 * math.sqrt(max(float(self.kf.P[1, 1]), 0.0)), 0.0)
            floor = rate ** 3 / max(abs(u), 1e-3)
            self.process_noise = min(max(self.q_test, floor), self.adaptation.q_max)
        return self.last

    def to_state(self) -> dict[str, Any]:
        """Return what a restart needs to continue (JSON-safe, :mod:`gear_phm.persistence`).

        x, P (row-major), time t [s], q and the adaptation's sums; the settings come from the
        configuration, not from the state.
        """
        last = self.last
        return {
            'x': encode_floats(self.kf.x[:, 0]), 'P': encode_floats(self.kf.P.ravel()),
            't': None if self.t is None else encode_float(self.t),
            'process_noise': encode_float(self.process_noise),
            'q_test': encode_float(self.q_test), 'sum': encode_float(self._sum),
            'power': encode_float(self._power), 'n': list(self._n),
            'mean': encode_floats(self._mean), 'excess': encode_floats(self._excess),
            'num': encode_floats(self._num), 'den': encode_floats(self._den),
            'mean_den': encode_floats(self._mean_den),
            'consecutive_gated': self.consecutive_gated, 'updates': self.updates,
            'last': [last.accepted, encode_float(last.innovation),
                     encode_float(last.innovation_variance), encode_float(last.nis),
                     last.reinitialised],
        }

    def from_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`to_state`; KeyError/ValueError/TypeError on a malformed dict."""
        x = decode_floats(state['x'])
        p = decode_floats(state['P'])
        if len(x) != 2 or len(p) != 4:
            raise ValueError('filter state: x needs 2 values and P 4')
        pairs = {key: decode_floats(state[key])
                 for key in ('mean', 'excess', 'num', 'den', 'mean_den')}
        n = [int(v) for v in state['n']]
        if len(n) != 2 or any(len(v) != 2 for v in pairs.values()):
            raise ValueError('filter state: per-direction values need 2 entries')
        last = state['last']
        self.kf.x = np.array(x).reshape(2, 1)
        self.kf.P = np.array(p).reshape(2, 2)
        self.t = None if state['t'] is None else decode_float(state['t'])
        self.process_noise = decode_float(state['process_noise'])
        self.q_test = decode_float(state['q_test'])
        self._sum = decode_float(state['sum'])
        self._power = decode_float(state['power'])
        self._n = n
        self._mean, self._excess = pairs['mean'], pairs['excess']
        self._num, self._den, self._mean_den = pairs['num'], pairs['den'], pairs['mean_den']
        self.consecutive_gated = int(state['consecutive_gated'])
        self.updates = int(state['updates'])
        self.last = UpdateResult(bool(last[0]), decode_float(last[1]), decode_float(last[2]),
                                 decode_float(last[3]), bool(last[4]))

    def _adapt(self, y: float, bias: float, p_uu: float, r: float, s: float, direction: int,
               gated: bool) -> None:
        """Run one step of both adaptations (before the update).

        ``y`` innovation of the raw measurement, ``bias`` the direction's learned bias,
        ``p_uu`` prior P_uu, ``r`` base variance, ``s`` innovation variance; ``gated``: the
        window fails the gate (it still feeds the matching, winsorised).
        """
        a = self.adaptation
        n, mean = self._n, self._mean
        both = n[0] > 0 and n[1] > 0
        common = 0.5 * (mean[0] + mean[1]) if both else mean[direction]
        offset = mean[direction] - common           # this direction's systematic part
        if p_uu <= 4.0 * (s - p_uu):
            # Not while the prior dominates (start-up, a long gap): there y is the prior's
            # error, and a mean taken from it stayed in the matching as a persistent
            # "mismatch" of (initial error)^2 (sigma 0.05 on a constant lever plant,
            # docs/estimation.md).
            self._match(y, p_uu, r, s, direction, common + bias)
        if gated:
            return
        e = (y - offset) / math.sqrt(s)
        lam = 1.0 - 1.0 / a.adapt_memory
        lam2 = lam * lam
        self._sum = lam * self._sum + e
        self._power = lam2 * self._power + (1.0 - lam2) * e * e
        h = ((1.0 - lam2) * self._sum ** 2 - self._power) / max(self._power, 1e-3)
        h = min(max(h, -2.0), 10.0)
        step = math.exp(a.adapt_gain * h - a.adapt_pull)
        self.q_test = min(max(self.q_test * step, a.q_min), a.q_max)

    def _match(self, y: float, p_uu: float, r: float, s: float, direction: int,
               common: float) -> None:
        """Covariance matching of the mismatch variance of ``direction`` (see ``_adapt``).

        Gated windows count too, their deviations winsorised at the gate (|y - mean| at most
        sqrt(gate S)): a mismatch larger than the gate is then learned in a few tens of
        windows instead of never, and an outlier moves the variance by at most gate S / memory.
        """
        n, mean = self._n, self._mean
        n[direction] += 1
        w = 1.0 / min(n[direction], self.adaptation.mismatch_memory)
        limit = math.sqrt(max(self.gate_threshold, 1.0) * s)
        # means weighted 1/S, variances 1/S^2 (Fisher scoring of an additive variance), so
        # precise windows are not drowned by noisy ones nor by the start-up transient
        keep = 1.0 - w
        self._mean_den[direction] = keep * self._mean_den[direction] + 1.0 / s
        step = min(max(y - mean[direction], -limit), limit)
        mean[direction] += step / (s * self._mean_den[direction])
        deviation = min(abs(y - common), limit)
        weight = 1.0 / (s * s)
        self._num[direction] = keep * self._num[direction] \
            + weight * (deviation ** 2 - p_uu - r)
        self._den[direction] = keep * self._den[direction] + weight
        # a variance is used once it is significant: estimate minus its standard error
        # sqrt(2 / sum of weights), so a plant without mismatch is not made conservative
        self._excess[direction] = (self._num[direction]
                                   - math.sqrt(2.0 * self._den[direction])) / self._den[direction]
