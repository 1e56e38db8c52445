"""Seeded simplified-model (lever) plant used by the estimation and live tests.

The gearbox follows the lever model exactly: opposing load ``tau_l = R eta_D tau_m,net``,
aiding load ``tau_m,net = eta_I tau_l / R``, with ``tau_m = tau_m,net + J_m dw_m/dt``.
Sensors add white Gaussian noise with the given sigmas.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from gear_phm.models import eta_aiding, eta_opposing


@dataclass
class PlantRun:
    """Sampled signals (t [s], speeds [rad/s], torques [N m]) and the true u(t) [-].

    ``operating_time`` [s] is the estimator's operating time at each sample (intervals ending
    at a sample whose measured motor speed exceeds the default speed_threshold, 0.01 rad/s).
    """

    t: np.ndarray
    motor_velocity: np.ndarray
    motor_effort: np.ndarray
    load_velocity: np.ndarray
    load_effort: np.ndarray
    u: np.ndarray
    operating_time: np.ndarray

    @property
    def stamp_ns(self) -> np.ndarray:
        return np.round(self.t * 1e9).astype(np.int64) + 1_700_000_000_000_000_000


def lever_plant(seed: int, duration: float, u: float | Callable[[np.ndarray], np.ndarray],
                ratio: float = 3.0, rate: float = 1000.0, motor_inertia: float = 0.01,
                noise: tuple[float, float, float, float] = (0.05, 0.01, 0.05, 0.01),
                eta_pair: tuple[Callable, Callable] | None = None,
                wear_clock: str = 'stamp') -> PlantRun:
    """Duty cycle with opposing, aiding and zero-speed dwell phases; ``u`` constant or u(t).

    ``eta_pair`` overrides the efficiencies as functions of t (e.g. a spur-gear plant).
    ``wear_clock`` 'operating': a callable ``u`` takes the operating time instead of t (the
    plant wears only while it moves, as the estimator assumes).
    """
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 1.0 / rate)
    envelope = np.maximum(0.0, np.sin(2 * np.pi * t / 40.0) + 0.3) / 1.3
    w_l = 4.0 * np.sin(2 * np.pi * t / 6.0) * envelope
    tau_l = 20.0 + 5.0 * np.sin(2 * np.pi * t / 3.7) + 2.0 * w_l
    s_tm, s_wm, s_tl, s_wl = noise
    w_m_noise = s_wm * rng.standard_normal(t.size)
    moving = np.abs(ratio * w_l + w_m_noise)[1:] > 0.01
    operating = np.concatenate(([0.0], np.cumsum(np.diff(t) * moving)))
    clock = operating if wear_clock == 'operating' else t
    u_t = np.broadcast_to(u(clock) if callable(u) else np.asarray(u, float), t.shape).copy()
    if eta_pair is None:
        eta_d, eta_i = eta_opposing(u_t, ratio), eta_aiding(u_t, ratio)
    else:
        eta_d, eta_i = eta_pair[0](t), eta_pair[1](t)
    opposing = tau_l * w_l > 0.0
    tau_m_net = np.where(opposing, tau_l / (ratio * eta_d), eta_i * tau_l / ratio)
    w_m = ratio * w_l
    tau_m = tau_m_net + motor_inertia * np.gradient(w_m, t)
    return PlantRun(t, w_m + w_m_noise, tau_m + s_tm * rng.standard_normal(t.size),
                    w_l + s_wl * rng.standard_normal(t.size),
                    tau_l + s_tl * rng.standard_normal(t.size), u_t, operating)
