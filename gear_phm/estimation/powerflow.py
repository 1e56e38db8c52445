"""Power-flow classification of gearbox samples (docs/architecture.md codes), vectorised."""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.models.power_flow import AIDING, IDLE, IMPOSSIBLE, OPPOSING, SELF_LOCKING


def classify(p_motor: ArrayLike, p_load: ArrayLike, motor_velocity: ArrayLike,
             power_threshold: float = 0.0, speed_threshold: float = 0.0) -> np.ndarray:
    """Power-flow code per sample (int8).

    0 idle, 1 opposing, 2 aiding, 3 self-locking, -1 impossible.

    A sample is idle when ``|w_m| <= speed_threshold`` [rad/s] or when either power is inside
    the deadband ``|P| <= power_threshold`` [W]; otherwise the signs of P_m and P_l decide:
    (+, -) opposing, (-, +) aiding, (+, +) self-locking, (-, -) impossible. NaN gives idle.
    """
    if not power_threshold >= 0.0:
        raise ValueError(f'power_threshold must be >= 0 W, got {power_threshold!r}')
    if not speed_threshold >= 0.0:
        raise ValueError(f'speed_threshold must be >= 0 rad/s, got {speed_threshold!r}')
    p_m = np.asarray(p_motor, dtype=float)
    p_l = np.asarray(p_load, dtype=float)
    moving = np.abs(np.asarray(motor_velocity, dtype=float)) > speed_threshold
    m_in, m_out = p_m > power_threshold, p_m < -power_threshold
    l_in, l_out = p_l > power_threshold, p_l < -power_threshold
    code = np.zeros(np.broadcast(p_m, p_l).shape, dtype=np.int8)
    code[m_in & l_out] = OPPOSING
    code[m_out & l_in] = AIDING
    code[m_in & l_in] = SELF_LOCKING
    code[m_out & l_out] = IMPOSSIBLE
    code[~moving] = IDLE
    return code


def classify_sample(p_motor: float, p_load: float, motor_velocity: float,
                    power_threshold: float = 0.0, speed_threshold: float = 0.0) -> int:
    """Power-flow code of one sample, as :func:`classify`.

    The estimator node's per-sample guess of when a window closes; the thresholds are not
    checked here.

    Both powers in (P_m > 0 and P_l > 0: a self-locking drive, eta_I < 0, that the motor
    pushes through an aiding load) is SELF_LOCKING, not aiding: the motor feeds power too.
    """
    if not abs(motor_velocity) > speed_threshold:
        return IDLE
    if p_motor > power_threshold:
        return OPPOSING if p_load < -power_threshold else \
            SELF_LOCKING if p_load > power_threshold else IDLE
    if p_motor < -power_threshold:
        return AIDING if p_load > power_threshold else \
            IMPOSSIBLE if p_load < -power_threshold else IDLE
    return IDLE
