"""Named estimator parameters with units, limits and validation (no ROS imports)."""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields
import math

#: (low, high, unit, description) per numeric parameter; bounds inclusive.
PARAMETERS: dict[str, tuple[float, float, str, str]] = {
    'ratio': (1e-6, 1e6, '-', 'ideal torque gain load/motor R = z2/z1 of the gearbox'),
    'motor_torque_noise': (0.0, 1e6, 'N m', 'std dev of one motor effort sample'),
    'motor_speed_noise': (0.0, 1e6, 'rad/s', 'std dev of one motor velocity sample'),
    'load_torque_noise': (0.0, 1e6, 'N m', 'std dev of one load effort sample'),
    'load_speed_noise': (0.0, 1e6, 'rad/s', 'std dev of one load velocity sample'),
    'motor_inertia': (0.0, 1e6, 'kg m^2', 'rotor inertia J_m on the motor shaft'),
    'load_inertia': (0.0, 1e6, 'kg m^2',
                     'inertia between the load torque sensor and the gear (usually 0)'),
    'window': (1e-3, 3600.0, 's', 'longest energy window within one power-flow phase'),
    'min_window': (0.0, 3600.0, 's', 'shorter windows are discarded (must be < window)'),
    'min_energy': (0.0, 1e12, 'J', 'windows with |E_m| or |E_l| below this are discarded'),
    'power_threshold': (0.0, 1e9, 'W', 'deadband on |P_m| and |P_l| for the power flow'),
    'speed_threshold': (0.0, 1e6, 'rad/s', 'motor speeds at or below this are zero speed'),
    'sensor_timeout': (1e-4, 3600.0, 's', 'a longer gap between samples is a sensor timeout'),
    'gate_threshold': (0.0, math.inf, '-',
                       'Mahalanobis gate on NIS (chi-square 1 dof; 10.83 = 99.9 %)'),
    'max_consecutive_gated': (1, 1_000_000, '-',
                              'after this many gated windows in a row the filter re-initialises'
                              ' on the measurement (step fault)'),
    'process_noise': (0.0, 1e6, '1/s^3',
                      'spectral density of white noise on d2u/dt2 (constant-rate model)'),
    'initial_u': (0.0, 1e3, '-', 'prior friction parameter u'),
    'initial_u_sigma': (1e-9, 1e3, '-', 'prior std dev of u'),
    'initial_rate_sigma': (1e-12, 1e3, '1/s', 'prior std dev of du/dt'),
    'model_sigma': (0.0, 1e3, '-', 'extra std dev added to each pseudo-measurement of u'),
    'publish_rate': (0.0, 1e4, 'Hz', 'output rate in sample time between filter updates'
                                     ' (0: only at updates)'),
}
BACKWARDS_POLICIES = ('reset', 'skip')


@dataclass(frozen=True)
class EstimatorConfig:
    """Estimator parameters (SI units, see :data:`PARAMETERS`). Validated on construction."""

    ratio: float = 3.0
    motor_torque_noise: float = 0.01
    motor_speed_noise: float = 0.01
    load_torque_noise: float = 0.01
    load_speed_noise: float = 0.01
    motor_inertia: float = 0.0
    load_inertia: float = 0.0
    window: float = 1.0
    min_window: float = 0.2
    min_energy: float = 0.01
    power_threshold: float = 0.01
    speed_threshold: float = 0.01
    sensor_timeout: float = 0.5
    gate_threshold: float = 10.83
    max_consecutive_gated: int = 3
    process_noise: float = 1e-11
    initial_u: float = 0.05
    initial_u_sigma: float = 0.5
    initial_rate_sigma: float = 1e-3
    model_sigma: float = 0.0
    publish_rate: float = 10.0
    backwards_policy: str = 'reset'

    def __post_init__(self) -> None:
        for name, (low, high, unit, _) in PARAMETERS.items():
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f'{name} must be a number [{unit}], got {value!r}')
            if name == 'max_consecutive_gated' and int(value) != value:
                raise ValueError(f'{name} must be an integer, got {value!r}')
            if not (low <= value <= high) or math.isnan(value):
                raise ValueError(
                    f'{name} must be in [{low:g}, {high:g}] {unit}, got {value!r}')
        if self.min_window >= self.window:
            raise ValueError(f'min_window must be < window ({self.window!r} s), '
                             f'got {self.min_window!r}')
        if self.backwards_policy not in BACKWARDS_POLICIES:
            raise ValueError(f'backwards_policy must be one of {BACKWARDS_POLICIES}, '
                             f'got {self.backwards_policy!r}')

    def replace(self, **changes: float | str) -> EstimatorConfig:
        """Return a validated copy with ``changes`` applied; unknown names raise ValueError."""
        unknown = set(changes) - {f.name for f in fields(self)}
        if unknown:
            raise ValueError(f'unknown estimator parameter(s): {sorted(unknown)}')
        return EstimatorConfig(**{**asdict(self), **changes})

    def as_dict(self) -> dict[str, float | str]:
        """Plain dict of all parameters."""
        return asdict(self)
