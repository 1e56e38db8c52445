"""Rotor inertia left in the windows' motor energy, learned from the windows (no ROS imports).

A motor torque that includes the rotor's J_m dw_m/dt (an electromagnetic torque does) leaves
J_m K in each window's motor energy, K = (w_m,end^2 - w_m,start^2) / 2 [rad^2/s^2], unless
``motor_inertia`` removes it. At a high ratio the motor turns R times faster than the load and
that term grows as R^2: on a spur plant at R = 30 with J_m = 2e-3 kg m^2 left at 0 it biased
eta_D by +0.0011 and doubled the windows' scatter (docs/estimation.md).

Each accepted window gives, with the filter's efficiency of its direction (g = 1 / eta_D
opposing, eta_I aiding), the residual e = E_m - g (-E_l) = dJ K + noise, dJ being the inertia
still left [kg m^2]. Weighted least squares over all windows so far (J_m is a constant of the
drive): dJ = sum(w K e) / sum(w K^2), w = 1 / var(e), variance scaled by the residuals'
reduced chi-square (at least 1). It is applied only once it is significant
(|dJ| > ``INERTIA_Z`` sigma) and has ``INERTIA_MIN_WINDOWS`` windows, and never below
-motor_inertia (an inertia is not negative).
"""
from __future__ import annotations

import math
from typing import Any

from gear_phm.persistence import decode_floats, encode_floats

#: Significance of dJ before it is applied [sigma].
INERTIA_Z = 4.0
#: Windows before dJ is applied.
INERTIA_MIN_WINDOWS = 30


class InertiaLearner:
    """Weighted least squares of the rotor inertia left in the windows (module docstring)."""

    def __init__(self, configured: float = 0.0) -> None:
        #: the configured motor_inertia [kg m^2]: dJ is at least -configured
        self.configured = float(configured)
        self.reset()

    def reset(self) -> None:
        """Forget every window."""
        self._sums = [0.0, 0.0, 0.0]        # sum w K^2, sum w K e, sum w e^2
        self.windows = 0

    def add(self, kinetic: float, residual: float, variance: float) -> None:
        """Add one window: K [rad^2/s^2], residual e [J], var(e) [J^2]."""
        if not (math.isfinite(kinetic) and math.isfinite(residual) and variance > 0.0
                and math.isfinite(variance)):
            return
        w = 1.0 / variance
        self._sums[0] += w * kinetic * kinetic
        self._sums[1] += w * kinetic * residual
        self._sums[2] += w * residual * residual
        self.windows += 1

    def fitted(self) -> tuple[float, float]:
        """Return (dJ [kg m^2], its variance) from all windows; (0, inf) before any."""
        s_kk, s_ke, s_ee = self._sums
        if not (self.windows >= 2 and s_kk > 0.0):
            return 0.0, math.inf
        d_j = s_ke / s_kk
        chi2 = max(s_ee - d_j * s_ke, 0.0) / (self.windows - 1)
        return d_j, max(chi2, 1.0) / s_kk

    @property
    def correction(self) -> tuple[float, float]:
        """Return (dJ [kg m^2], its variance) to apply: (0, 0) until significant."""
        d_j, variance = self.fitted()
        if self.windows < INERTIA_MIN_WINDOWS or not abs(d_j) > INERTIA_Z * math.sqrt(variance):
            return 0.0, 0.0
        return max(d_j, -self.configured), variance

    @property
    def inertia(self) -> float:
        """Return the motor inertia in use [kg m^2]: configured plus the applied dJ."""
        return self.configured + self.correction[0]

    def to_state(self) -> dict[str, Any]:
        """Return the sums and the window count (JSON-safe)."""
        return {'sums': encode_floats(self._sums), 'windows': self.windows}

    def from_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`to_state`; ValueError/KeyError/TypeError if malformed."""
        sums = decode_floats(state['sums'])
        if len(sums) != 3:
            raise ValueError('inertia: sums needs 3 values')
        self._sums, self.windows = [sums[0], sums[1], sums[2]], int(state['windows'])
