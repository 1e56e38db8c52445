"""Reference model: one helical stage, the spur model in its transverse plane.

A helical pair of normal module ``m_n``, normal pressure angle ``alpha_n`` and helix angle
``beta`` (at the pitch cylinder) is, in its transverse plane, an involute pair of::

    m_t = m_n / cos(beta)                       transverse module
    tan(alpha_t) = tan(alpha_n) / cos(beta)     transverse pressure angle
    sin(beta_b) = sin(beta) cos(alpha_n)        base helix angle

The tooth normal force ``F_n`` lies in the plane of action, inclined by ``beta_b`` to the
transverse plane: its transverse component ``F_t = F_n cos(beta_b)`` does the work of eqs 1-8,
its axial component is the thrust. The sliding is in the transverse plane along the profile,
so the Coulomb force ``f F_n = (f / cos(beta_b)) F_t`` is in the transverse plane too. Every
slice of the face width is a spur pair in its own phase of the mesh, and the model already
averages over the path of contact, so the helical stage is :class:`SpurGear` with the
transverse geometry and the **effective friction f / cos(beta_b)** (not f / cos(beta): the
force is normal to the flank, whose inclination is the base helix angle). The undercut check
of the transverse pair is the helical one, 2 cos(beta) / sin^2(alpha_t) for an addendum of
one normal module. Bearing friction acts on the transverse tooth force as in eqs 3-7; the
friction of the thrust bearings is not modelled. beta = 0 is the spur stage exactly.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.models._validation import (finite, in_half_open_interval, in_open_interval,
                                         non_negative, positive, unwrap)
from gear_phm.models.spur_gear import SpurGear


@dataclass(frozen=True)
class HelicalGear:
    """One helical stage; every field may be a numpy array (broadcast, for Monte Carlo).

    z1, z2: teeth of the motor and load wheels [-]. module: normal module m_n [m].
    pressure_angle: normal pressure angle alpha_n [rad] in (0, pi/2). helix_angle: beta [rad]
    in [0, pi/2) at the pitch cylinder. addendum: [m], default one normal module. friction:
    tooth Coulomb coefficient f [-] on the flank. bearing_radius_1/2: friction radii [m].
    Raises ModelError naming the field (the teeth against the helical undercut limit).
    """

    z1: ArrayLike
    z2: ArrayLike
    module: ArrayLike = 1e-3
    pressure_angle: ArrayLike = np.deg2rad(20.0)
    helix_angle: ArrayLike = np.deg2rad(15.0)
    addendum: ArrayLike | None = None
    friction: ArrayLike = 0.0
    bearing_radius_1: ArrayLike = 0.0
    bearing_radius_2: ArrayLike = 0.0
    transverse: SpurGear = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        module = positive('module', self.module)
        alpha_n = in_open_interval('pressure_angle', self.pressure_angle, 0.0, np.pi / 2,
                                   ' rad')
        beta = in_half_open_interval('helix_angle', self.helix_angle, 0.0, np.pi / 2, ' rad')
        addendum = module if self.addendum is None else positive('addendum', self.addendum)
        friction = non_negative('friction', self.friction)
        for name, value in (('module', module), ('pressure_angle', alpha_n),
                            ('helix_angle', beta), ('addendum', addendum),
                            ('friction', friction)):
            object.__setattr__(self, name, unwrap(value))
        finite('z1', self.z1)
        finite('z2', self.z2)
        transverse = SpurGear(
            self.z1, self.z2, module=module / np.cos(beta),
            pressure_angle=np.where(beta == 0.0, alpha_n,             # exact spur at beta 0
                                    np.arctan(np.tan(alpha_n) / np.cos(beta))),
            addendum=addendum,
            friction=friction / np.cos(self.base_helix_angle),
            bearing_radius_1=self.bearing_radius_1, bearing_radius_2=self.bearing_radius_2)
        for name in ('z1', 'z2', 'bearing_radius_1', 'bearing_radius_2'):
            object.__setattr__(self, name, getattr(transverse, name))
        object.__setattr__(self, 'transverse', transverse)

    @property
    def base_helix_angle(self) -> np.ndarray:
        """Angle beta_b of the base helix [rad]: sin(beta_b) = sin(beta) cos(alpha_n)."""
        angle: np.ndarray = np.arcsin(np.sin(self.helix_angle) * np.cos(self.pressure_angle))
        return angle

    @property
    def ratio(self) -> np.ndarray | float:
        """Transmission ratio R = z2 / z1 [-]."""
        return self.transverse.ratio

    def efficiencies(self) -> tuple[np.ndarray | float, np.ndarray | float]:
        """(eta_opposing, eta_aiding) [-]: those of the transverse spur pair."""
        return self.transverse.efficiencies()
