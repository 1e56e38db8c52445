"""Flat parameter table of a simulation, shared by the publisher node and ``gear-phm simulate``.

:data:`PARAMETERS` maps a flat name (node parameter / CLI option with ``-`` for ``_``) to
(default, description with unit, low bound or None, high bound or None).
:func:`config_from_parameters` builds a validated :class:`SimulationConfig` from such a dict.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from gear_phm.simulation._checks import one_of, real
from gear_phm.simulation.duty_cycle import DutyCycle
from gear_phm.simulation.plant import EFFICIENCY_MODELS, Plant
from gear_phm.simulation.sensors import Channel, Sensors
from gear_phm.simulation.simulator import SimulationConfig
from gear_phm.simulation.wear import Wear, WEAR_KINDS

_PLANT, _DUTY, _WEAR = Plant(), DutyCycle(), Wear()
_SENSORS = Sensors()

#: name -> (default, description, low, high); low/high are inclusive bounds or None.
PARAMETERS: dict[str, tuple[Any, str, float | None, float | None]] = {
    'seed': (0, 'seed of the sensor noise (numpy PCG64) [-]', 0, None),
    'plant': (_PLANT.efficiency_model,
              f'efficiency model of the plant: {" | ".join(EFFICIENCY_MODELS)}', None, None),
    'ratio': (_PLANT.ratio, 'transmission ratio R, ideal load/motor torque gain [-], > 0',
              1e-6, None),
    'motor_inertia': (_PLANT.motor_inertia, 'rotor inertia J_m [kg m^2]', 0.0, None),
    'load_inertia': (_PLANT.load_inertia, 'load (surface) inertia J_l [kg m^2]', 0.0, None),
    'air_load_preload': (_PLANT.air_load_preload,
                         'air-load hinge moment at retracted position T0 [N m]', 0.0, None),
    'air_load_stiffness': (_PLANT.air_load_stiffness,
                           'air-load hinge moment gradient k [N m/rad]', None, None),
    'pinion_teeth': (_PLANT.pinion_teeth,
                     'spur plant: pinion teeth z1 [-]; wheel z2 = ratio z1', 2.0, None),
    'module': (_PLANT.module, 'spur plant: module [m]', 1e-9, None),
    'bearing_radius_1': (_PLANT.bearing_radius_1,
                         'spur plant: pinion bearing friction radius [m]', 0.0, None),
    'bearing_radius_2': (_PLANT.bearing_radius_2,
                         'spur plant: wheel bearing friction radius [m]', 0.0, None),
    'travel': (_DUTY.travel, 'duty cycle: load stroke [rad]', 1e-9, None),
    'extend_time': (_DUTY.extend_time, 'duty cycle: extension stroke time [s]', 1e-6, None),
    'retract_time': (_DUTY.retract_time, 'duty cycle: retraction stroke time [s]', 1e-6, None),
    'accel_time': (_DUTY.accel_time, 'duty cycle: raised-cosine ramp time [s]', 1e-6, None),
    'dwell_extended': (_DUTY.dwell_extended, 'duty cycle: dwell when extended [s]', 0.0, None),
    'dwell_retracted': (_DUTY.dwell_retracted, 'duty cycle: dwell when retracted [s]',
                        0.0, None),
    'wear': (_WEAR.kind, f'wear trajectory: {" | ".join(WEAR_KINDS)}', None, None),
    'friction_initial': (_WEAR.initial,
                         'friction value at t = 0: lever u, or tooth coefficient f (spur) [-]',
                         0.0, None),
    'wear_rate': (_WEAR.rate, 'linear: friction increase per second [1/s]; exponential: '
                              'relative growth rate [1/s]', 0.0, None),
    't_fault': (_WEAR.t_fault, 'step wear: fault time after the start [s]', 0.0, None),
    'fault_step': (_WEAR.step, 'step wear: friction increase at t_fault [-]', 0.0, None),
}
for _channel in ('velocity_motor', 'velocity_load', 'effort_motor', 'effort_load'):
    _unit = 'rad/s' if _channel.startswith('velocity') else 'N m'
    PARAMETERS[f'noise_{_channel}'] = (getattr(_SENSORS, _channel).sigma,
                                       f'sensor noise standard deviation of {_channel} '
                                       f'[{_unit}]', 0.0, None)
    PARAMETERS[f'bias_{_channel}'] = (getattr(_SENSORS, _channel).bias,
                                      f'sensor bias of {_channel} [{_unit}]', None, None)


def config_from_parameters(values: Mapping[str, Any]) -> SimulationConfig:
    """Build a SimulationConfig from flat values (missing names take PARAMETERS' defaults).

    Raises ValueError naming the field and the value; unknown names are refused too.
    """
    unknown = sorted(set(values) - set(PARAMETERS))
    if unknown:
        raise ValueError(f'unknown simulation parameter(s): {", ".join(unknown)}')
    v = {name: values.get(name, spec[0]) for name, spec in PARAMETERS.items()}
    for name, (default, _, low, high) in PARAMETERS.items():
        if isinstance(default, str):
            continue
        number = real(name, v[name])
        if low is not None and number < low:
            raise ValueError(f'{name} must be >= {low:g}, got {v[name]!r}')
        if high is not None and number > high:
            raise ValueError(f'{name} must be <= {high:g}, got {v[name]!r}')
    one_of('plant', v['plant'], EFFICIENCY_MODELS)
    one_of('wear', v['wear'], WEAR_KINDS)
    plant = Plant(ratio=v['ratio'], motor_inertia=v['motor_inertia'],
                  load_inertia=v['load_inertia'], air_load_preload=v['air_load_preload'],
                  air_load_stiffness=v['air_load_stiffness'], efficiency_model=v['plant'],
                  pinion_teeth=v['pinion_teeth'], module=v['module'],
                  bearing_radius_1=v['bearing_radius_1'],
                  bearing_radius_2=v['bearing_radius_2'])
    duty = DutyCycle(travel=v['travel'], extend_time=v['extend_time'],
                     retract_time=v['retract_time'], accel_time=v['accel_time'],
                     dwell_extended=v['dwell_extended'], dwell_retracted=v['dwell_retracted'])
    wear = Wear(kind=v['wear'], initial=v['friction_initial'], rate=v['wear_rate'],
                t_fault=v['t_fault'], step=v['fault_step'])
    sensors = Sensors(*(Channel(sigma=_named(v, f'noise_{c}'), bias=_named(v, f'bias_{c}'))
                        for c in ('velocity_motor', 'velocity_load', 'effort_motor',
                                  'effort_load')))
    seed = v['seed']
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise ValueError(f'seed must be an integer >= 0, got {seed!r}')
    return SimulationConfig(plant=plant, duty_cycle=duty, wear=wear, sensors=sensors,
                            seed=seed)


def _named(values: Mapping[str, Any], name: str) -> float:
    """Re-raise a Channel error with the flat parameter name."""
    try:
        Channel(sigma=values[name]) if name.startswith('noise') else Channel(bias=values[name])
    except ValueError as exc:
        raise ValueError(f'{name}: {exc}') from None
    value: float = values[name]
    return value
