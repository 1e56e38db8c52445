"""Kalman filter on the friction parameter: x = [u, du/dt, d], filterpy underneath.

d [-], the direction offset, is what the aiding-load (inverse, eta_I) windows read of u minus
what the opposing-load (direct, eta_D) ones read; u [-] is the midpoint: opposing windows
measure u - d/2, aiding ones u + d/2 (docs/estimation.md, "Direction offset"). A gearbox that
is not exactly the lever model has eta_D and eta_I of two different u; d is a state of the
filter, learned from the first windows of both directions on, with a slow random walk
(:data:`OFFSET_DRIFT`), so that u does not move when the load direction changes and a drift
of the offset is followed (and reported) instead of being read as wear.

The filter adapts itself to the data (docs/estimation.md, "Adaptation"):

- process noise q [1/s^3]: log q follows a whiteness test of the normalised innovations
  (an exponentially weighted sum of them: a filter that lags makes them persist in sign, one
  that is too nervous makes them alternate), with a slow pull towards small q; q never falls
  below the wear-law floor ``r^3 / u`` (r: the part of |du/dt| beyond 2 sigma;
  acceleration ~ rate^2/u over a time scale u/rate
  for linear, exponential and power-law wear);
- measurement side: per power-flow direction, an additive model-mismatch variance learned by
  covariance matching on the innovations (their mean common to both directions, which is
  lag, taken out); the systematic disagreement between opposing and aiding windows is the
  state d, so it becomes a reported offset and not divergence.
"""
from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Any

import numpy as np

from gear_phm.estimation.config import DEFAULTS
from gear_phm.estimation.filterpy_light import KalmanFilter
from gear_phm.persistence import decode_float, decode_floats, encode_float, encode_floats

#: Prior standard deviation of the direction offset d [-] (real gearboxes: up to ~25 % of u).
OFFSET_SIGMA = 0.05
#: Spectral density of the random walk of d [1/s]: sigma 0.001 over 10 000 s of operation.
OFFSET_DRIFT = 1e-10
#: A drift of d from its settled value is reported once beyond this many sigmas.
OFFSET_DRIFT_Z = 3.0
#: d is settled (its reference for the drift report taken) once its sigma is below this [-].
OFFSET_SETTLED_SIGMA = 0.002


@dataclass(frozen=True)
class UpdateResult:
    """Outcome of one pseudo-measurement: innovation y [-], its variance S, NIS [-].

    ``bias`` [-]: the direction's learned offset taken off the measurement
    (:meth:`FrictionFilter.direction_bias`, before the update), ``bias_variance`` its
    variance [-^2].
    """

    accepted: bool
    innovation: float
    innovation_variance: float
    nis: float
    reinitialised: bool = False
    bias: float = 0.0
    bias_variance: float = 0.0


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
    """filterpy ``KalmanFilter`` on [u, du/dt, d] with Mahalanobis gating.

    ``predict(t)`` moves the state to time ``t`` [s]; ``update(z, r, t, direction)`` gates and
    fuses a pseudo-measurement ``z`` of u - d/2 (opposing windows, H = [1, 0, -1/2]) or of
    u + d/2 (aiding windows, H = [1, 0, 1/2]) with variance ``r``. After
    ``max_consecutive_gated`` rejections in a row the filter re-initialises u on the
    measurement (a step fault; d is kept). With
    ``adaptation.adaptive`` False d stays 0 (its variance 0): the two-state filter.
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
        self.offset_sigma = OFFSET_SIGMA if self.adaptation.adaptive else 0.0
        self.offset_drift = OFFSET_DRIFT if self.adaptation.adaptive else 0.0
        #: The settled offset d [-] and its variance, the reference of the drift report
        #: (:attr:`offset_drift_z`); NaN until d's sigma is below OFFSET_SETTLED_SIGMA.
        self.offset_reference = (math.nan, math.nan)
        self.kf = KalmanFilter(dim_x=3, dim_z=1)
        self.kf.H = np.array([[1.0, 0.0, 0.0]])
        self._initialise(float(initial_u), self.initial_u_sigma ** 2)
        self.kf.x[2, 0] = 0.0
        self.kf.P[2, 2] = self.offset_sigma ** 2
        self.t: float | None = None
        self.consecutive_gated = 0
        self.updates = 0
        self.last = UpdateResult(False, math.nan, math.nan, math.nan)

    def _initialise(self, u: float, u_variance: float) -> None:
        """Set u and du/dt afresh (variance ``u_variance``, rate prior).

        d and its variance are kept: a step fault changes the friction, not the offset.
        """
        x = getattr(self.kf, 'x', np.zeros((3, 1)))
        p_dd = float(self.kf.P[2, 2]) if self.kf.P.shape == (3, 3) else 0.0
        self.kf.x = np.array([[u], [0.0], [float(x[2, 0])]])
        self.kf.P = np.diag([u_variance, self.initial_rate_sigma ** 2, p_dd])

    def mismatch_variance(self, direction: int) -> float:
        """Learned model-mismatch variance [-] of direction 0 (opposing) or 1 (aiding)."""
        return max(self._excess[direction], 0.0) if self.adaptation.adaptive else 0.0

    def direction_bias(self, direction: int) -> float:
        """Learned reading of direction 0 (opposing) or 1 (aiding) windows minus u [-].

        -d/2 for opposing windows, +d/2 for aiding ones (u is the midpoint).
        """
        half = 0.5 * self.direction_offset
        return half if direction else -half

    @property
    def direction_offset(self) -> float:
        """Return the offset d [-]: aiding windows' reading of u minus the opposing ones'."""
        return float(self.kf.x[2, 0])

    @property
    def direction_offset_sigma(self) -> float:
        """Return the standard deviation of :attr:`direction_offset` [-]."""
        return math.sqrt(max(float(self.kf.P[2, 2]), 0.0))

    @property
    def offset_drift_z(self) -> float:
        """Drift of d from its settled value (:attr:`offset_reference`) in sigmas [-].

        The sigma combines both values' (the reference's is an upper bound, their errors
        overlap); NaN until d has settled. Beyond :data:`OFFSET_DRIFT_Z` the offset itself
        changes: one direction wears differently from the other (docs/estimation.md).
        """
        d_ref, v_ref = self.offset_reference
        if not math.isfinite(d_ref):
            return math.nan
        sigma = math.sqrt(v_ref + max(float(self.kf.P[2, 2]), 0.0))
        return (self.direction_offset - d_ref) / sigma if sigma > 0.0 else 0.0

    @property
    def x(self) -> np.ndarray:
        """Posterior state [u, du/dt] (copy, shape (2,)); d is :attr:`direction_offset`."""
        x: np.ndarray = self.kf.x[:2, 0].copy()
        return x

    @property
    def P(self) -> np.ndarray:  # noqa: N802 (filterpy naming)
        """Posterior covariance of [u, du/dt] (copy, 2x2)."""
        p: np.ndarray = self.kf.P[:2, :2].copy()
        return p

    def predict(self, t: float) -> None:
        """Propagate to time ``t`` [s]; earlier times leave the state unchanged."""
        if self.t is None:
            self.t = t
            return
        dt = t - self.t
        if dt > 0.0:
            f = np.eye(3)
            f[0, 1] = dt
            q = np.zeros((3, 3))
            q[:2, :2] = process_covariance(dt, self.process_noise)
            q[2, 2] = self.offset_drift * dt
            self.kf.predict(F=f, Q=q)
            self.t = t

    def predicted(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """State and covariance predicted to ``t`` [s] without changing the filter."""
        if self.t is None or t <= self.t:
            return self.x, self.P
        dt = t - self.t
        f = transition(dt)
        x = f @ self.kf.x[:2, 0]
        p = f @ self.kf.P[:2, :2] @ f.T + process_covariance(dt, self.process_noise)
        return x, p

    def predicted_many(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return :meth:`predicted` at each time of ``t`` [s] at once.

        States (n, 2) and covariances (n, 2, 2), from the same numpy operations stacked
        (bit-identical to one call each, :func:`predicted_stacked`).
        """
        t = np.asarray(t, dtype=float)
        n = t.size
        return predicted_stacked(np.tile(self.kf.x[:2, 0], (n, 1)),
                                 np.tile(self.kf.P[:2, :2], (n, 1, 1)),
                                 np.full(n, math.inf if self.t is None else self.t),
                                 np.full(n, self.process_noise), t)

    def update(self, z: float, r: float, t: float, direction: int = 0,
               age: float = 0.0, informative: bool = True) -> UpdateResult:
        """Predict to ``t`` [s], gate on NIS and fuse ``z`` (variance ``r``) if it passes.

        ``direction``: 0 for an opposing-load window (``z`` measures u - d/2), 1 for aiding (or
        self-locking: ``z`` measures u + d/2); with adaptation its learned mismatch variance is
        added to ``r``. ``age`` [s]: ``z`` measures u at ``t - age`` (a window's mid-time),
        H = [1, -age, -/+ 1/2]; without it a window of length T lags growing u by T/2
        (docs/estimation.md). ``informative`` False: ``r`` is mostly a deliberately broad
        prior (a window whose rotor inertia is not known yet), so the window does not feed the
        adaptation but its pull towards small q: its innovations, far inside their variance,
        made the whiteness test's power collapse and q rise tenfold (NIS 0.1 for 60 s on a
        lever plant).
        Raises ValueError on a non-finite ``z`` or ``r`` <= 0.
        """
        if not (math.isfinite(z) and math.isfinite(r) and r > 0.0):
            raise ValueError(f'measurement must be finite with variance > 0, got z={z!r}, '
                             f'r={r!r}')
        self.predict(t)
        half = 0.5 if direction else -0.5
        h = np.array([[1.0, -float(age), half]])
        bias = self.direction_bias(direction)
        bias_variance = 0.25 * float(self.kf.P[2, 2])
        y = z - float((h @ self.kf.x)[0, 0])
        p_uu = float((h @ self.kf.P @ h.T)[0, 0])
        r_total = r + self.mismatch_variance(direction)
        s = p_uu + r_total
        nis = y * y / s
        if self.adaptation.adaptive and informative:
            self._adapt(y, p_uu, r, s, direction, nis > self.gate_threshold)
        elif self.adaptation.adaptive:      # only the pull towards small q
            a = self.adaptation
            self.q_test = min(max(self.q_test * math.exp(-a.adapt_pull), a.q_min), a.q_max)
        r = r_total
        if nis > self.gate_threshold:
            self.consecutive_gated += 1
            if self.consecutive_gated < self.max_consecutive_gated:
                self.last = UpdateResult(False, y, s, nis, bias=bias, bias_variance=bias_variance)
                return self.last
            self._initialise(z - bias, r + bias_variance)
            self._sum, self._power = 0.0, 1.0
            self.consecutive_gated = 0
            self.updates += 1
            self.last = UpdateResult(True, y, s, nis, reinitialised=True, bias=bias,
                                     bias_variance=bias_variance)
            return self.last
        self.consecutive_gated = 0
        self.kf.update(np.array([[z]]), R=r, H=h)
        self.updates += 1
        self.last = UpdateResult(True, float(self.kf.y[0, 0]), float(self.kf.S[0, 0]), nis,
                                 bias=bias, bias_variance=bias_variance)
        if self.adaptation.adaptive:
            self._settle_offset()
        if self.adaptation.adaptive:
            u, rate = float(self.kf.x[0, 0]), float(self.kf.x[1, 0])
            # only a significant rate (beyond 2 sigma) sets the floor: no feedback from noise
            rate = max(abs(rate) - 2.0 * math.sqrt(max(float(self.kf.P[1, 1]), 0.0)), 0.0)
            floor = rate ** 3 / max(abs(u), 1e-3)
            self.process_noise = min(max(self.q_test, floor), self.adaptation.q_max)
        return self.last

    def _settle_offset(self) -> None:
        """Take d as the drift report's reference once its sigma is settled.

        That is below :data:`OFFSET_SETTLED_SIGMA` (after both directions have been seen).
        """
        if not math.isfinite(self.offset_reference[0]) and \
                self.direction_offset_sigma < OFFSET_SETTLED_SIGMA:
            self.offset_reference = (self.direction_offset, float(self.kf.P[2, 2]))

    def to_state(self) -> dict[str, Any]:
        """Return what a restart needs to continue (JSON-safe, :mod:`gear_phm.persistence`).

        x = [u, du/dt, d], P (row-major, 3x3), time t [s], q, the adaptation's sums and the
        settled offset; the settings come from the configuration, not from the state.
        """
        last = self.last
        return {
            'offset_reference': encode_floats(self.offset_reference),
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
        """Restore :meth:`to_state`; KeyError/ValueError/TypeError on a malformed dict.

        A state of the two-state filter (x 2 values, P 4; before the direction offset) is
        taken with d = 0 at its prior variance.
        """
        x = decode_floats(state['x'])
        p = decode_floats(state['P'])
        if len(x) == 2 and len(p) == 4:
            x = [*x, 0.0]
            p = [p[0], p[1], 0.0, p[2], p[3], 0.0, 0.0, 0.0, self.offset_sigma ** 2]
        if len(x) != 3 or len(p) != 9:
            raise ValueError('filter state: x needs 3 values and P 9 (or 2 and 4)')
        reference = decode_floats(state.get('offset_reference', ['nan', 'nan']))
        if len(reference) != 2:
            raise ValueError('filter state: offset_reference needs 2 values')
        pairs = {key: decode_floats(state[key])
                 for key in ('mean', 'excess', 'num', 'den', 'mean_den')}
        n = [int(v) for v in state['n']]
        if len(n) != 2 or any(len(v) != 2 for v in pairs.values()):
            raise ValueError('filter state: per-direction values need 2 entries')
        last = state['last']
        self.kf.x = np.array(x).reshape(3, 1)
        self.kf.P = np.array(p).reshape(3, 3)
        self.offset_reference = (reference[0], reference[1])
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

    def _adapt(self, y: float, p_uu: float, r: float, s: float, direction: int,
               gated: bool) -> None:
        """Run one step of both adaptations (before the update).

        ``y`` innovation, ``p_uu`` its prior variance H P H', ``r`` base variance, ``s``
        innovation variance; ``gated``: the window fails the gate (it still feeds the
        matching, winsorised).
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
            self._match(y, p_uu, r, s, direction, common)
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
        # y - mean has the variance S plus the mean's own, 1 / (its sum of weights): clipped
        # at S alone, a mean set by the first, imprecise windows (the prior's error of u, 0.1,
        # at a window whose rotor inertia was not known yet) was undone only 0.003 per window
        # and was taken as a mismatch for minutes (docs/estimation.md)
        spread = s + (1.0 / self._mean_den[direction] if self._mean_den[direction] > 0.0
                      else math.inf)
        mean_limit = math.sqrt(max(self.gate_threshold, 1.0) * spread)
        self._mean_den[direction] = keep * self._mean_den[direction] + 1.0 / s
        step = min(max(y - mean[direction], -mean_limit), mean_limit)
        mean[direction] += step / (s * self._mean_den[direction])
        deviation = min(abs(y - common), limit)
        weight = 1.0 / (s * s)
        self._num[direction] = keep * self._num[direction] \
            + weight * (deviation ** 2 - p_uu - r)
        self._den[direction] = keep * self._den[direction] + weight
        # a variance is used once it is significant, beyond its standard error
        # se = sqrt(2 / sum of weights), so a plant without mismatch is not made
        # conservative; beyond it shrunk by se^2 / estimate (positive part, continuous at se),
        # which vanishes as the mismatch dominates. Shrinking by se throughout, as before,
        # left the variance short by sqrt(2 / mismatch_memory) ~ 0.2 S where the mismatch
        # dominates S: NIS mean 1.25, and "model mismatch" WARNs on healthy gearboxes
        # (docs/estimation.md, "Rotor inertia in the measurement variance")
        estimate = self._num[direction] / self._den[direction]
        se = math.sqrt(2.0 / self._den[direction])
        self._excess[direction] = estimate - (se * se / estimate if estimate > se else se)
