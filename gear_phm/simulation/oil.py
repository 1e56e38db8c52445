"""Oil temperature of the gearbox and the viscosity factor of its no-load drag.

The temperature T [degC] is a first-order state on elapsed time t [s]: while the gearbox runs
(the duty cycle, dwells included) it tends to ``running_temperature`` with the time constant
``warm_time_constant``; in an idle gap (:class:`~gear_phm.simulation.idle_gap.IdleGap`) it
tends to ``ambient_temperature`` with ``cool_time_constant``. At ``start`` [s] it is
``T_amb + initial_warmth (T_run - T_amb)`` (0: the ambient temperature, a cold start; 1:
warm)::

    T(t) = T_target + (T(t0) - T_target) exp(-(t - t0) / tau)      on each stretch from t0

The drag of the oil scales like its viscosity, between ``cold_factor`` at the ambient
temperature and 1 at the running temperature::

    factor(T) = exp(ln(cold_factor) (T_run - T) / (T_run - T_amb))             [-]

Closed form: any times, in any order, give the same values (no integration state).
"""
from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.simulation._checks import positive, real
from gear_phm.simulation.idle_gap import IdleGap


@dataclass(frozen=True)
class Oil:
    """Oil temperature model; temperatures [degC], time constants and ``start`` [s]."""

    ambient_temperature: float = 20.0
    running_temperature: float = 60.0
    warm_time_constant: float = 900.0
    cool_time_constant: float = 1800.0
    initial_warmth: float = 0.0
    cold_factor: float = 1.0
    start: float = 0.0

    def __post_init__(self) -> None:
        ambient = real('oil_ambient_temperature', self.ambient_temperature)
        running = real('oil_running_temperature', self.running_temperature)
        if not running > ambient:
            raise ValueError(f'oil_running_temperature must be above oil_ambient_temperature '
                             f'= {ambient:g} degC (the oil warms while running), got '
                             f'{running!r}')
        positive('oil_warm_time_constant', self.warm_time_constant)
        positive('oil_cool_time_constant', self.cool_time_constant)
        warmth = real('oil_initial_warmth', self.initial_warmth)
        if not 0.0 <= warmth <= 2.0:
            raise ValueError(f'oil_initial_warmth must be in [0, 2], got {warmth!r}')
        if not (math.isfinite(self.cold_factor) and self.cold_factor >= 1.0):
            raise ValueError(f'no_load_cold_factor must be >= 1, got {self.cold_factor!r}')
        real('start', self.start)

    @property
    def initial(self) -> float:
        """Temperature at ``start`` [degC]."""
        ambient = float(self.ambient_temperature)
        return ambient + float(self.initial_warmth) * (float(self.running_temperature) - ambient)

    def temperature(self, t: ArrayLike, gap: IdleGap = IdleGap()) -> np.ndarray:
        """Oil temperature [degC] at elapsed times t [s] (before ``start``: the initial one)."""
        t = np.maximum(np.asarray(t, dtype=float) - self.start, 0.0)
        run, ambient = self.running_temperature, self.ambient_temperature
        warm, cool = self.warm_time_constant, self.cool_time_constant
        temperature = run + (self.initial - run) * np.exp(-t / warm)
        if not gap.enabled:
            return temperature
        at = max(gap.at - self.start, 0.0)
        end = at + gap.duration
        before = run + (self.initial - run) * math.exp(-at / warm)
        after = ambient + (before - ambient) * math.exp(-gap.duration / cool)
        idle = (t >= at) & (t < end)
        temperature[idle] = ambient + (before - ambient) * np.exp(-(t[idle] - at) / cool)
        late = t >= end
        temperature[late] = run + (after - run) * np.exp(-(t[late] - end) / warm)
        return temperature

    def drag_factor(self, temperature: ArrayLike) -> np.ndarray:
        """Viscosity factor of the no-load drag at ``temperature`` [degC] (1 when warm)."""
        temperature = np.asarray(temperature, dtype=float)
        if self.cold_factor == 1.0:
            return np.ones_like(temperature)
        share = (self.running_temperature - temperature) \
            / (self.running_temperature - self.ambient_temperature)
        factor: np.ndarray = np.exp(math.log(self.cold_factor) * share)
        return factor
