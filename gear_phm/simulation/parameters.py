"""Flat parameters of a simulation, shared by the publisher node and ``gear-phm simulate``.

:data:`PARAMETERS` holds one :class:`~gear_phm.parameters.ParamSpec` per flat name (node
parameter, CLI option with ``-`` for ``_``); :func:`config_from_parameters` builds a validated
:class:`SimulationConfig` from such values.
"""
from __future__ import annotations

from collections.abc import Mapping

from gear_phm.parameters import check_values, defaults, ParamSpec, RATIO, T, Value
from gear_phm.simulation.duty_cycle import DutyCycle
from gear_phm.simulation.idle_gap import IdleGap
from gear_phm.simulation.load_variation import LoadVariation
from gear_phm.simulation.no_load import NoLoadLoss
from gear_phm.simulation.oil import Oil
from gear_phm.simulation.plant import EFFICIENCY_MODELS, Plant
from gear_phm.simulation.sensors import Channel, CHANNELS, Sensors
from gear_phm.simulation.simulator import SimulationConfig
from gear_phm.simulation.wear import PROCESSES, Wear, WEAR_KINDS

_PLANT, _DUTY, _WEAR = Plant(), DutyCycle(), Wear()
_SENSORS = Sensors()
_OIL, _LOAD = Oil(), LoadVariation()
# Physical bounds of the plant, duty cycle and sensors: within them every simulated sample is
# finite (the fastest stroke, travel 1e4 rad in 2e-6 s, gives load accelerations ~1e16 rad/s^2
# and torques ~1e22 N m, far from float64's 1.8e308).
_INERTIA_MAX = 1e6        # kg m^2
_TORQUE_MAX = 1e9         # N m, and N m/rad for the stiffness
_TIME_MAX = 1e6           # s, a stroke or a dwell
_SENSOR_MAX = 1e9         # rad/s or N m
_TEMPERATURE = (-100.0, 300.0)  # degC
_COUNTS_MAX = 2**31 - 1   # encoder counts per revolution


def _sensor_specs() -> list[ParamSpec]:
    specs = []
    for channel in ('velocity_motor', 'velocity_load', 'effort_motor', 'effort_load'):
        unit = 'rad/s' if channel.startswith('velocity') else 'N m'
        specs.append(ParamSpec(f'noise_{channel}', getattr(_SENSORS, channel).sigma,
                               f'sensor noise standard deviation of {channel}', unit, 0.0,
                               _SENSOR_MAX))
        specs.append(ParamSpec(f'bias_{channel}', getattr(_SENSORS, channel).bias,
                               f'sensor bias of {channel}', unit, -_SENSOR_MAX, _SENSOR_MAX))
    return specs


#: The paper's simulation parameters, in the order of the publisher's config file.
BASE_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec('seed', 0, 'seed of the sensor noise (numpy PCG64)', '-', 0),
    ParamSpec('plant', _PLANT.efficiency_model, 'efficiency model of the plant',
              choices=EFFICIENCY_MODELS),
    RATIO,
    ParamSpec('motor_inertia', _PLANT.motor_inertia, 'rotor inertia J_m', 'kg m^2', 0.0,
              _INERTIA_MAX),
    ParamSpec('load_inertia', _PLANT.load_inertia, 'load (surface) inertia J_l', 'kg m^2', 0.0,
              _INERTIA_MAX),
    ParamSpec('air_load_preload', _PLANT.air_load_preload,
              'air-load hinge moment at retracted position T0', 'N m', 0.0, _TORQUE_MAX),
    ParamSpec('air_load_stiffness', _PLANT.air_load_stiffness,
              'air-load hinge moment gradient k', 'N m/rad', -_TORQUE_MAX, _TORQUE_MAX),
    ParamSpec('pinion_teeth', _PLANT.pinion_teeth,
              'spur plant: pinion teeth z1 (wheel z2 = ratio z1)', '-', 2.0, 1e4),
    ParamSpec('module', _PLANT.module, 'spur plant: module', 'm', 1e-9, 1.0),
    ParamSpec('bearing_radius_1', _PLANT.bearing_radius_1,
              'spur plant: pinion bearing friction radius', 'm', 0.0, 10.0),
    ParamSpec('bearing_radius_2', _PLANT.bearing_radius_2,
              'spur plant: wheel bearing friction radius', 'm', 0.0, 10.0),
    ParamSpec('direction_offset', _PLANT.direction_offset,
              "lever plant: model mismatch, eta_I is the lever model's at u + direction_offset "
              '(eta_D at u)', '-', -1.0, 1.0),
    ParamSpec('lead_angle', _PLANT.lead_angle, 'worm and screw plants: lead angle gamma '
              '(self-locking once the friction angle reaches it)', 'rad', 1e-6, 1.5),
    ParamSpec('travel', _DUTY.travel, 'duty cycle: load stroke', 'rad', 1e-9, 1e4),
    ParamSpec('extend_time', _DUTY.extend_time, 'duty cycle: extension stroke time', 's', 1e-6,
              _TIME_MAX),
    ParamSpec('retract_time', _DUTY.retract_time, 'duty cycle: retraction stroke time', 's',
              1e-6, _TIME_MAX),
    ParamSpec('accel_time', _DUTY.accel_time, 'duty cycle: raised-cosine ramp time', 's', 1e-6,
              _TIME_MAX),
    ParamSpec('dwell_extended', _DUTY.dwell_extended, 'duty cycle: dwell when extended', 's',
              0.0, _TIME_MAX),
    ParamSpec('dwell_retracted', _DUTY.dwell_retracted, 'duty cycle: dwell when retracted', 's',
              0.0, _TIME_MAX),
    ParamSpec('wear', _WEAR.kind, 'wear trajectory', choices=WEAR_KINDS),
    ParamSpec('friction_initial', _WEAR.initial,
              'friction value at t = 0: lever u, or the Coulomb coefficient of the other '
              'plants (tooth f, thread mu)', '-', 0.0),
    ParamSpec('wear_rate', _WEAR.rate, 'linear (and mixed): friction increase per second; '
              'exponential: relative growth rate; power: friction increase at t = 1 s '
              '(coefficient of t^wear_exponent)', '1/s', 0.0),
    ParamSpec('wear_exponent', _WEAR.exponent, 'power wear: exponent of t in '
              'friction_initial + wear_rate t^wear_exponent', '-', 1e-3, 100.0),
    ParamSpec('t_fault', _WEAR.t_fault, 'step wear: fault time after the start', 's', 0.0),
    ParamSpec('fault_step', _WEAR.step, 'step wear: friction increase at t_fault', '-', 0.0),
    ParamSpec('wear_exp_amplitude', _WEAR.exp_amplitude, 'mixed wear: amplitude A of the '
              'exponential term A (exp(wear_exp_rate tau) - 1)', '-', 0.0),
    ParamSpec('wear_exp_rate', _WEAR.exp_rate, 'mixed wear: relative growth rate of the '
              'exponential term', '1/s', 0.0),
    ParamSpec('wear_power_coefficient', _WEAR.power_coefficient, 'mixed wear: coefficient of '
              'the power term tau^wear_exponent (the linear term is wear_rate tau)', '-', 0.0),
    ParamSpec('friction_base', _WEAR.base, 'friction that never wears, added to the wear law '
              '(offset laws, e.g. friction_base + friction_initial exp(wear_rate tau))', '-',
              0.0),
    ParamSpec('wear_onset', _WEAR.onset, 'healthy plateau: the wear clock tau starts at this '
              'time (tau = t - wear_onset after it, 0 before)', 's', 0.0),
    ParamSpec('running_in', _WEAR.running_in, 'running-in: excess friction at t = 0, decaying '
              'as exp(-t / running_in_time)', '-', 0.0),
    ParamSpec('running_in_time', _WEAR.running_in_time, 'running-in: decay time constant',
              's', 1e-6),
    ParamSpec('regime_time', _WEAR.regime_time, 'regime change: from this time the wear clock '
              'runs regime_factor times faster', 's', 0.0),
    ParamSpec('regime_factor', _WEAR.regime_factor, 'regime change: wear-rate factor after '
              'regime_time (1: no change)', '-', 1e-6),
    ParamSpec('wear_process', _WEAR.process, 'stochastic wear around the mean law: gamma '
              '(monotone) or wiener (with drift) increments', choices=PROCESSES),
    ParamSpec('wear_process_scale', _WEAR.process_scale, 'stochastic wear: variance of an '
              'increment per unit of its mean (Var X(t) = scale x mean wear)', '-', 0.0),
    ParamSpec('wear_process_step', _WEAR.process_step, 'stochastic wear: grid step of the '
              'path (interpolated linearly in between)', 's', 0.01),
    *_sensor_specs(),
)

#: The real-gearbox effects (docs/publisher.md), all off by default: no-load drag and the oil
#: temperature, load variation, torque sensor errors, encoders, an idle gap.
EFFECT_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec('no_load_coulomb', 0.0, 'no-load loss: Coulomb drag torque T_0 at the motor, '
              'warm (T_0 sign(w_m))', 'N m', 0.0, _TORQUE_MAX),
    ParamSpec('no_load_viscous', 0.0, 'no-load loss: viscous drag coefficient c_v at the '
              'motor, warm (c_v w_m)', 'N m s/rad', 0.0, _TORQUE_MAX),
    ParamSpec('no_load_cold_factor', _OIL.cold_factor, 'no-load loss: drag at the ambient '
              'oil temperature over the drag warm (1: no temperature dependence)', '-', 1.0,
              100.0),
    ParamSpec('oil_ambient_temperature', _OIL.ambient_temperature, 'oil: ambient '
              'temperature (approached in idle gaps)', 'degC', *_TEMPERATURE),
    ParamSpec('oil_running_temperature', _OIL.running_temperature, 'oil: running '
              'temperature (approached while the gearbox runs; above the ambient one)',
              'degC', *_TEMPERATURE),
    ParamSpec('oil_warm_time_constant', _OIL.warm_time_constant, 'oil: time constant of the '
              'warming while running', 's', 1e-3, _TIME_MAX),
    ParamSpec('oil_cool_time_constant', _OIL.cool_time_constant, 'oil: time constant of the '
              'cooling in an idle gap', 's', 1e-3, _TIME_MAX),
    ParamSpec('oil_initial_warmth', _OIL.initial_warmth, 'oil: temperature at the start, '
              'as a share of the way from the ambient (0, a cold start) to the running '
              'temperature (1)', '-', 0.0, 2.0),
    ParamSpec('publish_temperature', False, 'also put out the oil temperature '
              '(sensor_msgs/Temperature on oil_temperature)'),
    ParamSpec('load_scale_min', _LOAD.scale_min, 'load variation: lowest factor of the air '
              'load per cycle (uniform in [load_scale_min, load_scale_max])', '-', 1e-3, 10.0),
    ParamSpec('load_scale_max', _LOAD.scale_max, 'load variation: highest factor of the air '
              'load per cycle', '-', 1e-3, 10.0),
    ParamSpec('load_modulation', _LOAD.modulation, 'load variation: relative amplitude of '
              'the smooth modulation within a cycle', '-', 0.0, 0.95),
    ParamSpec('load_modulation_frequency', _LOAD.frequency, 'load variation: mean frequency '
              'of the modulation', 'Hz', 1e-4, 1e3),
    *(spec for channel in ('effort_motor', 'effort_load') for spec in (
        ParamSpec(f'gain_{channel}', 0.0, f'gain error of {channel}: reads (1 + gain) x the '
                  f'torque', '-', -0.5, 0.5),
        ParamSpec(f'ripple_{channel}', 0.0, f'mesh-frequency ripple amplitude of {channel} '
                  f'(frequency teeth x motor speed)', 'N m', 0.0, _SENSOR_MAX),
        ParamSpec(f'quantum_{channel}', 0.0, f'quantisation step of {channel} (0: none)',
                  'N m', 0.0, _SENSOR_MAX))),
    ParamSpec('mesh_teeth', _PLANT.mesh_teeth, 'lever plant: teeth of the motor pinion, for '
              'the mesh ripple (spur plant: pinion_teeth)', '-', 2.0, 1e4),
    ParamSpec('encoder_counts_motor', 0, 'motor position encoder: counts per revolution; '
              'the speed is then differenced from it (0: exact position and speed)', '-', 0,
              _COUNTS_MAX),
    ParamSpec('encoder_counts_load', 0, 'load position encoder: counts per revolution (0: '
              'exact position and speed)', '-', 0, _COUNTS_MAX),
    ParamSpec('idle_gap_at', 0.0, 'idle gap: start, in elapsed time (nothing published '
              'during the gap, the oil cools)', 's', 0.0, _TIME_MAX * 1e3),
    ParamSpec('idle_gap_duration', 0.0, 'idle gap: length (0: no gap)', 's', 0.0,
              _TIME_MAX * 1e3),
)

#: Every simulation parameter: the paper's plant, wear and noise, then the effects.
PARAMETERS = BASE_PARAMETERS + EFFECT_PARAMETERS


def config_from_parameters(values: Mapping[str, object]) -> SimulationConfig:
    """Build a SimulationConfig from flat values (missing names take PARAMETERS' defaults).

    Raises ValueError naming the field and the value; unknown names are refused too.
    """
    v = {**defaults(PARAMETERS), **check_values(PARAMETERS, values)}

    def num(name: str) -> float:
        return _typed(v, name, float)

    def text(name: str) -> str:
        return _typed(v, name, str)

    plant = Plant(ratio=num('ratio'), motor_inertia=num('motor_inertia'),
                  load_inertia=num('load_inertia'), air_load_preload=num('air_load_preload'),
                  air_load_stiffness=num('air_load_stiffness'), efficiency_model=text('plant'),
                  pinion_teeth=num('pinion_teeth'), module=num('module'),
                  bearing_radius_1=num('bearing_radius_1'),
                  bearing_radius_2=num('bearing_radius_2'),
                  direction_offset=num('direction_offset'), mesh_teeth=num('mesh_teeth'),
                  lead_angle=num('lead_angle'))
    duty = DutyCycle(travel=num('travel'), extend_time=num('extend_time'),
                     retract_time=num('retract_time'), accel_time=num('accel_time'),
                     dwell_extended=num('dwell_extended'),
                     dwell_retracted=num('dwell_retracted'))
    wear = Wear(kind=text('wear'), initial=num('friction_initial'), rate=num('wear_rate'),
                t_fault=num('t_fault'), step=num('fault_step'), exponent=num('wear_exponent'),
                exp_amplitude=num('wear_exp_amplitude'), exp_rate=num('wear_exp_rate'),
                power_coefficient=num('wear_power_coefficient'), base=num('friction_base'),
                onset=num('wear_onset'), running_in=num('running_in'),
                running_in_time=num('running_in_time'), regime_time=num('regime_time'),
                regime_factor=num('regime_factor'), process=text('wear_process'),
                process_scale=num('wear_process_scale'),
                process_step=num('wear_process_step'))
    channels = {c: Channel(sigma=_named(v, f'noise_{c}'), bias=_named(v, f'bias_{c}'),
                           gain=num(f'gain_{c}') if f'gain_{c}' in v else 0.0,
                           ripple=num(f'ripple_{c}') if f'ripple_{c}' in v else 0.0,
                           quantum=num(f'quantum_{c}') if f'quantum_{c}' in v else 0.0)
                for c in CHANNELS}
    sensors = Sensors(**channels, encoder_counts_motor=_typed(v, 'encoder_counts_motor', int),
                      encoder_counts_load=_typed(v, 'encoder_counts_load', int))
    oil = Oil(ambient_temperature=num('oil_ambient_temperature'),
              running_temperature=num('oil_running_temperature'),
              warm_time_constant=num('oil_warm_time_constant'),
              cool_time_constant=num('oil_cool_time_constant'),
              initial_warmth=num('oil_initial_warmth'),
              cold_factor=num('no_load_cold_factor'))
    load = LoadVariation(scale_min=num('load_scale_min'), scale_max=num('load_scale_max'),
                         modulation=num('load_modulation'),
                         frequency=num('load_modulation_frequency'))
    return SimulationConfig(plant=plant, duty_cycle=duty, wear=wear, sensors=sensors,
                            seed=_typed(v, 'seed', int),
                            no_load=NoLoadLoss(num('no_load_coulomb'), num('no_load_viscous')),
                            oil=oil, load_variation=load,
                            idle_gap=IdleGap(num('idle_gap_at'), num('idle_gap_duration')),
                            publish_temperature=_typed(v, 'publish_temperature', bool))


def _typed(values: Mapping[str, Value], name: str, kind: type[T]) -> T:
    """Return the checked value ``name``, of its spec's type ``kind``.

    Raises TypeError on another type (a checked value never has one).
    """
    value = values[name]
    if not isinstance(value, kind):
        msg = f'{name} is {value!r}, not of type {kind.__name__}'
        raise TypeError(msg)
    return value


def _named(values: Mapping[str, Value], name: str) -> float:
    """Re-raise a Channel error with the flat parameter name."""
    value = _typed(values, name, float)
    try:
        Channel(sigma=value) if name.startswith('noise') else Channel(bias=value)
    except ValueError as exc:
        raise ValueError(f'{name}: {exc}') from None
    return value
