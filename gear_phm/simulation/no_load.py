"""Load-independent (no-load) losses at the motor shaft: Coulomb and viscous drag.

Oil churning, seal drag and the viscous part of bearing drag take a torque from the motor
that does not scale with the transmitted load (the load-dependent mesh loss is the plant's
efficiency). The motor supplies, besides the gearbox input torque and the rotor's inertia::

    T_nl = factor(T_oil) (coulomb sign(w_m) + viscous w_m)                    [N m]

``coulomb`` [N m] and ``viscous`` [N m s/rad] are the warm values; ``factor`` is the oil's
viscosity factor (:meth:`gear_phm.simulation.oil.Oil.drag_factor`). The drag consumes motor
power in both power-flow directions (T_nl w_m >= 0).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.simulation._checks import non_negative


@dataclass(frozen=True)
class NoLoadLoss:
    """Warm no-load drag at the motor: ``coulomb`` [N m], ``viscous`` [N m s/rad]."""

    coulomb: float = 0.0
    viscous: float = 0.0

    def __post_init__(self) -> None:
        non_negative('no_load_coulomb', self.coulomb)
        non_negative('no_load_viscous', self.viscous)

    @property
    def enabled(self) -> bool:
        """Return True if there is any drag."""
        return self.coulomb > 0.0 or self.viscous > 0.0

    def parts(self, factor: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(Coulomb torque T_0 [N m], viscous coefficient c_v [N m s/rad]) at ``factor``."""
        factor = np.asarray(factor, dtype=float)
        return self.coulomb * factor, self.viscous * factor

    def torque(self, velocity_motor: ArrayLike, factor: ArrayLike) -> np.ndarray:
        """Drag torque [N m] at motor speed [rad/s] and viscosity factor [-]."""
        w = np.asarray(velocity_motor, dtype=float)
        coulomb, viscous = self.parts(factor)
        drag: np.ndarray = coulomb * np.sign(w) + viscous * w
        return drag
