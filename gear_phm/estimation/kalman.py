"""Kalman filter on the friction parameter: x = [u, du/dt], filterpy underneath."""
from __future__ import annotations

from dataclasses import dataclass
import math

from filterpy.kalman import KalmanFilter
import numpy as np


@dataclass(frozen=True)
class UpdateResult:
    """Outcome of one pseudo-measurement: innovation y [-], its variance S, NIS [-]."""

    accepted: bool
    innovation: float
    innovation_variance: float
    nis: float
    reinitialised: bool = False


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


class FrictionFilter:
    """filterpy ``KalmanFilter`` on [u, du/dt] with H = [1, 0] and Mahalanobis gating.

    ``predict(t)`` moves the state to time ``t`` [s]; ``update(z, r, t)`` gates and fuses a
    pseudo-measurement ``z`` of u with variance ``r``. After ``max_consecutive_gated``
    rejections in a row the filter re-initialises on the measurement (a step fault).
    """

    def __init__(self, initial_u: float, initial_u_sigma: float, initial_rate_sigma: float,
                 process_noise: float, gate_threshold: float,
                 max_consecutive_gated: int) -> None:
        self.initial_u_sigma = float(initial_u_sigma)
        self.initial_rate_sigma = float(initial_rate_sigma)
        self.process_noise = float(process_noise)
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

    def update(self, z: float, r: float, t: float) -> UpdateResult:
        """Predict to ``t`` [s], gate on NIS and fuse ``z`` (variance ``r``) if it passes."""
        if not (math.isfinite(z) and math.isfinite(r) and r > 0.0):
            raise ValueError(f'measurement must be finite with variance > 0, got z={z!r}, '
                             f'r={r!r}')
        self.predict(t)
        y = z - float(self.kf.x[0, 0])
        s = float(self.kf.P[0, 0]) + r
        nis = y * y / s
        if nis > self.gate_threshold:
            self.consecutive_gated += 1
            if self.consecutive_gated < self.max_consecutive_gated:
                self.last = UpdateResult(False, y, s, nis)
                return self.last
            self._initialise(z, r)
            self.consecutive_gated = 0
            self.updates += 1
            self.last = UpdateResult(True, y, s, nis, reinitialised=True)
            return self.last
        self.consecutive_gated = 0
        self.kf.update(np.array([[z]]), R=r)
        self.updates += 1
        self.last = UpdateResult(True, float(self.kf.y[0, 0]), float(self.kf.S[0, 0]), nis)
        return self.last
