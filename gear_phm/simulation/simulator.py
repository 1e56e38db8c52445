"""Seeded, vectorised simulation of a wearing transmission; time is passed in, never read.

The sample times t are elapsed time [s]; the duty cycle, the load variation and the wear run
on the operating time s(t) of :class:`~gear_phm.simulation.idle_gap.IdleGap` (s = t without
an idle gap), the oil temperature on t.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.simulation.duty_cycle import DutyCycle
from gear_phm.simulation.idle_gap import IdleGap
from gear_phm.simulation.load_variation import LoadVariation
from gear_phm.simulation.no_load import NoLoadLoss
from gear_phm.simulation.oil import Oil
from gear_phm.simulation.plant import Plant
from gear_phm.simulation.sensors import differenced, encoder_reading, Sensors
from gear_phm.simulation.wear import Wear, WearPath

_PARTS = (('plant', Plant), ('duty_cycle', DutyCycle), ('wear', Wear), ('sensors', Sensors),
          ('no_load', NoLoadLoss), ('oil', Oil), ('load_variation', LoadVariation),
          ('idle_gap', IdleGap))


@dataclass(frozen=True)
class SimulationConfig:
    """Everything that defines a run; ``seed`` seeds the sensor noise (numpy PCG64).

    ``wear_seed`` seeds the stochastic wear path (None: ``seed``); a fleet's recordings of one
    unit share it, so the unit's wear continues from one recording to the next.
    ``seed`` also seeds the load variation (its own streams). ``publish_temperature``: the
    writers and the publisher also put out the oil temperature (sensor_msgs/Temperature).
    """

    plant: Plant = field(default_factory=Plant)
    duty_cycle: DutyCycle = field(default_factory=DutyCycle)
    wear: Wear = field(default_factory=Wear)
    sensors: Sensors = field(default_factory=Sensors)
    seed: int = 0
    wear_seed: int | None = None
    no_load: NoLoadLoss = field(default_factory=NoLoadLoss)
    oil: Oil = field(default_factory=Oil)
    load_variation: LoadVariation = field(default_factory=LoadVariation)
    idle_gap: IdleGap = field(default_factory=IdleGap)
    publish_temperature: bool = False

    def __post_init__(self) -> None:
        for name, kind in _PARTS:
            if not isinstance(getattr(self, name), kind):
                raise ValueError(f'{name} must be a {kind.__name__}, got '
                                 f'{getattr(self, name)!r}')
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) \
                or self.seed < 0:
            raise ValueError(f'seed must be an integer >= 0, got {self.seed!r}')
        if self.wear_seed is not None:
            self.wear.path(self.wear_seed)          # ValueError on a bad seed, now

    @property
    def extended_truth(self) -> bool:
        """Return True if a no-load loss, a load variation or an idle gap is on.

        The writers and the publisher then also put out the no-load and oil truth topics.
        """
        return self.no_load.enabled or self.load_variation.enabled or self.idle_gap.enabled

    def operating_time(self, t: ArrayLike) -> np.ndarray:
        """Operating time [s] at elapsed times t [s] (:class:`IdleGap`)."""
        return self.idle_gap.operating_time(t)

    def wear_path(self) -> WearPath:
        """Return the run's friction trajectory (its stochastic wear path, seeded)."""
        return self.wear.path(self.seed if self.wear_seed is None else self.wear_seed)


@dataclass(frozen=True)
class SimulationResult:
    """Arrays of equal length n, SI units.

    Measured: position_*, velocity_*, effort_* (as published on joint_states).
    True: true_velocity_*, true_effort_*, u, friction, eta_opposing, eta_aiding, phase
    (power-flow code of docs/architecture.md); oil_temperature [degC]; the no-load loss
    no_load_torque [N m] (included in true_effort_motor), its Coulomb part no_load_coulomb
    [N m] and viscous coefficient no_load_viscous [N m s/rad] at the oil's temperature;
    drag_factor [-] (the oil's viscosity factor); load_scale [-] (the air load's factor).
    """

    t: np.ndarray
    position_motor: np.ndarray
    position_load: np.ndarray
    velocity_motor: np.ndarray
    velocity_load: np.ndarray
    effort_motor: np.ndarray
    effort_load: np.ndarray
    true_velocity_motor: np.ndarray
    true_velocity_load: np.ndarray
    true_effort_motor: np.ndarray
    true_effort_load: np.ndarray
    acceleration_motor: np.ndarray
    u: np.ndarray
    friction: np.ndarray
    eta_opposing: np.ndarray
    eta_aiding: np.ndarray
    phase: np.ndarray
    oil_temperature: np.ndarray
    drag_factor: np.ndarray
    no_load_torque: np.ndarray
    no_load_coulomb: np.ndarray
    no_load_viscous: np.ndarray
    load_scale: np.ndarray

    def __len__(self) -> int:
        return int(self.t.shape[0])


class Simulator:
    """Stateful only in its noise generator, its last encoder readings and its wear path's cache.

    ``sample`` over consecutive chunks of t gives the same result as one call over the
    concatenated t (with encoders, the chunks must follow each other in time).
    """

    def __init__(self, config: SimulationConfig) -> None:
        if not isinstance(config, SimulationConfig):
            raise ValueError(f'config must be a SimulationConfig, got {config!r}')
        self.config = config
        self._rng = np.random.default_rng(int(config.seed))
        self._wear = config.wear_path()
        #: (time, motor reading, load reading) of the last sample, for encoder differencing
        self._previous: tuple[float, float, float] | None = None

    def sample(self, t: ArrayLike) -> SimulationResult:
        """Simulate at the 1-D array of times t [s] (finite, any order)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if t.ndim != 1:
            raise ValueError(f't must be a 1-D array of times, got shape {t.shape}')
        if not np.all(np.isfinite(t)):
            raise ValueError('t must be finite')
        cfg = self.config
        plant = cfg.plant
        ratio = float(plant.ratio)
        s = cfg.operating_time(t)
        position_load, velocity_load, acceleration_load = cfg.duty_cycle.load_motion(s)
        friction = self._wear.value(s)
        u, eta_d, eta_i = plant.efficiencies(friction)
        load_scale = cfg.load_variation.scale(s, cfg.duty_cycle.period, cfg.seed) \
            if cfg.load_variation.enabled else np.ones_like(t)
        tau_out = plant.output_torque(position_load, acceleration_load,
                                      load_scale if cfg.load_variation.enabled else None)
        tau_in, phase = plant.input_torque(tau_out, velocity_load, eta_d, eta_i)
        jammed = (eta_d <= 0.0) & (phase == 1)
        if jammed.any():
            first = int(np.argmax(jammed))
            raise ValueError(
                f'friction value {float(friction[first])!r} at t = {float(t[first]):g} s gives '
                f'eta_D = {float(eta_d[first]):.4g} <= 0: the gearbox jams')
        acceleration_motor = ratio * acceleration_load
        velocity_motor = ratio * velocity_load
        temperature = cfg.oil.temperature(t, cfg.idle_gap)
        factor = cfg.oil.drag_factor(temperature)
        coulomb, viscous = cfg.no_load.parts(factor)
        if cfg.no_load.enabled:
            no_load = cfg.no_load.torque(velocity_motor, factor)
            effort_motor = tau_in + no_load + plant.motor_inertia * acceleration_motor
        else:
            no_load = np.zeros_like(t)
            effort_motor = tau_in + plant.motor_inertia * acceleration_motor
        truth = np.column_stack((velocity_motor, velocity_load, effort_motor, tau_out))
        position_motor = ratio * position_load
        mesh_angle = plant.teeth * position_motor
        sensed = truth
        if cfg.sensors.encoders:
            position_motor, position_load, sensed = self._encoders(
                t, position_motor, position_load, truth)
        measured = cfg.sensors.measure(sensed, self._rng, mesh_angle)
        return SimulationResult(
            t=t, position_motor=position_motor, position_load=position_load,
            velocity_motor=measured[:, 0], velocity_load=measured[:, 1],
            effort_motor=measured[:, 2], effort_load=measured[:, 3],
            true_velocity_motor=truth[:, 0], true_velocity_load=velocity_load,
            true_effort_motor=effort_motor, true_effort_load=tau_out,
            acceleration_motor=acceleration_motor, u=np.asarray(u, dtype=float),
            friction=friction, eta_opposing=np.asarray(eta_d, dtype=float),
            eta_aiding=np.asarray(eta_i, dtype=float), phase=phase,
            oil_temperature=temperature, drag_factor=factor, no_load_torque=no_load,
            no_load_coulomb=coulomb, no_load_viscous=viscous, load_scale=load_scale)

    def _encoders(self, t: np.ndarray, position_motor: np.ndarray, position_load: np.ndarray,
                  truth: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return the encoder readings (motor, load) [rad] and the channels, speeds differenced."""
        sensors = self.config.sensors
        motor = encoder_reading(position_motor, sensors.encoder_counts_motor)
        load = encoder_reading(position_load, sensors.encoder_counts_load)
        sensed = truth.copy()
        previous = self._previous
        if sensors.encoder_counts_motor:
            sensed[:, 0] = differenced(motor, t, None if previous is None
                                       else (previous[0], previous[1]))
        if sensors.encoder_counts_load:
            sensed[:, 1] = differenced(load, t, None if previous is None
                                       else (previous[0], previous[2]))
        if t.size:
            self._previous = (float(t[-1]), float(motor[-1]), float(load[-1]))
        return motor, load, sensed


def simulate(config: SimulationConfig, t: ArrayLike) -> SimulationResult:
    """One run of ``config`` at times t [s] (a fresh generator seeded with config.seed)."""
    return Simulator(config).sample(t)


def sample_times(duration: float, rate: float, start: float = 0.0) -> np.ndarray:
    """Uniform sample times start + k / rate [s], k = 0 .. floor(duration rate) - 1."""
    if not (np.isfinite(rate) and rate > 0.0):
        raise ValueError(f'rate must be > 0, got {rate!r}')
    if not (np.isfinite(duration) and duration >= 0.0):
        raise ValueError(f'duration must be >= 0, got {duration!r}')
    count = int(np.floor(duration * rate + 1e-9))
    return start + np.arange(count) / rate
