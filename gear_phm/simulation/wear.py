"""Wear trajectory of the plant's friction value (lever u or spur tooth coefficient f) [-].

``kind`` sets the wear law L(tau) of the wear clock tau [s]:

- ``constant``:    L = initial
- ``linear``:      L = initial + rate tau                 (rate [1/s], absolute)
- ``exponential``: L = initial exp(rate tau)              (rate [1/s], relative growth)
- ``power``:       L = initial + rate tau^exponent         (rate [1/s^exponent])
- ``mixed``:       L = initial + rate tau + exp_amplitude (exp(exp_rate tau) - 1)
  + power_coefficient tau^exponent                      (a sum of the three terms)
- ``step``:        initial + step for t >= t_fault, initial before (sudden fault; no clock)

The friction value is::

    value(t) = base + L(tau(t)) + running_in exp(-t / running_in_time)

- ``base`` [-]: friction that never wears (offset laws: base + initial exp(rate tau) ...);
- ``running_in`` [-]: excess friction at t = 0 that decays with ``running_in_time`` [s]
  (a new gearbox running in: its friction falls at first);
- the wear clock tau(t) = max(t - onset, 0) + (regime_factor - 1) max(t - max(regime_time,
  onset), 0): a healthy plateau until ``onset`` [s], then wear; from ``regime_time`` [s] the
  wear runs ``regime_factor`` times faster (a regime change, value continuous).

Stochastic wear (``process`` ``gamma`` or ``wiener``) replaces the wear part W(t) = L(tau(t)) -
L(0) by a random path X around it, drawn on the fixed grid t_k = k ``process_step`` [s] and
interpolated linearly in between. Its increments over [t_k, t_k+1] have the mean law's mean
dW_k = W(t_k+1) - W(t_k) and the variance ``process_scale`` dW_k:

- ``gamma``:  Gamma(shape dW_k / process_scale, scale process_scale); the path never decreases;
- ``wiener``: dW_k + sqrt(process_scale dW_k) N(0, 1) (Brownian motion in the mean wear's
  time scale, a Wiener process with drift).

So Var X(t) = process_scale W(t): no noise on the plateau. The path is a function of the seed
alone (:meth:`Wear.path`), whatever the times it is asked for and in which blocks. Time t [s]
is simulation time (``t = 0`` at the start of a run). Friction values below 0 are clipped to 0.
"""
from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.simulation._checks import non_negative, one_of, positive

WEAR_KINDS: tuple[str, ...] = ('constant', 'linear', 'exponential', 'power', 'step', 'mixed')
#: Wear kinds that :meth:`Wear.reaching` can aim at a final value.
REACHING_KINDS: tuple[str, ...] = ('linear', 'exponential', 'power')
#: Stochastic processes of the wear part (``none``: the mean law itself).
PROCESSES: tuple[str, ...] = ('none', 'gamma', 'wiener')
#: Grid steps per block of the stochastic path; each block has its own random stream.
PATH_BLOCK = 4096
#: Tag of the stochastic path's streams, numpy SeedSequence entropy [seed, PATH_STREAM, block].
PATH_STREAM = 0x77656172


@dataclass(frozen=True)
class Wear:
    """Friction value as a function of time; see the module docstring. Values [-], times [s]."""

    kind: str = 'constant'
    initial: float = 0.05
    rate: float = 0.0
    t_fault: float = 0.0
    step: float = 0.0
    #: power wear: exponent of t (> 0; 1 is linear, > 1 accelerating)
    exponent: float = 2.0
    #: mixed wear: amplitude [-] and relative growth rate [1/s] of the exponential term
    exp_amplitude: float = 0.0
    exp_rate: float = 0.0
    #: mixed wear: coefficient of tau^exponent [1/s^exponent]
    power_coefficient: float = 0.0
    base: float = 0.0
    onset: float = 0.0
    running_in: float = 0.0
    running_in_time: float = 60.0
    regime_time: float = 0.0
    regime_factor: float = 1.0
    process: str = 'none'
    process_scale: float = 0.0
    process_step: float = 1.0

    def __post_init__(self) -> None:
        one_of('kind', self.kind, WEAR_KINDS)
        initial = non_negative('initial', self.initial)
        for name in ('rate', 't_fault', 'step', 'exp_amplitude', 'exp_rate',
                     'power_coefficient', 'base', 'onset', 'running_in', 'regime_time',
                     'process_scale'):
            non_negative(name, getattr(self, name))
        positive('running_in_time', self.running_in_time)
        positive('regime_factor', self.regime_factor)
        positive('process_step', self.process_step)
        one_of('process', self.process, PROCESSES)
        if not self.exponent > 0.0 or self.exponent == float('inf'):
            raise ValueError(f'exponent must be > 0 and finite, got {self.exponent!r}')
        if self.kind == 'exponential' and initial == 0.0 and self.rate > 0.0:
            raise ValueError('initial must be > 0 for exponential wear, got 0.0')
        if self.process != 'none' and self.kind == 'step':
            raise ValueError(f'process {self.process} needs a continuous wear law, got kind '
                             f'step')

    @classmethod
    def reaching(cls, kind: str, initial: float, final: float, duration: float,
                 exponent: float = 2.0) -> Wear:
        """Return linear, exponential or power wear from ``initial`` to ``final`` in ``duration``.

        ``duration`` [s]; ``exponent`` is the power law's.
        """
        one_of('kind', kind, REACHING_KINDS)
        initial = non_negative('initial', initial)
        final = non_negative('final', final)
        if final < initial:
            raise ValueError(f'final must be >= initial = {initial!r}, got {final!r}')
        if duration <= 0.0:
            raise ValueError(f'duration must be > 0, got {duration!r}')
        if kind == 'linear':
            return cls('linear', initial, (final - initial) / duration)
        if kind == 'power':
            return cls('power', initial, (final - initial) / duration ** exponent,
                       exponent=exponent)
        if initial <= 0.0:
            raise ValueError('initial must be > 0 for exponential wear, got 0.0')
        return cls('exponential', initial, float(np.log(final / initial) / duration))

    def clock(self, t: ArrayLike) -> np.ndarray:
        """Wear clock tau [s] at times t [s]: 0 until onset, regime_factor times faster later."""
        t = np.asarray(t, dtype=float)
        if self.onset == 0.0 and self.regime_factor == 1.0:
            return t                              # the original laws, bit for bit
        tau: np.ndarray = np.maximum(t - self.onset, 0.0)
        if self.regime_factor != 1.0:
            start = max(self.regime_time, self.onset)
            tau = tau + (self.regime_factor - 1.0) * np.maximum(t - start, 0.0)
        return tau

    def law(self, tau: ArrayLike) -> np.ndarray:
        """Wear law L [-] at wear-clock times tau [s] (without base, running-in, step)."""
        tau = np.asarray(tau, dtype=float)
        if self.kind == 'linear':
            return self.initial + self.rate * tau
        if self.kind == 'exponential':
            return self.initial * np.exp(self.rate * tau)
        if self.kind == 'power':
            grown: np.ndarray = self.initial + self.rate * np.power(np.maximum(tau, 0.0),
                                                                    self.exponent)
            return grown
        if self.kind == 'mixed':
            positive_tau = np.maximum(tau, 0.0)
            mixed: np.ndarray = (self.initial + self.rate * positive_tau
                                 + self.exp_amplitude * np.expm1(self.exp_rate * positive_tau)
                                 + self.power_coefficient * np.power(positive_tau,
                                                                     self.exponent))
            return mixed
        return np.full_like(tau, self.initial)

    def value(self, t: ArrayLike) -> np.ndarray:
        """Mean friction value [-] at times t [s] (same shape as t); the stochastic path's mean."""
        t = np.asarray(t, dtype=float)
        if self.kind == 'step':
            friction = np.where(t >= self.t_fault, self.initial + self.step, self.initial)
        else:
            friction = self.law(self.clock(t))
        return self._offsets(t, friction)

    def wear_part(self, t: ArrayLike) -> np.ndarray:
        """Mean wear W(t) = L(tau(t)) - L(0) [-], 0 until onset, never decreasing."""
        part: np.ndarray = self.law(self.clock(t)) - self.law(0.0)
        return part

    def path(self, seed: int) -> WearPath:
        """Return the friction trajectory of a run seeded with ``seed`` (its stochastic path)."""
        return WearPath(self, seed)

    def _offsets(self, t: np.ndarray, friction: np.ndarray) -> np.ndarray:
        """Add the base friction and the running-in excess; clip at 0 only if they are set."""
        if self.base == 0.0 and self.running_in == 0.0:
            return friction
        friction = friction + self.base + self.running_in * np.exp(
            -np.maximum(t, 0.0) / self.running_in_time)
        clipped: np.ndarray = np.maximum(friction, 0.0)
        return clipped


class WearPath:
    """Friction value of one run: the mean law, or its seeded stochastic path.

    The path's grid values are drawn block by block (:data:`PATH_BLOCK` steps per block,
    block ``b`` from ``numpy.random.default_rng([seed, PATH_STREAM, b])``) and kept, so memory
    is 8 bytes per ``process_step`` of the longest time asked for (240 kB for 30 000 s at 1 s).
    """

    def __init__(self, wear: Wear, seed: int) -> None:
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ValueError(f'seed must be an integer >= 0, got {seed!r}')
        self.wear = wear
        self.seed = int(seed)
        self._levels = np.zeros(1)               # X(t_k), k = 0 .. len - 1; X(0) = 0

    def value(self, t: ArrayLike) -> np.ndarray:
        """Friction value [-] at times t [s] (any order, any block)."""
        wear = self.wear
        t = np.asarray(t, dtype=float)
        if wear.process == 'none' or t.size == 0:
            return wear.value(t)
        dt = wear.process_step
        grid_t = np.maximum(t, 0.0) / dt
        self._extend(int(math.floor(float(np.max(grid_t)))) + 2)
        k = np.minimum(np.floor(grid_t).astype(np.int64), len(self._levels) - 2)
        share = grid_t - k
        wear_now = self._levels[k] * (1.0 - share) + self._levels[k + 1] * share
        friction = wear.law(0.0) + wear_now
        if wear.base == 0.0 and wear.running_in == 0.0:
            clipped: np.ndarray = np.maximum(friction, 0.0)
            return clipped
        return wear._offsets(t, friction)

    def _extend(self, points: int) -> None:
        """Draw whole blocks until the grid holds at least ``points`` levels."""
        wear = self.wear
        while len(self._levels) < points:
            block = (len(self._levels) - 1) // PATH_BLOCK
            k0 = block * PATH_BLOCK
            edges = wear.wear_part(np.arange(k0, k0 + PATH_BLOCK + 1) * wear.process_step)
            mean = np.maximum(np.diff(edges), 0.0)
            rng = np.random.default_rng([self.seed, PATH_STREAM, block])
            scale = wear.process_scale
            if scale == 0.0:
                steps = mean
            elif wear.process == 'gamma':
                steps = rng.gamma(mean / scale, scale)      # shape 0 gives 0
            else:
                steps = mean + np.sqrt(scale * mean) * rng.standard_normal(mean.shape)
            self._levels = np.concatenate((self._levels, self._levels[-1] + np.cumsum(steps)))
