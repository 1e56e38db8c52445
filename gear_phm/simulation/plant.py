"""Kinematically driven transmission plant: motor shaft, massless gearbox, load with air load.

A servo makes the motor speed follow the duty cycle exactly, ``w_m = R w_l``. The load is a
control surface of inertia ``J_l`` [kg m^2] with a flap-like air-load hinge moment that always
pushes it back towards retracted (position 0), growing with deflection::

    T_air(theta) = -(T0 + k theta)                                      [N m]

The gearbox output shaft must deliver (``effort_load``, positive along the load position)::

    tau_out = J_l dw_l/dt + T0 + k theta_l                              [N m]

Gearbox, massless, efficiencies eta_D (opposing) and eta_I (aiding) [-]:

- ``tau_out w_l > 0`` (power to the load, opposing):  tau_in = tau_out / (R eta_D)
- ``tau_out w_l < 0`` (load drives, aiding):          tau_in = eta_I tau_out / R
  (eta_I < 0 when self-locking: the motor must push the load back)
- ``w_l = 0`` (holding):                              tau_in = max(eta_I, 0) tau_out / R

Motor torque (``effort_motor``, electromagnetic, includes the rotor) ``tau_in + J_m dw_m/dt``.
So ``P_m = effort_motor w_m`` and ``P_l = -effort_load w_l`` as in docs/architecture.md.

Efficiency source (``efficiency_model``):

- ``lever``: the friction value is the lever parameter u; eta_D = eta_opposing(u, R),
  eta_I = eta_aiding(u + direction_offset, R): with a ``direction_offset`` != 0 the two
  efficiencies do not come from one u (model mismatch, as in a real gearbox).
- ``spur``: the friction value is the tooth-tooth Coulomb coefficient f of one spur stage
  (pinion ``pinion_teeth``, wheel ``R * pinion_teeth``, other geometry fixed); the true u is
  the lever u with the same eta_D, ``u_from_eta_opposing(eta_D, R)``.
- The other architectures of :mod:`gear_phm.models` (docs/architectures.md), their friction
  value the model's Coulomb coefficient, each efficiency from the geometry and it, the true u
  again the lever u of eta_D:

  - ``gear_train``: two equal spur stages of ratio sqrt(R), pinions ``pinion_teeth``, the
    same tooth friction f on both;
  - ``planetary``: a simple planetary set, ring fixed, sun driving, carrier out
    (R = 1 + z_ring / z_sun > 2); the smaller of sun and planet has ``pinion_teeth``, f on
    both meshes (sun-planet, planet-ring);
  - ``worm``: one start, ``R`` wheel teeth, lead angle ``lead_angle``, normal pressure angle
    ``pressure_angle``, thread friction mu; self-locking (eta_I <= 0) once the friction angle
    reaches the lead angle;
  - ``screw``: a lead screw of lead 2 pi / R (R in rad per unit of load travel), lead angle
    ``lead_angle`` at its mean diameter, flank angle 15 deg (trapezoidal), thread friction mu.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.models import (eta_aiding, eta_opposing, GearTrain, LeadScrew, PlanetaryGearSet,
                             SpurGear, u_from_eta_opposing, WormGear)
from gear_phm.models.power_flow import AIDING, IDLE, OPPOSING, SELF_LOCKING
from gear_phm.parameters import RATIO
from gear_phm.simulation._checks import non_negative, one_of, positive, real

EFFICIENCY_MODELS: tuple[str, ...] = ('lever', 'spur', 'gear_train', 'planetary', 'worm',
                                      'screw')
#: The plants whose pinion is ``pinion_teeth`` (their mesh ripple's teeth).
_PINION_PLANTS = ('spur', 'gear_train')
#: Flank angle of the screw plant's thread [rad]: trapezoidal (ISO 2904, 30 deg included).
SCREW_FLANK_ANGLE = float(np.deg2rad(15.0))


@dataclass(frozen=True)
class Plant:
    """Plant parameters (SI). ratio R [-] = load torque / motor torque, ideal.

    motor_inertia J_m and load_inertia J_l [kg m^2]; air_load_preload T0 [N m] and
    air_load_stiffness k [N m/rad]; spur geometry: pinion_teeth [-], module [m],
    pressure_angle [rad], bearing radii [m] (used only when efficiency_model == 'spur');
    direction_offset [-]: lever plant only, eta_I is the lever model's at u + direction_offset;
    mesh_teeth [-]: lever plant, teeth of the pinion on the motor shaft (the mesh ripple's
    frequency is teeth x shaft speed; the spur plant's are ``pinion_teeth``); lead_angle
    [rad]: the worm and screw plants' lead angle.
    """

    ratio: float = float(RATIO.default)
    motor_inertia: float = 2.0e-3
    load_inertia: float = 0.5
    air_load_preload: float = 20.0
    air_load_stiffness: float = 60.0
    efficiency_model: str = 'lever'
    pinion_teeth: float = 20.0
    module: float = 1.0e-3
    pressure_angle: float = float(np.deg2rad(20.0))
    bearing_radius_1: float = 0.0
    bearing_radius_2: float = 0.0
    direction_offset: float = 0.0
    mesh_teeth: float = 20.0
    lead_angle: float = float(np.deg2rad(10.0))

    def __post_init__(self) -> None:
        positive('ratio', self.ratio)
        non_negative('motor_inertia', self.motor_inertia)
        non_negative('load_inertia', self.load_inertia)
        non_negative('air_load_preload', self.air_load_preload)
        real('air_load_stiffness', self.air_load_stiffness)
        one_of('efficiency_model', self.efficiency_model, EFFICIENCY_MODELS)
        positive('mesh_teeth', self.mesh_teeth)
        offset = real('direction_offset', self.direction_offset)
        if offset != 0.0 and self.efficiency_model != 'lever':
            raise ValueError(f'direction_offset applies to the lever plant only (the spur '
                             f'plant has its own mismatch), got {offset!r} with '
                             f'{self.efficiency_model}')
        if self.efficiency_model != 'lever':
            self.reference_model(0.0)  # geometry errors surface now, naming the field

    def spur_gear(self, friction: ArrayLike) -> SpurGear:
        """Return the spur stage (pinion ``pinion_teeth``, wheel ``ratio * pinion_teeth``)."""
        pinion = positive('pinion_teeth', self.pinion_teeth)
        return SpurGear(z1=pinion, z2=self.ratio * pinion, module=self.module,
                        pressure_angle=self.pressure_angle, friction=friction,
                        bearing_radius_1=self.bearing_radius_1,
                        bearing_radius_2=self.bearing_radius_2)

    def reference_model(self, friction: ArrayLike) -> (SpurGear | GearTrain | PlanetaryGearSet
                                                       | WormGear | LeadScrew):
        """Return the reference model of a plant other than ``lever`` (module docstring).

        Its ratio is ``ratio``. Raises ValueError (a ModelError naming the field) for a
        geometry the model refuses, e.g. a planetary ratio at most 2 or a worm ratio below 1.
        """
        model, ratio = self.efficiency_model, self.ratio
        if model == 'spur':
            return self.spur_gear(friction)
        pinion = positive('pinion_teeth', self.pinion_teeth)
        if model == 'gear_train':
            stage = SpurGear(z1=pinion, z2=float(np.sqrt(ratio)) * pinion, module=self.module,
                             pressure_angle=self.pressure_angle, friction=friction)
            return GearTrain((stage, stage))
        if model == 'planetary':
            if not ratio > 2.0:
                msg = (f'ratio of the planetary plant must be > 2 (1 + z_ring / z_sun), got '
                       f'{ratio!r}')
                raise ValueError(msg) from None
            # R = 2 + 2 z_planet / z_sun: the smaller gear gets pinion_teeth
            z_sun, z_planet = ((pinion, 0.5 * (ratio - 2.0) * pinion) if ratio >= 4.0
                               else (2.0 * pinion / (ratio - 2.0), pinion))
            return PlanetaryGearSet(z_sun, z_planet, module=self.module,
                                    pressure_angle=self.pressure_angle, friction=friction)
        if model == 'worm':
            return WormGear(self.lead_angle, 1.0, ratio, self.pressure_angle, friction)
        lead = 2.0 * np.pi / ratio
        return LeadScrew(lead, lead / (np.pi * np.tan(self.lead_angle)),
                         SCREW_FLANK_ANGLE, friction)

    def efficiencies(self, friction: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return (true lever u, eta_D, eta_I) [-] for the plant friction value(s) [-]."""
        friction = np.asarray(friction, dtype=float)
        if self.efficiency_model == 'lever':
            u = friction
            eta_d = np.asarray(eta_opposing(u, self.ratio))
            shifted = u + self.direction_offset if self.direction_offset else u
            eta_i = np.asarray(eta_aiding(shifted, self.ratio))
        else:
            eta_d, eta_i = (np.asarray(e)
                            for e in self.reference_model(friction).efficiencies())
            u = np.asarray(u_from_eta_opposing(eta_d, self.ratio))
        return u, eta_d, eta_i

    @property
    def teeth(self) -> float:
        """Teeth of the pinion on the motor shaft: ``mesh_teeth``, or the spur plants'."""
        return float(self.pinion_teeth if self.efficiency_model in _PINION_PLANTS
                     else self.mesh_teeth)

    def output_torque(self, position: ArrayLike, acceleration: ArrayLike,
                      scale: ArrayLike | None = None) -> np.ndarray:
        """Torque the gearbox applies to the load, tau_out [N m].

        At load position [rad] and load acceleration [rad/s^2]; ``scale`` [-] multiplies the
        air load (:mod:`gear_phm.simulation.load_variation`; None: 1).
        """
        position = np.asarray(position, dtype=float)
        inertial = self.load_inertia * np.asarray(acceleration, dtype=float)
        if scale is None:
            return inertial + self.air_load_preload + self.air_load_stiffness * position
        air = self.air_load_preload + self.air_load_stiffness * position
        return inertial + np.asarray(scale, dtype=float) * air

    def input_torque(self, tau_out: ArrayLike, velocity_load: ArrayLike, eta_d: ArrayLike,
                     eta_i: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(gearbox input torque tau_in [N m] on the motor side, power-flow phase code)."""
        tau_out = np.asarray(tau_out, dtype=float)
        w = np.asarray(velocity_load, dtype=float)
        eta_d = np.broadcast_to(np.asarray(eta_d, dtype=float), tau_out.shape)
        eta_i = np.broadcast_to(np.asarray(eta_i, dtype=float), tau_out.shape)
        load_power = tau_out * w
        opposing = load_power > 0.0
        aiding = load_power < 0.0
        holding = np.maximum(eta_i, 0.0) * tau_out / self.ratio
        safe_eta_d = np.where(opposing, eta_d, 1.0)
        tau_in = np.where(opposing, tau_out / (self.ratio * safe_eta_d),
                          np.where(aiding, eta_i * tau_out / self.ratio, holding))
        phase = np.full(tau_out.shape, IDLE, dtype=np.int8)
        phase[opposing] = OPPOSING
        phase[aiding & (eta_i >= 0.0)] = AIDING
        phase[aiding & (eta_i < 0.0)] = SELF_LOCKING
        return tau_in, phase
