"""Reference model: an internal (pinion-ring) mesh with Coulomb tooth friction, as eqs 1-4.

The pinion (wheel 1, ``z1`` teeth) runs inside the ring (wheel 2, ``z2`` internal teeth), both
turning the same way. The line of action touches both base circles on the same side of the
pitch point P, at the distances ``d_p1 = r_p1 sin(theta)`` and ``d_p2 = r_p2 sin(theta)``.
The path of contact, split by P (s measured from P away from the tangent points)::

    A = sqrt(r_a1^2 - r_b1^2) - d_p1            bounded by the pinion's tip, r_a1 = r_p1 + a
    B = d_p2 - sqrt(r_a2^2 - r_b2^2)            bounded by the ring's tip, r_a2 = r_p2 - a_2

The friction force ``f F`` is perpendicular to the line of action; its arms about the two
centres are ``d_p1 + s`` and ``d_p2 + s`` (both tangent points lie behind the contact; in the
external mesh the second arm is ``d_p2 - s``). The sliding speed ``s (omega_1 - omega_2)``
reverses at P. Per unit normal force, with ``k = f / (A + B)``::

    m_i = k (A (d_pi + A/2) - B (d_pi - B/2))
    T_M,D = r_b1 + m_1,   T_U,D = r_b2 + m_2        pinion drives ring (opposing)
    T_M,I = r_b1 - m_1,   T_U,I = r_b2 - m_2        ring drives pinion (aiding)
    eta_D = (T_U,D / r_b2) / (T_M,D / r_b1),   eta_I = (T_M,I / r_b1) / (T_U,I / r_b2)

R = z2 / z1. The loss per unit of transmitted power is f (1/r_b1 - 1/r_b2) mean|s| to first
order, less than the external mesh's f (1/r_b1 + 1/r_b2) mean|s|. Bearings are not modelled
(in a planetary set the ring is a member and the planet bearings turn with the carrier).
Geometry: the ring's tip circle must lie outside its base circle, and the contact must not
pass the pinion's tangent point (B <= d_p1, no involute interference).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.models._validation import (at_least, in_open_interval, ModelError, non_negative,
                                         positive, result, unwrap)
from gear_phm.models.spur_gear import min_teeth


def contact_path(z1: ArrayLike, z2: ArrayLike, module: ArrayLike, pressure_angle: ArrayLike,
                 addendum: ArrayLike, ring_addendum: ArrayLike | None = None
                 ) -> dict[str, np.ndarray]:
    """Return r_b1, r_b2, d_p1, d_p2, A, B [m] of an internal mesh (NaN where B undefined)."""
    theta = np.asarray(pressure_angle, dtype=float)
    addendum = np.asarray(addendum, dtype=float)
    ring = addendum if ring_addendum is None else np.asarray(ring_addendum, dtype=float)
    r_p1 = 0.5 * np.asarray(module) * np.asarray(z1)
    r_p2 = 0.5 * np.asarray(module) * np.asarray(z2)
    r_b1, r_b2 = r_p1 * np.cos(theta), r_p2 * np.cos(theta)
    d_p1, d_p2 = r_p1 * np.sin(theta), r_p2 * np.sin(theta)
    ring_reach_sq = (r_p2 - ring) ** 2 - r_b2 ** 2
    ring_reach = np.sqrt(np.where(ring_reach_sq >= 0.0, ring_reach_sq, np.nan))
    return {'r_b1': r_b1, 'r_b2': r_b2, 'd_p1': d_p1, 'd_p2': d_p2,
            'A': np.sqrt((r_p1 + addendum) ** 2 - r_b1 ** 2) - d_p1, 'B': d_p2 - ring_reach}


def interference_free(z1: ArrayLike, z2: ArrayLike, pressure_angle: ArrayLike,
                      addendum_over_module: ArrayLike = 1.0,
                      ring_addendum_over_module: ArrayLike | None = None) -> np.ndarray:
    """Tell which internal meshes are valid: no undercut, ring tip above base, B <= d_p1."""
    path = contact_path(z1, z2, 1.0, pressure_angle, addendum_over_module,
                        ring_addendum_over_module)
    valid: np.ndarray = ((np.asarray(z1) >= min_teeth(pressure_angle, addendum_over_module))
                         & (np.asarray(z2) > np.asarray(z1)) & np.isfinite(path['B'])
                         & (path['B'] <= path['d_p1']))
    return valid


@dataclass(frozen=True)
class InternalGear:
    """One pinion-ring mesh; every field may be a numpy array (broadcast, for Monte Carlo).

    z1: pinion teeth [-] (undercut limit as the spur model). z2: ring teeth [-] (> z1).
    module: [m]. pressure_angle: [rad] in (0, pi/2). addendum: the pinion's [m], default one
    module. ring_addendum: how far the ring's teeth reach inwards [m], default ``addendum``
    (rings are often cut shorter, e.g. 0.8 module, to avoid interference with small pinions).
    friction: tooth Coulomb coefficient f [-] (>= 0).
    Raises ModelError naming the field; ``z2`` also for a ring tip inside its base circle or
    a contact past the pinion's tangent point (interference).
    """

    z1: ArrayLike
    z2: ArrayLike
    module: ArrayLike = 1e-3
    pressure_angle: ArrayLike = np.deg2rad(20.0)
    addendum: ArrayLike | None = None
    friction: ArrayLike = 0.0
    ring_addendum: ArrayLike | None = None

    def __post_init__(self) -> None:
        module = positive('module', self.module)
        theta = in_open_interval('pressure_angle', self.pressure_angle, 0.0, np.pi / 2, ' rad')
        addendum = module if self.addendum is None else positive('addendum', self.addendum)
        ring = (addendum if self.ring_addendum is None
                else positive('ring_addendum', self.ring_addendum))
        z1 = at_least('z1', self.z1, min_teeth(theta, addendum / module),
                      'involute undercut limit 2 (a/m) / sin^2(pressure_angle)')
        z2 = at_least('z2', self.z2, z1 + 1.0, 'a ring has more teeth than its pinion')
        friction = non_negative('friction', self.friction)
        path = contact_path(z1, z2, module, theta, addendum, ring)
        bad = ~(np.isfinite(path['B']) & (path['B'] <= path['d_p1']))
        if bad.any():
            index = tuple(int(i) for i in np.argwhere(bad)[0]) if bad.ndim else ()
            msg = (f'z2 {float(np.broadcast_to(z2, bad.shape)[index])!r} gives involute '
                   'interference with the pinion (the ring tip circle must lie outside its '
                   'base circle and meet the line of action before the tangent point of the '
                   'pinion)')
            raise ModelError(msg) from None
        for name, value in (('z1', z1), ('z2', z2), ('module', module),
                            ('pressure_angle', theta), ('addendum', addendum),
                            ('friction', friction), ('ring_addendum', ring)):
            object.__setattr__(self, name, unwrap(value))

    @property
    def ratio(self) -> np.ndarray | float:
        """Transmission ratio R = z2 / z1 [-] (ideal torque gain ring / pinion)."""
        return result(np.asarray(self.z2) / np.asarray(self.z1))

    def efficiencies(self) -> tuple[np.ndarray | float, np.ndarray | float]:
        """(eta_opposing, eta_aiding) [-]: pinion driving the ring, ring driving the pinion."""
        g = contact_path(self.z1, self.z2, self.module, self.pressure_angle,
                         cast(ArrayLike, self.addendum), self.ring_addendum)
        a, b = g['A'], g['B']
        k = np.asarray(self.friction) / (a + b)
        motor = k * (a * (g['d_p1'] + a / 2) - b * (g['d_p1'] - b / 2)) / g['r_b1']
        load = k * (a * (g['d_p2'] + a / 2) - b * (g['d_p2'] - b / 2)) / g['r_b2']
        return result((1.0 + load) / (1.0 + motor)), result((1.0 - motor) / (1.0 - load))
