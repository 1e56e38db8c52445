"""Sensor model: white Gaussian noise (standard deviation ``sigma``) plus a constant bias.

Channels, in the order of the noise draws: motor velocity, load velocity [rad/s], motor torque,
load torque [N m]. Positions are the exact integrals of the true velocities (encoders).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gear_phm.simulation._checks import non_negative, real

CHANNELS: tuple[str, ...] = ('velocity_motor', 'velocity_load', 'effort_motor', 'effort_load')


@dataclass(frozen=True)
class Channel:
    """One sensor: measured = true + bias + sigma * N(0, 1). Units of the channel."""

    sigma: float = 0.0
    bias: float = 0.0

    def __post_init__(self) -> None:
        non_negative('sigma', self.sigma)
        real('bias', self.bias)


@dataclass(frozen=True)
class Sensors:
    """Noise of the four measured channels (defaults: small, realistic, unbiased)."""

    velocity_motor: Channel = field(default_factory=lambda: Channel(0.01))
    velocity_load: Channel = field(default_factory=lambda: Channel(0.005))
    effort_motor: Channel = field(default_factory=lambda: Channel(0.05))
    effort_load: Channel = field(default_factory=lambda: Channel(0.2))

    def __post_init__(self) -> None:
        for name in CHANNELS:
            if not isinstance(getattr(self, name), Channel):
                raise ValueError(f'{name} must be a Channel, got {getattr(self, name)!r}')

    def measure(self, truth: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Measured channels, shape (n, 4), from true channels ``truth`` (n, 4), CHANNELS order.

        Draws exactly 4 n normals, row by row, so chunked calls equal one big call.
        """
        sigma = np.array([getattr(self, c).sigma for c in CHANNELS])
        bias = np.array([getattr(self, c).bias for c in CHANNELS])
        measured: np.ndarray = truth + bias + sigma * rng.standard_normal(truth.shape)
        return measured
