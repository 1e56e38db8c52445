"""Sensor model: gain error, mesh ripple, offset (bias), white noise, quantisation; encoders.

Channels, in the order of the noise draws: motor velocity, load velocity [rad/s], motor torque,
load torque [N m]. Each channel reads::

    measured = Q((1 + gain) true + ripple sin(teeth theta_m) + bias + sigma N(0, 1))

``teeth theta_m`` is the mesh angle (teeth of the pinion on the motor shaft times the motor
position), so the ripple's frequency is teeth x shaft speed; Q rounds to a multiple of
``quantum`` (0: no rounding). Positions are the exact integrals of the true velocities, or,
with an encoder of ``encoder_counts_*`` counts per revolution, the true position rounded down
to a count; the velocity is then the difference of two consecutive readings over their time
step (the first sample of a run reads 0), plus the channel's errors above.
"""
from __future__ import annotations

from dataclasses import dataclass, field
import math

import numpy as np

from gear_phm.simulation._checks import non_negative, real

CHANNELS: tuple[str, ...] = ('velocity_motor', 'velocity_load', 'effort_motor', 'effort_load')


@dataclass(frozen=True)
class Channel:
    """One sensor (see the module docstring). Units of the channel; ``gain`` [-]."""

    sigma: float = 0.0
    bias: float = 0.0
    gain: float = 0.0
    ripple: float = 0.0
    quantum: float = 0.0

    def __post_init__(self) -> None:
        non_negative('sigma', self.sigma)
        real('bias', self.bias)
        if not (math.isfinite(self.gain) and self.gain > -1.0):
            raise ValueError(f'gain must be > -1 (the sensor keeps its sign), got '
                             f'{self.gain!r}')
        non_negative('ripple', self.ripple)
        non_negative('quantum', self.quantum)


@dataclass(frozen=True)
class Sensors:
    """Noise of the four measured channels (defaults: small, realistic, unbiased).

    ``encoder_counts_motor``, ``encoder_counts_load``: counts per revolution of the position
    encoders (0: exact positions and velocities, as the plant's).
    """

    velocity_motor: Channel = field(default_factory=lambda: Channel(0.01))
    velocity_load: Channel = field(default_factory=lambda: Channel(0.005))
    effort_motor: Channel = field(default_factory=lambda: Channel(0.05))
    effort_load: Channel = field(default_factory=lambda: Channel(0.2))
    encoder_counts_motor: int = 0
    encoder_counts_load: int = 0

    def __post_init__(self) -> None:
        for name in CHANNELS:
            if not isinstance(getattr(self, name), Channel):
                raise ValueError(f'{name} must be a Channel, got {getattr(self, name)!r}')
        for name in ('encoder_counts_motor', 'encoder_counts_load'):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) \
                    or value < 0:
                raise ValueError(f'{name} must be an integer >= 0, got {value!r}')

    @property
    def encoders(self) -> bool:
        """Return True if a position encoder quantises a position."""
        return bool(self.encoder_counts_motor or self.encoder_counts_load)

    def measure(self, truth: np.ndarray, rng: np.random.Generator,
                mesh_angle: np.ndarray | None = None) -> np.ndarray:
        """Measured channels, shape (n, 4), from true channels ``truth`` (n, 4), CHANNELS order.

        ``mesh_angle`` [rad] (n,): teeth x motor position, for the ripple. Draws exactly
        4 n normals, row by row, so chunked calls equal one big call.
        """
        channels = [getattr(self, c) for c in CHANNELS]
        sigma = np.array([c.sigma for c in channels])
        bias = np.array([c.bias for c in channels])
        gain = np.array([c.gain for c in channels])
        ripple = np.array([c.ripple for c in channels])
        quantum = np.array([c.quantum for c in channels])
        base = truth * (1.0 + gain) if gain.any() else truth
        if ripple.any():
            if mesh_angle is None:
                raise ValueError('a mesh ripple needs the mesh angle')
            base = base + ripple * np.sin(mesh_angle)[:, None]
        measured: np.ndarray = base + bias + sigma * rng.standard_normal(truth.shape)
        if quantum.any():
            step = np.where(quantum > 0.0, quantum, 1.0)
            measured = np.where(quantum > 0.0, np.round(measured / step) * step, measured)
        return measured


def encoder_reading(position: np.ndarray, counts: int) -> np.ndarray:
    """Position [rad] an encoder of ``counts`` per revolution reads (rounded down to a count)."""
    if not counts:
        return position
    step = 2.0 * math.pi / counts
    reading: np.ndarray = np.floor(position / step) * step
    return reading


def differenced(reading: np.ndarray, t: np.ndarray, previous: tuple[float, float] | None
                ) -> np.ndarray:
    """Velocity [rad/s] by backward differences of ``reading`` [rad] at times t [s].

    ``previous``: (time, reading) of the sample before the first, None at a run's start
    (its first velocity is 0).
    """
    before = np.empty_like(reading)
    t_before = np.empty_like(t)
    before[1:], t_before[1:] = reading[:-1], t[:-1]
    if previous is None:
        before[0], t_before[0] = reading[0], t[0] - 1.0
    else:
        t_before[0], before[0] = previous
    step = t - t_before
    velocity: np.ndarray = np.where(step > 0.0, (reading - before) / np.where(
        step > 0.0, step, 1.0), 0.0)
    return velocity
