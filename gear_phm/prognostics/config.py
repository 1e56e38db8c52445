"""Named prognostics parameters with units, limits and validation (no ROS imports).

:class:`HealthConfig` holds everything that sets end of life, the RUL extrapolation and the
health levels. The diagnostics node declares one ROS parameter per field (same name, same
range, same description); ``gear-phm analyze`` exposes them as ``--kebab-case`` options.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields
import math

#: (low, high, unit, description) per numeric parameter; bounds inclusive.
PARAMETERS: dict[str, tuple[float, float, str, str]] = {
    'ratio': (1e-6, 1e6, '-', 'ideal torque gain load/motor R = z2/z1 of the gearbox'),
    'eta_opposing_min': (-1.0, 1.0, '-',
                         'end of life when the opposing-load efficiency eta_D falls to this'),
    'u_max': (0.0, 1e6, '-', 'end of life when u reaches this (0: criterion disabled)'),
    'eta_warn': (-1.0, 1.0, '-', 'WARN when eta_D is below this (must be > eta_opposing_min)'),
    'warn_horizon': (0.0, 1e12, 's', 'WARN when the 5 % RUL bound is below this'),
    'detect_z': (0.0, 100.0, '-',
                 'degradation is seen when du/dt > detect_z sigma(du/dt); otherwise RUL = inf'),
    'trend_window': (1e-3, 1e12, 's', 'length of the u history used to detect acceleration'),
    'accel_z': (0.0, 1e3, '-',
                'exponential trend when the fitted curvature of u(t) exceeds accel_z std errors'),
    'min_growth': (0.0, 1e6, '-',
                   'and when du/dt grows by at least this fraction over the trend window'),
    'mc_samples': (100, 1_000_000, '-', 'Monte Carlo samples of the posterior for RUL bounds'),
    'seed': (0, 2**31 - 1, '-', 'seed of the fixed Monte Carlo draws (common random numbers)'),
    'nis_window': (1, 100_000, '-', 'number of recent NIS values averaged for divergence'),
    'nis_probability': (0.5, 1.0 - 1e-12, '-',
                        'chi-square probability of the NIS-average bound (divergence above)'),
    'max_u_sigma': (1e-9, 1e6, '-', 'divergence when sigma_u exceeds this'),
    'stale_timeout': (1e-3, 1e6, 's', 'STALE when no estimator input arrives for this long'),
}
TRENDS = ('auto', 'linear', 'exponential')
_INTEGERS = ('mc_samples', 'seed', 'nis_window')


@dataclass(frozen=True)
class HealthConfig:
    """End-of-life, RUL and health-level parameters (SI units, see :data:`PARAMETERS`)."""

    ratio: float = 3.0
    eta_opposing_min: float = 0.5
    self_locking_eol: bool = True
    u_max: float = 0.0
    eta_warn: float = 0.6
    warn_horizon: float = 3600.0
    detect_z: float = 2.0
    trend: str = 'auto'
    trend_window: float = 600.0
    accel_z: float = 3.0
    min_growth: float = 0.25
    mc_samples: int = 2000
    seed: int = 0
    nis_window: int = 20
    nis_probability: float = 0.999
    max_u_sigma: float = 1.0
    stale_timeout: float = 2.0

    def __post_init__(self) -> None:
        for name, (low, high, unit, _) in PARAMETERS.items():
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f'{name} must be a number [{unit}], got {value!r}')
            if name in _INTEGERS and int(value) != value:
                raise ValueError(f'{name} must be an integer, got {value!r}')
            if math.isnan(value) or not low <= value <= high:
                raise ValueError(f'{name} must be in [{low:g}, {high:g}] {unit}, got {value!r}')
        if not isinstance(self.self_locking_eol, bool):
            raise ValueError(f'self_locking_eol must be a bool, got {self.self_locking_eol!r}')
        if self.trend not in TRENDS:
            raise ValueError(f'trend must be one of {TRENDS}, got {self.trend!r}')
        problem = cross_field_problem(asdict(self))
        if problem:
            raise ValueError(problem)

    def replace(self, **changes: object) -> HealthConfig:
        """Return a validated copy with ``changes`` applied; unknown names raise ValueError."""
        unknown = set(changes) - {f.name for f in fields(self)}
        if unknown:
            raise ValueError(f'unknown health parameter(s): {sorted(unknown)}')
        return HealthConfig(**{**asdict(self), **changes})

    def as_dict(self) -> dict[str, object]:
        """Plain dict of all parameters."""
        return asdict(self)


def cross_field_problem(values: dict[str, object]) -> str:
    """Reason why a set of parameter values is inconsistent, or '' if it is fine.

    Checks: ``eta_warn > eta_opposing_min`` (the warning must come before end of life) and
    ``eta_opposing_min > -1/ratio`` (below that no friction parameter reaches it).
    """
    eta_min = float(values['eta_opposing_min'])  # type: ignore[arg-type]
    eta_warn = float(values['eta_warn'])  # type: ignore[arg-type]
    ratio = float(values['ratio'])  # type: ignore[arg-type]
    if not eta_warn > eta_min:
        return (f'eta_warn must be > eta_opposing_min ({eta_min!r}) so WARN comes before end '
                f'of life, got {eta_warn!r}')
    if not eta_min > -1.0 / ratio:
        return (f'eta_opposing_min must be > -1/ratio = {-1.0 / ratio:.4g} (no friction '
                f'parameter reaches it), got {eta_min!r}')
    return ''
