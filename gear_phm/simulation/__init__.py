"""Seeded transmission simulator (numpy only, no clock): plant, duty cycle, wear, sensors.

Usage::

    from gear_phm.simulation import SimulationConfig, Wear, simulate, sample_times
    config = SimulationConfig(wear=Wear('linear', initial=0.05, rate=1e-3), seed=1)
    result = simulate(config, sample_times(duration=60.0, rate=100.0))
    result.effort_motor, result.eta_opposing, result.phase   # measured and true arrays

See docs/publisher.md for the physics, the defaults and their units, and docs/lives.md for
realistic lives (onset, running-in, mixed and stochastic wear, mismatch) and
:func:`gear_phm.simulation.lives.random_life`.
"""
from gear_phm.simulation.duty_cycle import DutyCycle
from gear_phm.simulation.parameters import config_from_parameters, PARAMETERS
from gear_phm.simulation.plant import (
    EFFICIENCY_MODELS,
    Plant,
)
from gear_phm.simulation.sensors import Channel, CHANNELS, Sensors
from gear_phm.simulation.simulator import (sample_times, simulate, SimulationConfig,
                                           SimulationResult, Simulator)
from gear_phm.simulation.wear import PROCESSES, REACHING_KINDS, Wear, WEAR_KINDS, WearPath

__all__ = [
    'CHANNELS', 'Channel', 'DutyCycle', 'EFFICIENCY_MODELS', 'PARAMETERS', 'PROCESSES', 'Plant',
    'Sensors', 'SimulationConfig', 'SimulationResult', 'Simulator', 'REACHING_KINDS',
    'WEAR_KINDS', 'Wear', 'WearPath', 'config_from_parameters', 'sample_times', 'simulate',
]
