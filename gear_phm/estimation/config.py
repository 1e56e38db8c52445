"""Named estimator parameters with units, limits and validation (no ROS imports)."""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields
import math

from gear_phm.parameters import check_values, defaults, ParamSpec, RATIO

#: The estimator's parameters (node parameters of the same names, config/estimator.yaml).
PARAMETERS: tuple[ParamSpec, ...] = (
    RATIO,
    ParamSpec('motor_torque_noise', 0.01, 'std dev of one motor effort sample', 'N m', 0.0, 1e6),
    ParamSpec('motor_speed_noise', 0.01, 'std dev of one motor velocity sample', 'rad/s', 0.0,
              1e6),
    ParamSpec('load_torque_noise', 0.01, 'std dev of one load effort sample', 'N m', 0.0, 1e6),
    ParamSpec('load_speed_noise', 0.01, 'std dev of one load velocity sample', 'rad/s', 0.0,
              1e6),
    ParamSpec('motor_inertia', 0.0, 'rotor inertia J_m on the motor shaft', 'kg m^2', 0.0, 1e6),
    ParamSpec('learn_motor_inertia', True, 'learn the rotor inertia that motor_inertia leaves '
              'in the windows (a torque that includes J_m dw/dt; it matters at high ratios)'),
    ParamSpec('motor_effort_sign', 1, '+1: the motor effort is the torque the motor applies to '
              'its shaft (README "Conventions"); -1: the opposite sign', '-', -1, 1),
    ParamSpec('load_effort_sign', 1, '+1: the load effort is the torque the gearbox output '
              'applies to the load (README "Conventions"); -1: the opposite sign, e.g. a torque '
              'sensor that reads the reaction', '-', -1, 1),
    ParamSpec('load_inertia', 0.0,
              'inertia between the load torque sensor and the gear (usually 0)', 'kg m^2', 0.0,
              1e6),
    ParamSpec('window', 1.0, 'longest energy window within one power-flow phase', 's', 1e-3,
              3600.0),
    ParamSpec('min_window', 0.2, 'shorter windows are discarded (must be < window)', 's', 0.0,
              3600.0),
    ParamSpec('min_energy', 0.01, 'windows with |E_m| or |E_l| below this are discarded', 'J',
              0.0, 1e12),
    ParamSpec('power_threshold', 0.01, 'deadband on |P_m| and |P_l| for the power flow', 'W',
              0.0, 1e9),
    ParamSpec('speed_threshold', 0.01, 'motor speeds at or below this are zero speed', 'rad/s',
              0.0, 1e6),
    ParamSpec('sensor_timeout', 0.5, 'a longer gap between samples is a sensor timeout', 's',
              1e-4, 3600.0),
    ParamSpec('gate_threshold', 10.83,
              'Mahalanobis gate on NIS (chi-square 1 dof; 10.83 = 99.9 %)', '-', 0.0, math.inf),
    ParamSpec('max_consecutive_gated', 3, 'after this many gated windows in a row the filter '
              're-initialises on the measurement (step fault)', '-', 1, 1_000_000),
    ParamSpec('process_noise', 1e-11,
              'spectral density of white noise on d2u/dt2: the starting value, then learned '
              'from the data (fixed when adaptive is false)', '1/s^3', 0.0, 1e6),
    ParamSpec('adaptive', True, 'learn the process noise and the per-direction model-mismatch '
              'variance from the innovations (false: fixed process_noise and model_sigma)'),
    ParamSpec('adapt_memory', 5.0, 'length of the innovation whiteness test that drives the '
              'process noise', 'updates', 2.0, 1e4),
    ParamSpec('adapt_gain', 0.05, 'step of ln(process noise) per unit of the whiteness '
              'statistic', '-', 0.0, 10.0),
    ParamSpec('adapt_pull', 0.02, 'decrease of ln(process noise) per update, towards the '
              'smallest q the data allow', '-', 0.0, 10.0),
    ParamSpec('mismatch_memory', 50.0, 'window of the per-direction model-mismatch variance '
              '(covariance matching)', 'updates', 1.0, 1e6),
    ParamSpec('initial_u', 0.05, 'prior friction parameter u', '-', 0.0, 1e3),
    ParamSpec('initial_u_sigma', 0.5, 'prior std dev of u', '-', 1e-9, 1e3),
    ParamSpec('initial_rate_sigma', 1e-3, 'prior std dev of du/dt', '1/s', 1e-12, 1e3),
    ParamSpec('model_sigma', 0.0, 'extra std dev added to each pseudo-measurement of u', '-',
              0.0, 1e3),
    ParamSpec('publish_rate', 10.0,
              'output rate in sample time between filter updates (0: only at updates)', 'Hz',
              0.0, 1e4),
    ParamSpec('backwards_policy', 'reset', 'a run of stamps far back in time (bag loop, rig '
              'restart): reset the estimator or skip the samples',
              choices=('reset', 'skip')),
    ParamSpec('stamp_run', 10, 'stamps in sequence that confirm a jump of the stamps: a run '
              'far back resets (backwards_policy reset), a run far ahead is accepted; a '
              'shorter run is dropped as stray (dropped_backwards, dropped_future)', '-', 1,
              100_000),
    ParamSpec('period_hold', 5.0, 'a longer sample period must last this long (in stamp time) '
              "before it is taken as the rig's new rate; until then its gaps count as "
              'samples_missing', 's', 0.0, 1e6),
    ParamSpec('no_load_model', False, 'learn the load-independent (no-load) loss at the motor '
              '(T_0 sign(w_m) + c_v w_m and a torque offset) jointly with u, and fuse into u '
              'only the windows where it is identified (false: the paper model, every loss is '
              'friction)'),
    ParamSpec('no_load_tolerance', 0.004, "largest std dev of a window's no-load correction, "
              'relative to its load energy (about the efficiency), for the window to be fused '
              'into u; above it the window is held as not identifiable', '-', 1e-6, 1.0),
    ParamSpec('no_load_cool_gap', 3600.0, 'after an idle gap longer than this (stamp time) the '
              'no-load loss starts again from its cold value', 's', 0.0, 1e9),
    ParamSpec('no_load_reference_speed', 0.0, 'motor speed at which the no-load torque is '
              'reported (0: the typical speed of the windows)', 'rad/s', 0.0, 1e9),
    ParamSpec('rated_load_torque', 0.0, 'output torque of the rated point for the total '
              'efficiency (0: not reported)', 'N m', 0.0, 1e12),
    ParamSpec('rated_speed', 0.0, 'output speed of the rated point for the total efficiency '
              '(0: not reported)', 'rad/s', 0.0, 1e9),
    ParamSpec('loss_warn', 0.01, 'WARN when the share of samples missing over the last '
              'status period exceeds this', '-', 0.0, 1.0),
)
#: ``{name: default}`` of :data:`PARAMETERS`, the one home of these defaults.
DEFAULTS = defaults(PARAMETERS)


@dataclass(frozen=True)
class EstimatorConfig:
    """Estimator parameters (SI units, see :data:`PARAMETERS`). Validated on construction."""

    ratio: float = float(DEFAULTS['ratio'])
    motor_torque_noise: float = float(DEFAULTS['motor_torque_noise'])
    motor_speed_noise: float = float(DEFAULTS['motor_speed_noise'])
    load_torque_noise: float = float(DEFAULTS['load_torque_noise'])
    load_speed_noise: float = float(DEFAULTS['load_speed_noise'])
    motor_inertia: float = float(DEFAULTS['motor_inertia'])
    motor_effort_sign: int = int(DEFAULTS['motor_effort_sign'])
    load_effort_sign: int = int(DEFAULTS['load_effort_sign'])
    load_inertia: float = float(DEFAULTS['load_inertia'])
    window: float = float(DEFAULTS['window'])
    min_window: float = float(DEFAULTS['min_window'])
    min_energy: float = float(DEFAULTS['min_energy'])
    power_threshold: float = float(DEFAULTS['power_threshold'])
    speed_threshold: float = float(DEFAULTS['speed_threshold'])
    sensor_timeout: float = float(DEFAULTS['sensor_timeout'])
    gate_threshold: float = float(DEFAULTS['gate_threshold'])
    max_consecutive_gated: int = int(DEFAULTS['max_consecutive_gated'])
    process_noise: float = float(DEFAULTS['process_noise'])
    adaptive: bool = bool(DEFAULTS['adaptive'])
    learn_motor_inertia: bool = bool(DEFAULTS['learn_motor_inertia'])
    adapt_memory: float = float(DEFAULTS['adapt_memory'])
    adapt_gain: float = float(DEFAULTS['adapt_gain'])
    adapt_pull: float = float(DEFAULTS['adapt_pull'])
    mismatch_memory: float = float(DEFAULTS['mismatch_memory'])
    initial_u: float = float(DEFAULTS['initial_u'])
    initial_u_sigma: float = float(DEFAULTS['initial_u_sigma'])
    initial_rate_sigma: float = float(DEFAULTS['initial_rate_sigma'])
    model_sigma: float = float(DEFAULTS['model_sigma'])
    publish_rate: float = float(DEFAULTS['publish_rate'])
    backwards_policy: str = str(DEFAULTS['backwards_policy'])
    stamp_run: int = int(DEFAULTS['stamp_run'])
    period_hold: float = float(DEFAULTS['period_hold'])
    no_load_model: bool = bool(DEFAULTS['no_load_model'])
    no_load_tolerance: float = float(DEFAULTS['no_load_tolerance'])
    no_load_cool_gap: float = float(DEFAULTS['no_load_cool_gap'])
    no_load_reference_speed: float = float(DEFAULTS['no_load_reference_speed'])
    rated_load_torque: float = float(DEFAULTS['rated_load_torque'])
    rated_speed: float = float(DEFAULTS['rated_speed'])
    loss_warn: float = float(DEFAULTS['loss_warn'])

    def __post_init__(self) -> None:
        check_values(PARAMETERS, asdict(self))
        for name in ('motor_effort_sign', 'load_effort_sign'):
            if getattr(self, name) not in (-1, 1):
                raise ValueError(f'{name} must be 1 or -1, got {getattr(self, name)!r}')
        if self.min_window >= self.window:
            raise ValueError(f'min_window must be < window ({self.window!r} s), '
                             f'got {self.min_window!r}')

    def replace(self, **changes: float | str | bool) -> EstimatorConfig:
        """Return a validated copy with ``changes`` applied; unknown names raise ValueError."""
        unknown = set(changes) - {f.name for f in fields(self)}
        if unknown:
            raise ValueError(f'unknown estimator parameter(s): {sorted(unknown)}')
        return EstimatorConfig(**{**asdict(self), **changes})

    def as_dict(self) -> dict[str, float | str | bool]:
        """Plain dict of all parameters."""
        return asdict(self)
