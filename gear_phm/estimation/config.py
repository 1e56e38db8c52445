"""Named estimator parameters with units, limits and validation (no ROS imports).

Each parameter is declared once, as a field of :class:`EstimatorConfig`. To add one, add a
field ``name: type = param(default, description, unit, low, high)`` (see
:func:`gear_phm.parameters.param`; ``choices=`` for a text); :data:`PARAMETERS`, the node
parameter and the ``gear-phm analyze`` option follow from it. Then give it a commented entry
in config/estimator.yaml and, for a rule between fields, a check in ``__post_init__``.

A field that gives the learned state its meaning is ``read_only=True`` (structural): the
ratio, the effort signs (which way the samples read) and ``motor_inertia`` (the learned rotor
inertia is what it leaves). The node refuses to change them at run time, and
:meth:`~gear_phm.estimation.EstimatorPipeline.reconfigure` too; every other field applies
live and keeps what was learned.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields
import math

from gear_phm.parameters import (check_values, defaults, param, param_from, ParamSpec, RATIO,
                                 specs_of, Value)


@dataclass(frozen=True)
class EstimatorConfig:
    """Estimator parameters (SI units, see :data:`PARAMETERS`). Validated on construction."""

    ratio: float = param_from(RATIO, float)
    motor_torque_noise: float = param(
        0.01, 'std dev of one motor effort sample', 'N m', 0.0, 1e6)
    motor_speed_noise: float = param(
        0.01, 'std dev of one motor velocity sample', 'rad/s', 0.0, 1e6)
    load_torque_noise: float = param(
        0.01, 'std dev of one load effort sample', 'N m', 0.0, 1e6)
    load_speed_noise: float = param(
        0.01, 'std dev of one load velocity sample', 'rad/s', 0.0, 1e6)
    motor_inertia: float = param(
        0.0, 'rotor inertia J_m on the motor shaft', 'kg m^2', 0.0, 1e6, read_only=True)
    learn_motor_inertia: bool = param(
        True, 'learn the rotor inertia that motor_inertia leaves in the windows (a torque that '
        'includes J_m dw/dt; it matters at high ratios)')
    motor_effort_sign: int = param(
        1, '+1: the motor effort is the torque the motor applies to its shaft (README '
        '"Conventions"); -1: the opposite sign', '-', -1, 1, read_only=True)
    load_effort_sign: int = param(
        1, '+1: the load effort is the torque the gearbox output applies to the load (README '
        '"Conventions"); -1: the opposite sign, e.g. a torque sensor that reads the reaction',
        '-', -1, 1, read_only=True)
    load_inertia: float = param(
        0.0, 'inertia between the load torque sensor and the gear (usually 0)', 'kg m^2', 0.0,
        1e6)
    window: float = param(
        1.0, 'longest energy window within one power-flow phase', 's', 1e-3, 3600.0)
    min_window: float = param(
        0.2, 'shorter windows are discarded (must be < window)', 's', 0.0, 3600.0)
    min_energy: float = param(
        0.01, 'windows with |E_m| or |E_l| below this are discarded', 'J', 0.0, 1e12)
    power_threshold: float = param(
        0.01, 'deadband on |P_m| and |P_l| for the power flow', 'W', 0.0, 1e9)
    speed_threshold: float = param(
        0.01, 'motor speeds at or below this are zero speed', 'rad/s', 0.0, 1e6)
    sensor_timeout: float = param(
        0.5, 'a longer gap between samples is a sensor timeout', 's', 1e-4, 3600.0)
    gate_threshold: float = param(
        10.83, 'Mahalanobis gate on NIS (chi-square 1 dof; 10.83 = 99.9 %)', '-', 0.0, math.inf)
    max_consecutive_gated: int = param(
        3, 'after this many gated windows in a row the filter re-initialises on the '
        'measurement (step fault)', '-', 1, 1_000_000)
    process_noise: float = param(
        1e-11, 'spectral density of white noise on d2u/dt2: the starting value, then learned '
        'from the data (fixed when adaptive is false)', '1/s^3', 0.0, 1e6)
    adaptive: bool = param(
        True, 'learn the process noise and the per-direction model-mismatch variance from the '
        'innovations (false: fixed process_noise and model_sigma)')
    adapt_memory: float = param(
        5.0, 'length of the innovation whiteness test that drives the process noise',
        'updates', 2.0, 1e4)
    adapt_gain: float = param(
        0.05, 'step of ln(process noise) per unit of the whiteness statistic', '-', 0.0, 10.0)
    adapt_pull: float = param(
        0.02, 'decrease of ln(process noise) per update, towards the smallest q the data '
        'allow', '-', 0.0, 10.0)
    mismatch_memory: float = param(
        50.0, 'window of the per-direction model-mismatch variance (covariance matching)',
        'updates', 1.0, 1e6)
    initial_u: float = param(0.05, 'prior friction parameter u', '-', 0.0, 1e3)
    initial_u_sigma: float = param(0.5, 'prior std dev of u', '-', 1e-9, 1e3)
    initial_rate_sigma: float = param(1e-3, 'prior std dev of du/dt', '1/s', 1e-12, 1e3)
    model_sigma: float = param(
        0.0, 'extra std dev added to each pseudo-measurement of u', '-', 0.0, 1e3)
    publish_rate: float = param(
        10.0, 'output rate in sample time between filter updates (0: only at updates)', 'Hz',
        0.0, 1e4)
    backwards_policy: str = param(
        'reset', 'a run of stamps far back in time (bag loop, rig restart): reset the '
        'estimator or skip the samples', choices=('reset', 'skip'))
    stamp_run: int = param(
        10, 'stamps in sequence that confirm a jump of the stamps: a run far back resets '
        '(backwards_policy reset), a run far ahead is accepted; a shorter run is dropped as '
        'stray (dropped_backwards, dropped_future)', '-', 1, 100_000)
    period_hold: float = param(
        5.0, 'a longer sample period must last this long (in stamp time) before it is taken '
        "as the rig's new rate; until then its gaps count as samples_missing", 's', 0.0, 1e6)
    no_load_model: bool = param(
        False, 'learn the load-independent (no-load) loss at the motor (T_0 sign(w_m) + c_v w_m '
        'and a torque offset) jointly with u, and fuse into u only the windows where it is '
        'identified (false: the paper model, every loss is friction)', read_only=True)
    no_load_tolerance: float = param(
        0.004, "largest std dev of a window's no-load correction, relative to its load energy "
        '(about the efficiency), for the window to be fused into u; above it the window is '
        'held as not identifiable', '-', 1e-6, 1.0)
    no_load_cool_gap: float = param(
        3600.0, 'after an idle gap longer than this (stamp time) the no-load loss starts again '
        'from its cold value', 's', 0.0, 1e9)
    no_load_reference_speed: float = param(
        0.0, 'motor speed at which the no-load torque is reported (0: the typical speed of the '
        'windows)', 'rad/s', 0.0, 1e9)
    no_load_band_time: float = param(
        3600.0, "operating time over which the no-load loss's healthy band is learned (a cold "
        'start included); after it, a loss above no_load_band_factor times that band is WARN',
        's', 0.0, 1e9)
    no_load_band_factor: float = param(
        1.5, 'the no-load loss is above its healthy band beyond this multiple of the highest '
        'healthy value (WARN: seal or lubrication, never end of life)', '-', 1.0, 1e3)
    rated_load_torque: float = param(
        0.0, 'output torque of the rated point for the total efficiency (0: not reported)',
        'N m', 0.0, 1e12)
    rated_speed: float = param(
        0.0, 'output speed of the rated point for the total efficiency (0: not reported)',
        'rad/s', 0.0, 1e9)
    loss_warn: float = param(
        0.01, 'WARN when the share of samples missing over the last status period exceeds '
        'this', '-', 0.0, 1.0)

    def __post_init__(self) -> None:
        check_values(PARAMETERS, asdict(self))
        for name in ('motor_effort_sign', 'load_effort_sign'):
            if getattr(self, name) not in (-1, 1):
                raise ValueError(f'{name} must be 1 or -1, got {getattr(self, name)!r}')
        if self.min_window >= self.window:
            raise ValueError(f'min_window must be < window ({self.window!r} s), '
                             f'got {self.min_window!r}')

    def replace(self, **changes: Value) -> EstimatorConfig:
        """Return a validated copy with ``changes`` applied; unknown names raise ValueError."""
        unknown = set(changes) - {f.name for f in fields(self)}
        if unknown:
            raise ValueError(f'unknown estimator parameter(s): {sorted(unknown)}')
        return EstimatorConfig(**{**asdict(self), **changes})

    def as_dict(self) -> dict[str, Value]:
        """Plain dict of all parameters."""
        return asdict(self)


#: The estimator's parameters (node parameters of the same names, config/estimator.yaml), one
#: per field of :class:`EstimatorConfig`, in field order.
PARAMETERS: tuple[ParamSpec, ...] = specs_of(EstimatorConfig)
#: ``{name: default}`` of :data:`PARAMETERS`.
DEFAULTS = defaults(PARAMETERS)
