"""Flight-control duty cycle of the load (a flap or slat surface), vectorised over time.

One cycle of period ``extend_time + dwell_extended + retract_time + dwell_retracted`` [s]:

1. extend: the surface moves from 0 (retracted) to ``travel`` [rad] against the air load
   (opposing load, power flows motor -> load);
2. dwell at ``travel`` (zero speed, the gearbox holds the air load);
3. retract: back to 0, the air load drives the surface (aiding load, load -> motor);
4. dwell at 0.

Each stroke is a trapezoidal speed profile with raised-cosine ramps of ``accel_time`` [s]
(continuous acceleration), so the constant-speed part of a stroke lasts
``stroke_time - 2 accel_time`` and the peak load speed is ``travel / (stroke_time -
accel_time)`` [rad/s]. Everything is closed form: any array of times, in any order, gives the
same values (no integration state).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.simulation._checks import non_negative, positive


@dataclass(frozen=True)
class DutyCycle:
    """Load-side motion profile. Angles [rad], times [s]; see the module docstring."""

    travel: float = 0.6
    extend_time: float = 2.5
    retract_time: float = 2.0
    accel_time: float = 0.25
    dwell_extended: float = 0.5
    dwell_retracted: float = 0.5

    def __post_init__(self) -> None:
        positive('travel', self.travel)
        accel = positive('accel_time', self.accel_time)
        for name in ('extend_time', 'retract_time'):
            stroke = positive(name, getattr(self, name))
            if stroke < 2.0 * accel:
                raise ValueError(
                    f'{name} must be >= 2 accel_time = {2.0 * accel:g} s, got {stroke!r}')
        non_negative('dwell_extended', self.dwell_extended)
        non_negative('dwell_retracted', self.dwell_retracted)

    @property
    def period(self) -> float:
        """Duration of one cycle [s]."""
        return float(self.extend_time + self.dwell_extended
                     + self.retract_time + self.dwell_retracted)

    @property
    def extend_speed(self) -> float:
        """Constant load speed while extending [rad/s]."""
        return float(self.travel / (self.extend_time - self.accel_time))

    @property
    def retract_speed(self) -> float:
        """Constant load speed magnitude while retracting [rad/s]."""
        return float(self.travel / (self.retract_time - self.accel_time))

    def load_motion(self, t: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Load (position [rad], velocity [rad/s], acceleration [rad/s^2]) at times t [s]."""
        t = np.asarray(t, dtype=float)
        if not np.all(np.isfinite(t)):
            raise ValueError('t must be finite')
        tau = np.mod(t, self.period)
        position = np.zeros_like(tau)
        velocity = np.zeros_like(tau)
        acceleration = np.zeros_like(tau)

        extending = tau < self.extend_time
        x, v, a = _stroke(tau[extending], self.extend_time, self.accel_time, self.travel)
        position[extending], velocity[extending], acceleration[extending] = x, v, a

        start_retract = self.extend_time + self.dwell_extended
        at_top = (tau >= self.extend_time) & (tau < start_retract)
        position[at_top] = self.travel

        retracting = (tau >= start_retract) & (tau < start_retract + self.retract_time)
        x, v, a = _stroke(tau[retracting] - start_retract, self.retract_time,
                          self.accel_time, self.travel)
        position[retracting] = self.travel - x
        velocity[retracting], acceleration[retracting] = -v, -a
        return position, velocity, acceleration


def _stroke(tau: np.ndarray, duration: float, ramp: float,
            distance: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distance, speed, acceleration of one raised-cosine trapezoid stroke at tau in [0, T)."""
    peak = distance / (duration - ramp)
    omega = np.pi / ramp
    rising = tau < ramp
    falling = tau > duration - ramp
    remaining = duration - tau
    x = peak * (0.5 * ramp + (tau - ramp))
    v = np.full_like(tau, peak)
    a = np.zeros_like(tau)
    s = tau[rising]
    x[rising] = 0.5 * peak * (s - np.sin(omega * s) / omega)
    v[rising] = 0.5 * peak * (1.0 - np.cos(omega * s))
    a[rising] = 0.5 * peak * omega * np.sin(omega * s)
    s = remaining[falling]
    x[falling] = distance - 0.5 * peak * (s - np.sin(omega * s) / omega)
    v[falling] = 0.5 * peak * (1.0 - np.cos(omega * s))
    a[falling] = -0.5 * peak * omega * np.sin(omega * s)
    return x, v, a
