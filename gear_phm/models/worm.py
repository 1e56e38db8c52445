"""Reference model: a worm gear set with Coulomb friction on the thread (docs/architectures.md).

The worm (``starts`` z1 threads, lead angle ``gamma`` at its reference diameter) drives the
wheel (``wheel_teeth`` z2). The ratio is R = z2 / z1: the wheel turns once per z2 / z1
turns of the worm, and the ideal torque gain wheel / worm is the same. With the normal
pressure angle ``alpha_n`` and the tooth friction coefficient ``mu``::

    tan(phi') = mu / cos(alpha_n)                        friction angle
    eta_D = tan(gamma) / tan(gamma + phi')               worm drives wheel (opposing load)
    eta_I = tan(gamma - phi') / tan(gamma)               wheel drives worm (aiding load)

eta_I <= 0 when gamma <= phi': the set is **self-locking** (irreversible); the load cannot
back-drive it and the motor must feed power in both load cases. Bearing and churning losses are
not modelled.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.models._helix import friction_angle, thread_efficiencies, ThreadDrive
from gear_phm.models._validation import (at_least, in_open_interval, non_negative, result,
                                         unwrap)


@dataclass(frozen=True)
class WormGear(ThreadDrive):
    """One worm and wheel; every field may be a numpy array (broadcast, for Monte Carlo).

    lead_angle: gamma [rad] in (0, pi/2), at the worm's reference diameter.
    starts: number of threads z1 [-] (>= 1). wheel_teeth: z2 [-] (>= 1).
    normal_pressure_angle: alpha_n [rad] in (0, pi/2). friction: Coulomb coefficient mu [-]
    (>= 0) of the sliding between thread and tooth.
    ``efficiencies()``: worm driving the wheel, wheel driving the worm; ``self_locking`` where
    gamma <= phi'.
    Raises ModelError naming the field; ``friction`` also when gamma + phi' >= pi/2.
    """

    lead_angle: ArrayLike
    starts: ArrayLike = 1.0
    wheel_teeth: ArrayLike = 40.0
    normal_pressure_angle: ArrayLike = np.deg2rad(20.0)
    friction: ArrayLike = 0.05

    def __post_init__(self) -> None:
        gamma = in_open_interval('lead_angle', self.lead_angle, 0.0, np.pi / 2, ' rad')
        starts = at_least('starts', self.starts, 1.0, 'one thread')
        teeth = at_least('wheel_teeth', self.wheel_teeth, 1.0, 'one tooth')
        alpha = in_open_interval('normal_pressure_angle', self.normal_pressure_angle, 0.0,
                                 np.pi / 2, ' rad')
        mu = non_negative('friction', self.friction)
        thread_efficiencies(gamma, friction_angle(mu, alpha))
        for name, value in (('lead_angle', gamma), ('starts', starts), ('wheel_teeth', teeth),
                            ('normal_pressure_angle', alpha), ('friction', mu)):
            object.__setattr__(self, name, unwrap(value))

    @property
    def ratio(self) -> np.ndarray | float:
        """Transmission ratio R = z2 / z1 [-] (ideal torque gain wheel / worm)."""
        return result(np.asarray(self.wheel_teeth) / np.asarray(self.starts))

    @property
    def friction_angle(self) -> np.ndarray | float:
        """Friction angle phi' = atan(mu / cos(alpha_n)) [rad]."""
        return result(friction_angle(np.asarray(self.friction),
                                     np.asarray(self.normal_pressure_angle)))

    def _angles(self) -> tuple[np.ndarray, np.ndarray]:
        return np.asarray(self.lead_angle), np.asarray(self.friction_angle)
