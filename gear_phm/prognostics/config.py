"""Named prognostics parameters with units, limits and validation (no ROS imports).

:class:`HealthConfig` holds everything that sets end of life, the RUL extrapolation and the
health levels. The diagnostics node declares one ROS parameter per field (same name, same
range, same description); ``gear-phm analyze`` exposes them as ``--kebab-case`` options.

Each parameter is declared once, as a field of :class:`HealthConfig`. To add one, add a field
``name: type = param(default, description, unit, low, high)`` (see
:func:`gear_phm.parameters.param`; ``choices=`` for a text); :data:`PARAMETERS` follows from
it. Then give it a commented entry in config/diagnostics.yaml and, for a rule between fields,
a check in :func:`cross_field_problem`.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
import math

from gear_phm.parameters import (check_values, defaults, param, param_from, ParamSpec, RATIO,
                                 specs_of, Value)
from gear_phm.prognostics.laws import MODELS

TRENDS = ('auto', *MODELS)
#: The derived eta_warn lies this fraction of the degradation budget from eta_opposing_min up
#: to the gearbox's own healthy eta_D [-]: WARN once 75 % of the budget is used.
ETA_WARN_MARGIN = 0.25
#: The healthy eta_D is learned from the first estimate whose sigma_u is at most this share
#: of the distance from u to u_eol [-]: the filter has settled. An error e in the healthy
#: eta_D moves eta_warn by ETA_WARN_MARGIN e, so a 2-sigma error moves it by 5 % of the
#: budget at most.
HEALTHY_SETTLED_SHARE = 0.1
#: The RUL WARN clears once the RUL's 5 % bound is above this many times ``warn_horizon``:
#: a factor, not the other conditions' hysteresis (a fraction of the distance from a new
#: gearbox, whose RUL is inf). With 1.05, stochastic wear took two lives of the random-life
#: ensemble (28, 75) through WARN, OK, WARN: an early, pessimistic RUL of the new regime
#: (median 1316 s, truth 11 300 s) warned, its p5 rose to 3900-5100 s and cleared it, and
#: the true end of life warned again (docs/prognostics.md, "Health levels").
RUL_CLEAR_FACTOR = 2.0


def derived_eta_warn(eta_opposing_min: float, eta_healthy: float = 1.0) -> float:
    """Return the default WARN efficiency [-].

    eta_min + ETA_WARN_MARGIN (eta_healthy - eta_min): the share 1 - ETA_WARN_MARGIN of the
    degradation budget between the healthy eta_D (learned at the start, see
    :class:`~gear_phm.prognostics.health.LevelTracker`; 1, a loss-free gearbox, for the bound
    in the configuration check) and end of life used. Never above ``eta_healthy``, never
    below ``eta_opposing_min`` (a gearbox already past it gets eta_min).
    """
    budget = max(eta_healthy - eta_opposing_min, 0.0)
    return eta_opposing_min + ETA_WARN_MARGIN * budget


@dataclass(frozen=True)
class HealthConfig:
    """End-of-life, RUL and health-level parameters (SI units, see :data:`PARAMETERS`)."""

    ratio: float = param_from(RATIO, float)
    eta_opposing_min: float = param(
        0.5, 'end of life when the opposing-load efficiency eta_D falls to this', '-', -1.0, 1.0)
    must_back_drive: bool = param(
        False, 'the drive must stay reversible: a gearbox that back-drives when healthy and '
        'becomes self-locking through wear (eta_I <= 0, u >= 1) is at end of life (ERROR); off, '
        'that is a WARN. A gearbox self-locking when healthy is never an end of life by it')
    u_max: float = param(
        0.0, 'end of life when u reaches this (0: criterion disabled)', '-', 0.0, 1e6)
    eta_warn: float = param(
        math.nan, 'WARN when eta_D is below this (must be > eta_opposing_min)', '-', -1.0, 1.0,
        nan_means='derived: eta_opposing_min + 0.25 (eta_healthy - eta_opposing_min), '
                  'eta_healthy the healthy eta_D learned once the filter has settled')
    warn_horizon: float = param(
        3600.0, 'WARN when the RUL median in operating time is below this; it clears once the '
        f'RUL 5 % bound is above {RUL_CLEAR_FACTOR:g} times this', 's', 0.0, 1e12)
    utilisation_window: float = param(
        60.0, 'the elapsed-time RUL assumes the utilisation of the newest max(RUL, this) of '
        'operation (a night idle before a run stops counting after this much operation)', 's',
        0.0, 1e12)
    detect_z: float = param(
        2.0, 'degradation is seen when the fitted du/dt at the newest time > detect_z '
        'sigma(du/dt); otherwise RUL = inf', '-', 0.0, 100.0)
    trend: str = param(
        'auto', 'RUL wear law fitted to the whole u history (auto: by AICc)', choices=TRENDS)
    eta_accuracy: float = param(
        0.001, 'systematic uncertainty of the measured efficiency (torque-sensor calibration, '
        'model accuracy): it does not average out over windows and widens the RUL band by its '
        'u at end of life over du/dt', '-', 0.0, 0.5)
    mc_samples: int = param(
        2000, 'Monte Carlo samples of the posterior for RUL bounds', '-', 100, 1_000_000)
    seed: int = param(
        0, 'seed of the fixed Monte Carlo draws (common random numbers)', '-', 0, 2**31 - 1)
    nis_window: int = param(
        20, 'number of recent NIS values averaged for the filter check', '-', 1, 100_000)
    # 1 - 1e-6, not 0.999: the test runs on every new NIS value, so a long life holds
    # thousands of windows, and at 0.999 a consistent filter crossed the bound (a WARN, then
    # OK, then WARN again on random lives 28 and 89; docs/prognostics.md, "Levels")
    nis_probability: float = param(
        0.999999, 'chi-square probability of the NIS-average bound (model mismatch, WARN, '
        'above)', '-', 0.5, 1.0 - 1e-12)
    max_u_sigma: float = param(
        1.0, 'ERROR (filter lost the signal) when sigma_u exceeds this', '-', 1e-9, 1e6)
    nis_lost: float = param(
        25.0, 'ERROR (filter lost the signal) when the median of the NIS window exceeds this; '
        'a mean above the chi-square bound alone is a model mismatch (WARN)', '-', 1.0, 1e12)
    level_hysteresis: float = param(
        0.05, "a level is left when its value is back by this fraction of the threshold's "
        'distance from a new gearbox (eta_D 1, u 0)', '-', 0.0, 0.5)
    level_dwell: float = param(
        5.0, 'a level change must hold this long in stamp time before it is reported (leaving '
        'a WARN or ERROR condition: level_clear_dwell)', 's', 0.0, 1e6)
    level_clear_dwell: float = param(
        600.0, 'a reported WARN or ERROR condition is left only once its clearing test has '
        'held this long in stamp time, so that a condition near its threshold gives one '
        'report, not a flicker', 's', 0.0, 1e9)
    stale_timeout: float = param(
        2.0, 'STALE when no estimator input arrives for this long', 's', 1e-3, 1e6)

    def __post_init__(self) -> None:
        check_values(PARAMETERS, asdict(self))
        problem = cross_field_problem(asdict(self))
        if problem:
            raise ValueError(problem)

    def replace(self, **changes: object) -> HealthConfig:
        """Return a validated copy with ``changes`` applied; unknown names raise ValueError."""
        unknown = set(changes) - {f.name for f in fields(self)}
        if unknown:
            raise ValueError(f'unknown health parameter(s): {sorted(unknown)}')
        return HealthConfig(**{**asdict(self), **changes})

    def effective_eta_warn(self, eta_healthy: float = math.nan) -> float:
        """Return ``eta_warn``, or when it is NaN (the default) the derived one [-].

        That is :func:`derived_eta_warn` of the healthy eta_D ``eta_healthy`` (NaN while that
        is not learned yet: no efficiency WARN).
        """
        if math.isnan(self.eta_warn):
            if math.isnan(eta_healthy):
                return math.nan
            return derived_eta_warn(self.eta_opposing_min, eta_healthy)
        return self.eta_warn

    def as_dict(self) -> dict[str, Value]:
        """Plain dict of all parameters."""
        return asdict(self)


#: The health parameters (diagnostics node parameters of the same names,
#: config/diagnostics.yaml; ``gear-phm analyze`` and ``evaluate`` options), one per field of
#: :class:`HealthConfig`, in field order.
PARAMETERS: tuple[ParamSpec, ...] = specs_of(HealthConfig)
#: ``{name: default}`` of :data:`PARAMETERS`.
DEFAULTS = defaults(PARAMETERS)
#: The health parameters that are not options of the offline tools (``analyze_bag``,
#: ``gear-phm analyze``/``evaluate``): the ratio is their own argument, and staleness is a
#: live-only concept (no clock runs offline).
NOT_OFFLINE_OPTIONS: tuple[str, ...] = (RATIO.name, 'stale_timeout')


def cross_field_problem(values: Mapping[str, Value]) -> str:
    """Reason why a set of parameter values is inconsistent, or '' if it is fine.

    Checks: an explicit ``eta_warn > eta_opposing_min`` (the warning must come before end of
    life; NaN, the derived default, always is) and ``eta_opposing_min > -1/ratio`` (below that
    no friction parameter reaches it).
    """
    eta_min = float(values['eta_opposing_min'])
    eta_warn = float(values['eta_warn'])
    ratio = float(values['ratio'])
    if not math.isnan(eta_warn) and not eta_warn > eta_min:
        return (f'eta_warn must be > eta_opposing_min ({eta_min!r}) so WARN comes before end '
                f'of life, got {eta_warn!r}; leave it unset (nan) for the derived default '
                f'(eta_min + 0.25 (healthy eta_D - eta_min), at most '
                f'{derived_eta_warn(eta_min):.4g})')
    if not eta_min > -1.0 / ratio:
        return (f'eta_opposing_min must be > -1/ratio = {-1.0 / ratio:.4g} (no friction '
                f'parameter reaches it), got {eta_min!r}')
    return ''
