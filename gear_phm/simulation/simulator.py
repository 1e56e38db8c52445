"""Seeded, vectorised simulation of a wearing transmission; time is passed in, never read."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.simulation.duty_cycle import DutyCycle
from gear_phm.simulation.plant import Plant
from gear_phm.simulation.sensors import Sensors
from gear_phm.simulation.wear import Wear, WearPath


@dataclass(frozen=True)
class SimulationConfig:
    """Everything that defines a run; ``seed`` seeds the sensor noise (numpy PCG64).

    ``wear_seed`` seeds the stochastic wear path (None: ``seed``); a fleet's recordings of one
    unit share it, so the unit's wear continues from one recording to the next.
    """

    plant: Plant = field(default_factory=Plant)
    duty_cycle: DutyCycle = field(default_factory=DutyCycle)
    wear: Wear = field(default_factory=Wear)
    sensors: Sensors = field(default_factory=Sensors)
    seed: int = 0
    wear_seed: int | None = None

    def __post_init__(self) -> None:
        for name, kind in (('plant', Plant), ('duty_cycle', DutyCycle), ('wear', Wear),
                           ('sensors', Sensors)):
            if not isinstance(getattr(self, name), kind):
                raise ValueError(f'{name} must be a {kind.__name__}, got '
                                 f'{getattr(self, name)!r}')
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) \
                or self.seed < 0:
            raise ValueError(f'seed must be an integer >= 0, got {self.seed!r}')
        if self.wear_seed is not None:
            self.wear.path(self.wear_seed)          # ValueError on a bad seed, now

    def wear_path(self) -> WearPath:
        """Return the run's friction trajectory (its stochastic wear path, seeded)."""
        return self.wear.path(self.seed if self.wear_seed is None else self.wear_seed)


@dataclass(frozen=True)
class SimulationResult:
    """Arrays of equal length n, SI units.

    Measured: position_*, velocity_*, effort_* (as published on joint_states).
    True: true_velocity_*, true_effort_*, u, friction, eta_opposing, eta_aiding, phase
    (power-flow code of docs/architecture.md).
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

    def __len__(self) -> int:
        return int(self.t.shape[0])


class Simulator:
    """Stateful only in its noise generator (and the cache of its wear path).

    ``sample`` over consecutive chunks of t gives the same result as one call over the
    concatenated t.
    """

    def __init__(self, config: SimulationConfig) -> None:
        if not isinstance(config, SimulationConfig):
            raise ValueError(f'config must be a SimulationConfig, got {config!r}')
        self.config = config
        self._rng = np.random.default_rng(int(config.seed))
        self._wear = config.wear_path()

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
        position_load, velocity_load, acceleration_load = cfg.duty_cycle.load_motion(t)
        friction = self._wear.value(t)
        u, eta_d, eta_i = plant.efficiencies(friction)
        tau_out = plant.output_torque(position_load, acceleration_load)
        tau_in, phase = plant.input_torque(tau_out, velocity_load, eta_d, eta_i)
        jammed = (eta_d <= 0.0) & (phase == 1)
        if jammed.any():
            first = int(np.argmax(jammed))
            raise ValueError(
                f'friction value {float(friction[first])!r} at t = {float(t[first]):g} s gives '
                f'eta_D = {float(eta_d[first]):.4g} <= 0: the gearbox jams')
        acceleration_motor = ratio * acceleration_load
        effort_motor = tau_in + plant.motor_inertia * acceleration_motor
        truth = np.column_stack((ratio * velocity_load, velocity_load, effort_motor, tau_out))
        measured = cfg.sensors.measure(truth, self._rng)
        return SimulationResult(
            t=t, position_motor=ratio * position_load, position_load=position_load,
            velocity_motor=measured[:, 0], velocity_load=measured[:, 1],
            effort_motor=measured[:, 2], effort_load=measured[:, 3],
            true_velocity_motor=truth[:, 0], true_velocity_load=velocity_load,
            true_effort_motor=effort_motor, true_effort_load=tau_out,
            acceleration_motor=acceleration_motor, u=np.asarray(u, dtype=float),
            friction=friction, eta_opposing=np.asarray(eta_d, dtype=float),
            eta_aiding=np.asarray(eta_i, dtype=float), phase=phase)


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
