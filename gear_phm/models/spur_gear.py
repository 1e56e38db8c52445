"""Reference model: Coulomb friction on a single spur-gear stage (Berri et al., eqs 1-8).

Geometry of each wheel ``i`` (module ``m`` [m], teeth ``z_i``, pressure angle ``theta`` [rad],
addendum ``a`` [m])::

    r_p = m z / 2        pitch radius (the paper prints m z: errata E5)
    r_t = r_p + a        tip radius
    r_b = r_p cos(theta) base radius
    d_p = r_p sin(theta) distance from the base-circle tangent point to the pitch point

Path of contact on the line of action, split by the pitch point P (eqs 1, 2)::

    A = sqrt(r_t1^2 - r_b1^2) - d_p1     from P towards wheel 2, bounded by wheel 1's tip
    B = sqrt(r_t2^2 - r_b2^2) - d_p2     from P towards wheel 1, bounded by wheel 2's tip

The normal force ``F`` is constant along the path, the contact point moves uniformly, so the
contact spends fractions ``B/(A+B)`` and ``A/(A+B)`` of the time on each side with mean arms
``d_p1 -/+ ...``. The tooth friction force ``f F`` is perpendicular to the line of action and
reverses at P with the sliding velocity. Bearing friction acts at radius ``rho_i`` on the
magnitude of the mean tooth force ``F sqrt(1 + (f (A - B)/(A + B))^2)``. With ``s = f/(A+B)``
and ``N = sqrt(1 + (f (A - B)/(A + B))^2)``, per unit ``F``::

    T_M,D = r_b1 - s B (d_p1 - B/2) + s A (d_p1 + A/2) + rho_1 N                     (3)
    T_U,D = r_b2 - s B (d_p2 + B/2) + s A (d_p2 - A/2) - rho_2 N                     (4)
    T_M,I = r_b1 + s B (d_p1 - B/2) - s A (d_p1 + A/2) - rho_1 N                     (6)
    T_U,I = r_b2 + s B (d_p2 + B/2) - s A (d_p2 - A/2) + rho_2 N   (paper: rho_1, E6) (7)
    eta_D = T_U,D / (R T_M,D),   eta_I = R T_M,I / T_U,I,   R = z2 / z1 = r_b2 / r_b1 (5, 8)

``F`` cancels from both efficiencies, so it is not a parameter. The efficiencies are computed
as ``(T_U / r_b2) / (T_M / r_b1)``, which is the same quantity and makes the frictionless case
exactly 1.0 in floating point.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.models._validation import at_least, in_open_interval, non_negative, positive


def min_teeth(pressure_angle: ArrayLike, addendum_over_module: ArrayLike = 1.0) -> np.ndarray:
    """Fewest teeth an involute wheel can have without undercut: 2 (a/m) / sin^2(theta) [-]."""
    teeth: np.ndarray = (2.0 * np.asarray(addendum_over_module)
                         / np.sin(np.asarray(pressure_angle)) ** 2)
    return teeth


@dataclass(frozen=True)
class SpurGear:
    """One spur-gear stage; every field may be a numpy array (broadcast, for Monte Carlo).

    z1, z2: teeth of the motor (driving under opposing load) and load wheels [-].
    module: [m]. pressure_angle: [rad], in (0, pi/2). addendum: [m], default one module.
    friction: tooth-tooth Coulomb coefficient f [-]. bearing_radius_1/2: friction radii rho of
    the bearings of wheel 1 and 2 [m].
    """

    z1: ArrayLike
    z2: ArrayLike
    module: ArrayLike = 1e-3
    pressure_angle: ArrayLike = np.deg2rad(20.0)
    addendum: ArrayLike | None = None
    friction: ArrayLike = 0.0
    bearing_radius_1: ArrayLike = 0.0
    bearing_radius_2: ArrayLike = 0.0
    _geometry: dict[str, np.ndarray] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        module = positive('module', self.module)
        theta = in_open_interval('pressure_angle', self.pressure_angle, 0.0, np.pi / 2, ' rad')
        addendum = module if self.addendum is None else positive('addendum', self.addendum)
        z_min = min_teeth(theta, addendum / module)
        why = 'involute undercut limit 2 (a/m) / sin^2(pressure_angle)'
        z1 = at_least('z1', self.z1, z_min, why)
        z2 = at_least('z2', self.z2, z_min, why)
        friction = non_negative('friction', self.friction)
        rho_1 = non_negative('bearing_radius_1', self.bearing_radius_1)
        rho_2 = non_negative('bearing_radius_2', self.bearing_radius_2)
        for name, value in (('module', module), ('pressure_angle', theta), ('z1', z1),
                            ('z2', z2), ('friction', friction), ('addendum', addendum),
                            ('bearing_radius_1', rho_1), ('bearing_radius_2', rho_2)):
            object.__setattr__(self, name, value[()] if value.ndim == 0 else value)
        object.__setattr__(self, '_geometry', self._contact_geometry())

    @property
    def ratio(self) -> np.ndarray | float:
        """Transmission ratio R = z2 / z1 [-] (ideal torque gain load/motor)."""
        ratio: np.ndarray = np.asarray(self.z2) / np.asarray(self.z1)
        return ratio

    def _contact_geometry(self) -> dict[str, np.ndarray]:
        cos_t, sin_t = np.cos(self.pressure_angle), np.sin(self.pressure_angle)
        geometry: dict[str, np.ndarray] = {}
        for wheel, teeth in (('1', self.z1), ('2', self.z2)):
            pitch = 0.5 * np.asarray(self.module) * np.asarray(teeth)
            tip, base = pitch + np.asarray(self.addendum), pitch * cos_t
            geometry['r_b' + wheel] = base
            geometry['d_p' + wheel] = pitch * sin_t
            geometry['reach' + wheel] = np.sqrt(tip ** 2 - base ** 2)
        geometry['A'] = geometry['reach1'] - geometry['d_p1']
        geometry['B'] = geometry['reach2'] - geometry['d_p2']
        return geometry

    def torques(self) -> dict[str, np.ndarray]:
        """Torques per unit normal force [N m / N] = [m]: T_M_D, T_U_D, T_M_I, T_U_I."""
        g = self._geometry
        a, b, d1, d2 = g['A'], g['B'], g['d_p1'], g['d_p2']
        s = self.friction / (a + b)
        bearing = np.sqrt(1.0 + (self.friction * (a - b) / (a + b)) ** 2)
        motor_friction = -s * b * (d1 - b / 2) + s * a * (d1 + a / 2)
        load_friction = -s * b * (d2 + b / 2) + s * a * (d2 - a / 2)
        return {
            'T_M_D': g['r_b1'] + motor_friction + self.bearing_radius_1 * bearing,
            'T_U_D': g['r_b2'] + load_friction - self.bearing_radius_2 * bearing,
            'T_M_I': g['r_b1'] - motor_friction - self.bearing_radius_1 * bearing,
            'T_U_I': g['r_b2'] - load_friction + self.bearing_radius_2 * bearing,
        }

    def efficiencies(self) -> tuple[np.ndarray | float, np.ndarray | float]:
        """(eta_opposing, eta_aiding) [-], eqs 5 and 8."""
        g, t = self._geometry, self.torques()
        motor_d, load_d = t['T_M_D'] / g['r_b1'], t['T_U_D'] / g['r_b2']
        motor_i, load_i = t['T_M_I'] / g['r_b1'], t['T_U_I'] / g['r_b2']
        eta_d, eta_i = load_d / motor_d, motor_i / load_i
        return _scalar(eta_d), _scalar(eta_i)


def _scalar(value: np.ndarray) -> np.ndarray | float:
    value = np.asarray(value)
    return float(value) if value.ndim == 0 else value
