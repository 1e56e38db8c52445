"""Reference models: lead, ball and roller screws of linear actuators (docs/architectures.md).

A screw of lead ``L`` [m] (axial advance of the nut per turn) and mean (pitch or ball-circle)
diameter ``d`` [m] has the lead angle ``lambda = atan(L / (pi d))``.

**Ratio.** The motor turns the screw (torque ``T`` [N m], speed ``omega`` [rad/s]); the load is
the nut (force ``F`` [N], speed ``v`` [m/s]). Ideally ``F v = T omega`` and ``omega = R v``, so::

    R = 2 pi / L   [rad/m]        the ideal force gain F / T [N / (N m)]

In the package's terms the load joint is prismatic: its "torque" is the force [N] and its
"speed" the linear speed [m/s]; powers stay in watts, efficiencies are dimensionless, and R is
given in rad/m (``ratio`` of a transmission). Note that the simplified lever model's eq 14
depends on the number R, so a screw's lever curve depends on the length unit: in SI units R is
10^2..10^4 and the lever is close to its R -> inf limit eta_I = 2 - 1/eta_D.

**Friction.** The thread is an inclined plane of angle lambda. Its flank normal makes the
angle ``alpha`` with the axis in the axial section; in the normal section
``tan(alpha_n) = tan(alpha) cos(lambda)``. A Coulomb coefficient ``mu`` gives the friction angle
``tan(phi') = mu / cos(alpha_n)`` and::

    eta_D = tan(lambda) / tan(lambda + phi')     screw drives nut (opposing load)
    eta_I = tan(lambda - phi') / tan(lambda)     nut drives screw (aiding load; <= 0: self-locking)

:class:`LeadScrew`: sliding thread, ``alpha`` = half the thread angle (15 deg for a trapezoidal
ISO 2904 thread, 14.5 deg Acme, 0 square). :class:`BallScrew` and :class:`RollerScrew`: rolling
elements, ``mu`` is the equivalent rolling-resistance coefficient and the contact angle
``beta`` is measured from the plane normal to the axis, so ``alpha = pi/2 - beta``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.models._helix import friction_angle, thread_efficiencies, ThreadDrive
from gear_phm.models._validation import (in_half_open_interval, in_open_interval, non_negative,
                                         positive, result, unwrap)


def _lead_angle(lead: ArrayLike, diameter: ArrayLike) -> np.ndarray:
    angle: np.ndarray = np.arctan(np.asarray(lead) / (np.pi * np.asarray(diameter)))
    return angle


def _normal_flank_angle(flank_angle: np.ndarray, lead_angle: np.ndarray) -> np.ndarray:
    angle: np.ndarray = np.arctan(np.tan(flank_angle) * np.cos(lead_angle))
    return angle


@dataclass(frozen=True)
class _Screw(ThreadDrive):
    """Common part of the screws: lead, diameter, flank angle from the axis, friction.

    ``efficiencies()``: screw driving the nut, nut driving the screw; ``self_locking`` where
    lambda <= phi'.
    """

    lead: ArrayLike
    diameter: ArrayLike

    @property
    def ratio(self) -> np.ndarray | float:
        """Ratio R = 2 pi / lead [rad/m]: ideal force [N] per torque [N m]; motor rad per m."""
        return result(2.0 * np.pi / np.asarray(self.lead))

    @property
    def lead_angle(self) -> np.ndarray | float:
        """Lead angle lambda = atan(lead / (pi diameter)) [rad]."""
        return result(_lead_angle(self.lead, self.diameter))

    def _flank_angle(self) -> np.ndarray:
        raise NotImplementedError

    def _friction(self) -> np.ndarray:
        raise NotImplementedError

    @property
    def friction_angle(self) -> np.ndarray | float:
        """Friction angle phi' = atan(mu / cos(alpha_n)) [rad]."""
        alpha_n = _normal_flank_angle(self._flank_angle(), np.asarray(self.lead_angle))
        return result(friction_angle(self._friction(), alpha_n))

    def _angles(self) -> tuple[np.ndarray, np.ndarray]:
        return np.asarray(self.lead_angle), np.asarray(self.friction_angle)

    def _check(self, friction_name: str) -> None:
        lead = positive('lead', self.lead)
        diameter = positive('diameter', self.diameter)
        for name, value in (('lead', lead), ('diameter', diameter)):
            object.__setattr__(self, name, unwrap(value))
        thread_efficiencies(*self._angles(), friction_name)


@dataclass(frozen=True)
class LeadScrew(_Screw):
    """A sliding (lead, trapezoidal, Acme) screw; fields may be numpy arrays (broadcast).

    lead: axial advance per turn [m] (> 0; lead = pitch x starts). diameter: mean thread
    diameter [m] (> 0). flank_angle: half the thread angle alpha [rad] in [0, pi/2) (0.2618,
    15 deg, trapezoidal). friction: sliding Coulomb coefficient mu [-] (>= 0).
    Raises ModelError naming the field; ``friction`` also if the thread jams when driven.
    """

    flank_angle: ArrayLike = np.deg2rad(15.0)
    friction: ArrayLike = 0.1

    def __post_init__(self) -> None:
        flank = in_half_open_interval('flank_angle', self.flank_angle, 0.0, np.pi / 2, ' rad')
        mu = non_negative('friction', self.friction)
        object.__setattr__(self, 'flank_angle', unwrap(flank))
        object.__setattr__(self, 'friction', unwrap(mu))
        self._check('friction')

    def _flank_angle(self) -> np.ndarray:
        return np.asarray(self.flank_angle)

    def _friction(self) -> np.ndarray:
        return np.asarray(self.friction)


@dataclass(frozen=True)
class BallScrew(_Screw):
    """A ball screw; fields may be numpy arrays (broadcast).

    lead: axial advance per turn [m] (> 0). diameter: ball-circle diameter [m] (> 0).
    contact_angle: beta [rad] in (0, pi/2] from the plane normal to the axis (0.7854, 45 deg,
    gothic-arch grooves). rolling_friction: equivalent rolling-resistance coefficient [-]
    (>= 0; about 0.003-0.01).
    Raises ModelError naming the field.
    """

    contact_angle: ArrayLike = np.deg2rad(45.0)
    rolling_friction: ArrayLike = 0.005

    def __post_init__(self) -> None:
        beta = in_open_interval('contact_angle', self.contact_angle, 0.0, np.pi / 2 + 1e-12,
                                ' rad')
        mu = non_negative('rolling_friction', self.rolling_friction)
        object.__setattr__(self, 'contact_angle', unwrap(np.minimum(beta, np.pi / 2)))
        object.__setattr__(self, 'rolling_friction', unwrap(mu))
        self._check('rolling_friction')

    def _flank_angle(self) -> np.ndarray:
        angle: np.ndarray = np.pi / 2 - np.asarray(self.contact_angle)
        return angle

    def _friction(self) -> np.ndarray:
        return np.asarray(self.rolling_friction)


@dataclass(frozen=True)
class RollerScrew(BallScrew):
    """A planetary roller screw: the ball screw's model with rollers as rolling elements.

    diameter: the screw's pitch diameter [m]; contact_angle: the thread flank's contact angle
    from the plane normal to the axis (45 deg for the usual 90 deg thread).
    """
