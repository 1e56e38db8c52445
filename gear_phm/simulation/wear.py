"""Wear trajectory of the plant's friction value (lever u or spur tooth coefficient f) [-].

``kind``:

- ``constant``:    value(t) = initial
- ``linear``:      value(t) = initial + rate t                 (rate [1/s], absolute)
- ``exponential``: value(t) = initial exp(rate t)              (rate [1/s], relative growth)
- ``power``:       value(t) = initial + rate t^exponent         (rate [1/s^exponent])
- ``step``:        value(t) = initial + step for t >= t_fault, initial before (sudden fault)

Time t [s] is simulation time (``t = 0`` at the start of a run). Wear never decreases.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.simulation._checks import non_negative, one_of

WEAR_KINDS: tuple[str, ...] = ('constant', 'linear', 'exponential', 'power', 'step')
#: Wear kinds that :meth:`Wear.reaching` can aim at a final value.
REACHING_KINDS: tuple[str, ...] = ('linear', 'exponential', 'power')


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

    def __post_init__(self) -> None:
        one_of('kind', self.kind, WEAR_KINDS)
        initial = non_negative('initial', self.initial)
        non_negative('rate', self.rate)
        non_negative('t_fault', self.t_fault)
        non_negative('step', self.step)
        if not self.exponent > 0.0 or self.exponent == float('inf'):
            raise ValueError(f'exponent must be > 0 and finite, got {self.exponent!r}')
        if self.kind == 'exponential' and initial == 0.0 and self.rate > 0.0:
            raise ValueError('initial must be > 0 for exponential wear, got 0.0')

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

    def value(self, t: ArrayLike) -> np.ndarray:
        """Friction value [-] at times t [s] (same shape as t)."""
        t = np.asarray(t, dtype=float)
        if self.kind == 'linear':
            return self.initial + self.rate * t
        if self.kind == 'exponential':
            return self.initial * np.exp(self.rate * t)
        if self.kind == 'power':
            grown: np.ndarray = self.initial + self.rate * np.power(np.maximum(t, 0.0),
                                                                    self.exponent)
            return grown
        if self.kind == 'step':
            return np.where(t >= self.t_fault, self.initial + self.step, self.initial)
        return np.full_like(t, self.initial)
