"""Reference model: a simple planetary gear set by the Willis method (docs/architectures.md).

Members: sun (``z_sun``), ring (``z_ring = z_sun + 2 z_planet``, internal teeth) and carrier;
the planets are idlers (their number does not change the efficiency). With ``k = z_ring /
z_sun`` the Willis equation (the kinematics seen from the carrier) is::

    omega_sun - omega_carrier = -k (omega_ring - omega_carrier)

**Basic efficiency.** With the carrier held, the set is a train sun -> planet (external
:class:`SpurGear`) -> ring (internal :class:`InternalGear`): eta0 = eta_D of that train when
the sun drives, eta0' = its eta_I when the ring drives (:func:`series_efficiencies`).

**Each configuration.** One member is ``fixed``, one is ``driving`` (the motor side), the
third is the output (the load side). Torques on the members sum to zero. In the carrier frame
the meshes carry the power ``T_sun (omega_sun - omega_carrier)``; when it is positive the sun
drives relative to the carrier and ``T_ring = k eta0 T_sun``, otherwise the ring drives and
``T_sun = eta0' T_ring / k``. Which one holds follows from the ideal torques of the power
flow; reversing the power flow (aiding load) reverses it. Then::

    eta_D = -P_out / P_in (motor drives),  eta_I = -P_in / P_out (load drives),  P = T omega

Ring fixed, sun driving: ``eta_D = (1 + k eta0) / (1 + k)``,
``eta_I = (1 + k) eta0' / (k + eta0')``. R = |omega_in / omega_out|, the ideal torque gain;
:attr:`PlanetaryGearSet.reverses` tells whether the output turns the other way (carrier held).
Multi-stage planetary: :class:`~gear_phm.models.GearTrain` of sets.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.models._validation import finite, ModelError, positive, result, unwrap
from gear_phm.models.gear_train import series_efficiencies
from gear_phm.models.internal_gear import InternalGear
from gear_phm.models.spur_gear import SpurGear

MEMBERS = ('sun', 'ring', 'carrier')


def _speeds(k: np.ndarray, fixed: str, driving: str) -> dict[str, np.ndarray]:
    """Member speeds [rad/s] with omega_driving = 1 and omega_fixed = 0 (Willis equation)."""
    output = next(m for m in MEMBERS if m not in (fixed, driving))
    known = {fixed: np.zeros_like(k), driving: np.ones_like(k)}
    # omega_sun + k omega_ring - (1 + k) omega_carrier = 0, solved for the output member.
    coefficient = {'sun': np.ones_like(k), 'ring': k, 'carrier': -(1.0 + k)}
    rest = sum(coefficient[m] * known[m] for m in known)
    known[output] = -rest / coefficient[output]
    return known


@dataclass(frozen=True)
class PlanetaryGearSet:
    """A simple planetary set; the teeth, module, angle and friction may be numpy arrays.

    z_sun, z_planet: teeth [-]. z_ring: internal teeth [-], default (and required)
    z_sun + 2 z_planet (coaxial standard gears). module [m], pressure_angle [rad], addendum
    [m] (default one module) and friction (tooth Coulomb coefficient f [-]) of both meshes;
    ring_addendum [m] of the ring's teeth (default ``addendum``; see :class:`InternalGear`).
    fixed, driving: two different members of 'sun', 'ring', 'carrier'; the third is the
    output. Raises ModelError naming the field (the meshes' fields as the mesh models).
    """

    z_sun: ArrayLike
    z_planet: ArrayLike
    z_ring: ArrayLike | None = None
    module: ArrayLike = 1e-3
    pressure_angle: ArrayLike = np.deg2rad(20.0)
    addendum: ArrayLike | None = None
    friction: ArrayLike = 0.0
    fixed: str = 'ring'
    driving: str = 'sun'
    ring_addendum: ArrayLike | None = None

    def __post_init__(self) -> None:
        for name in ('fixed', 'driving'):
            if getattr(self, name) not in MEMBERS:
                msg = f'{name} must be one of {", ".join(MEMBERS)}, got {getattr(self, name)!r}'
                raise ModelError(msg) from None
        if self.fixed == self.driving:
            msg = f'driving must differ from fixed, both are {self.fixed!r}'
            raise ModelError(msg) from None
        z_sun = positive('z_sun', self.z_sun)
        z_planet = positive('z_planet', self.z_planet)
        coaxial = z_sun + 2.0 * z_planet
        z_ring = coaxial if self.z_ring is None else finite('z_ring', self.z_ring)
        bad = np.broadcast_to(np.abs(z_ring - coaxial) > 1e-9 * coaxial,
                              np.broadcast(z_ring, coaxial).shape)
        if bad.any():
            index = tuple(int(i) for i in np.argwhere(bad)[0]) if bad.ndim else ()
            got = float(np.broadcast_to(z_ring, bad.shape)[index])
            msg = (f'z_ring must be z_sun + 2 z_planet '
                   f'({float(np.broadcast_to(coaxial, bad.shape)[index]):g}, coaxial standard '
                   f'gears), got {got!r}')
            raise ModelError(msg) from None
        for name, value in (('z_sun', z_sun), ('z_planet', z_planet), ('z_ring', z_ring)):
            object.__setattr__(self, name, unwrap(value))
        try:
            SpurGear(z_sun, z_planet, self.module, self.pressure_angle, self.addendum,
                     self.friction)
        except ModelError as exc:
            msg = f'sun-planet mesh (z1 = z_sun, z2 = z_planet): {exc}'
            raise ModelError(msg) from None
        try:
            InternalGear(z_planet, z_ring, self.module, self.pressure_angle, self.addendum,
                         self.friction, self.ring_addendum)
        except ModelError as exc:
            msg = f'planet-ring mesh (z1 = z_planet, z2 = z_ring): {exc}'
            raise ModelError(msg) from None

    def meshes(self) -> tuple[SpurGear, InternalGear]:
        """Return the sun-planet (external) and planet-ring (internal) meshes, carrier held."""
        return (SpurGear(self.z_sun, self.z_planet, self.module, self.pressure_angle,
                         self.addendum, self.friction),
                InternalGear(self.z_planet, cast(ArrayLike, self.z_ring), self.module,
                             self.pressure_angle, self.addendum, self.friction,
                             self.ring_addendum))

    @property
    def k(self) -> np.ndarray | float:
        """Ring-to-sun teeth ratio k = z_ring / z_sun [-] (basic ratio -k, carrier held)."""
        return result(np.asarray(self.z_ring) / np.asarray(self.z_sun))

    def basic_efficiencies(self) -> tuple[np.ndarray | float, np.ndarray | float]:
        """(eta0, eta0') [-], carrier held: sun driving the ring, ring driving the sun."""
        return series_efficiencies([mesh.efficiencies() for mesh in self.meshes()])

    def speeds(self) -> dict[str, np.ndarray]:
        """Member speeds [rad/s] for a driving member at 1 rad/s, the fixed one at 0."""
        return _speeds(np.asarray(self.k, dtype=float), self.fixed, self.driving)

    @property
    def output(self) -> str:
        """Name the load-side member: the one neither fixed nor driving."""
        return next(m for m in MEMBERS if m not in (self.fixed, self.driving))

    @property
    def ratio(self) -> np.ndarray | float:
        """Transmission ratio R = |omega_driving / omega_output| [-] (ideal torque gain)."""
        return result(1.0 / np.abs(self.speeds()[self.output]))

    @property
    def reverses(self) -> bool:
        """Tell whether the output turns against the driving member (carrier held)."""
        return self.fixed == 'carrier'

    def efficiencies(self) -> tuple[np.ndarray | float, np.ndarray | float]:
        """(eta_opposing, eta_aiding) [-] of the configuration (Willis, see the module)."""
        k = np.asarray(self.k, dtype=float)
        eta0, eta0_reverse = (np.asarray(x, dtype=float) for x in self.basic_efficiencies())
        omega = self.speeds()
        ideal = {'sun': np.ones_like(k), 'ring': k, 'carrier': -(1.0 + k)}
        # Direct power flow: the ideal torques scaled so that the driving member feeds power.
        scale = np.sign(ideal[self.driving] * omega[self.driving])
        sun_drives_direct = scale * ideal['sun'] * (omega['sun'] - omega['carrier']) > 0.0
        efficiencies = []
        for sun_drives, forward in ((sun_drives_direct, True), (~sun_drives_direct, False)):
            torque_sun = np.where(sun_drives, 1.0, eta0_reverse)
            torque_ring = np.where(sun_drives, k * eta0, k)
            torques = {'sun': torque_sun, 'ring': torque_ring,
                       'carrier': -(torque_sun + torque_ring)}
            power_in = torques[self.driving] * omega[self.driving]
            power_out = torques[self.output] * omega[self.output]
            efficiencies.append(-power_out / power_in if forward else -power_in / power_out)
        return result(efficiencies[0]), result(efficiencies[1])
