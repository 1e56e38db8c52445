"""Seeded transmission simulator (numpy only, no clock): plant, duty cycle, wear, sensors.

Usage::

    from gear_phm.simulation import SimulationConfig, Wear, simulate, sample_times
    config = SimulationConfig(wear=Wear('linear', initial=0.05, rate=1e-3), seed=1)
    result = simulate(config, sample_times(duration=60.0, rate=100.0))
    result.effort_motor, result.eta_opposing, result.phase   # measured and true arrays

See docs/publisher.md for the physics, the defaults and their units.
"""
from gear_phm.simulation.duty_cycle import DutyCycle
from gear_phm.simulation.plant import (
    EFFICIENCY_MODELS,
    Plant,
)
from gear_phm.simulation.parameters import PARAMETERS, config_from_parameters
from gear_phm.simulation.sensors import CHANNELS, Channel, Sensors
from gear_phm.simulation.simulator import (
    SimulationConfig,
    SimulationResult,
    Simulator,
    sample_times,
    simulate,
)
from gear_phm.simulation.wear import WEAR_KINDS, Wear

__all__ = [
    'CHANNELS', 'Channel', 'DutyCycle', 'EFFICIENCY_MODELS', 'PARAMETERS', 'Plant', 'Sensors',
    'SimulationConfig', 'SimulationResult', 'Simulator', 'WEAR_KINDS', 'Wear',
    'config_from_parameters', 'sample_times', 'simulate',
]
