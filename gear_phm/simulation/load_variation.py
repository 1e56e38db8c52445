"""Load amplitude that varies from cycle to cycle and within a cycle.

The air load of the duty cycle (``T0 + k theta``, :mod:`gear_phm.simulation.plant`) is
multiplied by a scale [-] at operating time s [s]::

    scale(s) = c_n (1 + modulation (sin(2 pi f_1 s + p_1) + sin(2 pi f_2 s + p_2)) / 2)

- c_n, the cycle's factor, is uniform in [scale_min, scale_max], one draw per cycle
  n = floor(s / period) (another flight condition every cycle); cycle n is draw n % 4096 of
  ``numpy.random.default_rng([seed, LOAD_STREAM, n // 4096])``;
- the modulation is a smooth low-frequency component of relative amplitude ``modulation``:
  f_1, f_2 are ``frequency`` times U(0.5, 1.5) and p_1, p_2 U(0, 2 pi), drawn once from
  ``default_rng([seed, LOAD_STREAM, MODULATION_BLOCK])``.

Closed form in s: any times, in any order, give the same values. With the defaults (range
1..1, no modulation) the scale is exactly 1 and nothing is drawn.
"""
from __future__ import annotations

from dataclasses import dataclass
import functools
import math

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.simulation._checks import non_negative, positive

#: Tag of the load variation's streams (numpy SeedSequence entropy).
LOAD_STREAM = 0x6C6F6164
#: Cycle factors per block of draws.
BLOCK = 4096
#: The block key of the modulation's frequencies and phases (no cycle block uses it).
MODULATION_BLOCK = 2**62


@dataclass(frozen=True)
class LoadVariation:
    """Cycle factor range [scale_min, scale_max] [-], modulation [-] and frequency [Hz]."""

    scale_min: float = 1.0
    scale_max: float = 1.0
    modulation: float = 0.0
    frequency: float = 0.3

    def __post_init__(self) -> None:
        low = positive('load_scale_min', self.scale_min)
        high = positive('load_scale_max', self.scale_max)
        if low > high:
            raise ValueError(f'load_scale_min must be <= load_scale_max = {high:g}, got '
                             f'{low!r}')
        modulation = non_negative('load_modulation', self.modulation)
        if modulation >= 1.0:
            raise ValueError(f'load_modulation must be < 1 (the load keeps its sign), got '
                             f'{modulation!r}')
        positive('load_modulation_frequency', self.frequency)

    @property
    def enabled(self) -> bool:
        """Return True unless the scale is 1 throughout."""
        return self.scale_min != 1.0 or self.scale_max != 1.0 or self.modulation > 0.0

    def scale(self, s: ArrayLike, period: float, seed: int) -> np.ndarray:
        """Scale of the air load [-] at operating times s [s], cycles of ``period`` [s]."""
        s = np.asarray(s, dtype=float)
        scale = np.ones_like(s)
        if self.scale_max != self.scale_min or self.scale_min != 1.0:
            cycle = np.floor(s / period).astype(np.int64)
            blocks, slot = np.divmod(cycle, BLOCK)
            for block in np.unique(blocks):
                where = blocks == block
                draws = _cycle_draws(int(seed), int(block) % (1 << 62))
                scale[where] = self.scale_min + (self.scale_max - self.scale_min) \
                    * draws[slot[where]]
        if self.modulation > 0.0:
            frequencies, phases = _modulation_draws(int(seed))
            wave = sum(np.sin(2.0 * math.pi * self.frequency * f * s + p)
                       for f, p in zip(frequencies, phases))
            scale = scale * (1.0 + self.modulation * 0.5 * wave)
        return scale


@functools.lru_cache(maxsize=8)
def _cycle_draws(seed: int, block: int) -> np.ndarray:
    """U(0, 1) draws of the BLOCK cycles of ``block``."""
    draws: np.ndarray = np.random.default_rng([seed, LOAD_STREAM, block]).uniform(size=BLOCK)
    return draws


@functools.lru_cache(maxsize=8)
def _modulation_draws(seed: int) -> tuple[tuple[float, float], tuple[float, float]]:
    """(frequency factors, phases [rad]) of the two modulation terms."""
    rng = np.random.default_rng([seed, LOAD_STREAM, MODULATION_BLOCK])
    factors = rng.uniform(0.5, 1.5, 2)
    phases = rng.uniform(0.0, 2.0 * math.pi, 2)
    return (float(factors[0]), float(factors[1])), (float(phases[0]), float(phases[1]))
