"""Random lives: whole gearbox lives drawn from a broad prior (``simulate --random-life``).

:func:`random_life` draws, from ``numpy.random.default_rng([seed, LIFE_STREAM])``, the plant
(lever or spur), ratio, duty cycle, load, sensor noise, healthy friction, end-of-life threshold
``eta_opposing_min`` and, for a wear life, the wear law (linear, exponential, power or a mix),
its onset, running-in, base friction, regime change and stochastic process. The wear magnitude
is solved so that the mean friction reaches the end-of-life value near the end of the record;
the true end of life (first sample whose true u >= u_eol, the rule of ``gear-phm evaluate``) is
then found on the realised path. Every distribution and range is in docs/lives.md; the
constants below are that prior.
"""
from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import Any

import numpy as np

from gear_phm.models import u_from_eta_opposing
from gear_phm.parameters import defaults
from gear_phm.simulation.parameters import BASE_PARAMETERS, config_from_parameters, PARAMETERS
from gear_phm.simulation.simulator import SimulationConfig

#: A random life's record, next to the bag's files (:meth:`Life.to_json`).
LIFE_FILE = 'life.json'
#: Tag of the prior's stream: numpy SeedSequence entropy [seed, LIFE_STREAM].
LIFE_STREAM = 0x6C696665
#: Simulation seeds tried per life (seed = life seed * SEED_TRIES + attempt) until the realised
#: stochastic path crosses the end of life inside the record, EOL_TAIL before its end.
SEED_TRIES = 64
#: The record runs on past the true end of life by at least this share of the span from the
#: wear onset, so that the end-of-life ERROR (u's lower 95 % bound past u_eol, then the level
#: dwell) can fall inside it: a gamma path that crossed 4.7 s before the end of a 2 619 s
#: record (seed 65) left no time for any ERROR.
EOL_TAIL = 0.03
#: Families of wear law; ``healthy`` lives do not wear.
FAMILIES: tuple[str, ...] = ('healthy', 'linear', 'exponential', 'power', 'mixed')
#: Probability of each family, in FAMILIES order.
FAMILY_WEIGHTS: tuple[float, ...] = (0.18, 0.164, 0.164, 0.164, 0.328)
#: Features a wear life may have besides its law (healthy lives: only ``mismatch``).
FEATURES: tuple[str, ...] = ('onset', 'running_in', 'offset', 'regime', 'gamma', 'wiener',
                             'mismatch')
#: Record length [s], log-uniform.
DURATION_RANGE = (300.0, 30_000.0)
#: Spur plant: largest tooth friction coefficient searched for the end of life [-].
SPUR_FRICTION_MAX = 3.0
#: The priors: ``paper`` (the paper's physics), ``bench`` (every real-gearbox effect on) and
#: ``architectures`` (the paper's physics on the architecture plants, opt-in).
PRIORS: tuple[str, ...] = ('paper', 'bench', 'architectures')
#: Tag of the architecture prior's own stream, [seed, ARCHITECTURE_STREAM]: the paper prior's
#: draws stay the same.
ARCHITECTURE_STREAM = 0x61726368
#: The architecture prior's plants (:mod:`gear_phm.simulation.plant`), drawn with equal
#: probability.
ARCHITECTURE_PLANTS: tuple[str, ...] = ('gear_train', 'planetary', 'worm', 'screw')
#: Architecture prior: range of the worm's and screw's lead angle [deg], uniform; reversible
#: at the healthy friction (friction angle at most 6 deg for mu <= 0.1).
LEAD_ANGLE_RANGE_DEG = (8.0, 25.0)
#: Tag of the bench prior's own stream, [seed, BENCH_STREAM]: the paper prior's draws stay
#: the same.
BENCH_STREAM = 0x62656E63
#: Features only bench lives have.
BENCH_FEATURES: tuple[str, ...] = ('cold_restart', 'oil_temperature')
#: Bench prior: share of the lives that restart cold mid-record after an idle gap.
COLD_RESTART_SHARE = 0.3


@dataclass(frozen=True)
class Life:
    """One drawn life: flat simulation parameters, record length and its truth.

    ``duration`` [s], ``rate`` [Hz]; ``onset`` and ``end_of_life`` [s] are None for a healthy
    life; ``eta_healthy`` is eta_D at the healthy friction (after any running-in) [-]. Times
    are elapsed times (stamps - start): with an idle gap they run on through it. ``bench``:
    the bench prior's truth (no-load loss, oil, idle gap), None for the paper prior.
    """

    seed: int
    family: str
    features: tuple[str, ...]
    parameters: dict[str, Any] = field(compare=False)
    duration: float
    rate: float
    eta_healthy: float
    eta_opposing_min: float
    u_eol: float
    onset: float | None
    end_of_life: float | None
    attempts: int
    prior: str = 'paper'
    bench: dict[str, Any] | None = field(default=None, compare=False)

    def config(self) -> SimulationConfig:
        """Return the simulation config of the drawn parameters."""
        return config_from_parameters(self.parameters)

    def to_json(self) -> dict[str, Any]:
        """Everything drawn, JSON-ready (written as life.json next to the bag)."""
        return {'seed': self.seed, 'family': self.family, 'features': list(self.features),
                'healthy': self.family == 'healthy', 'duration_s': self.duration,
                'rate_hz': self.rate, 'plant': self.parameters['plant'],
                'ratio': self.parameters['ratio'], 'eta_healthy': self.eta_healthy,
                'eta_opposing_min': self.eta_opposing_min, 'u_eol': self.u_eol,
                'onset_s': self.onset, 'end_of_life_s': self.end_of_life,
                'seed_attempts': self.attempts, 'parameters': dict(self.parameters),
                **({} if self.prior == 'paper' else {'prior': self.prior}),
                **({} if self.bench is None else self.bench)}


def _log_uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(np.exp(rng.uniform(np.log(low), np.log(high))))


def _draw_plant(rng: np.random.Generator, p: dict[str, Any]) -> None:
    """Plant, ratio, duty cycle, load and sensor noise (all lives)."""
    p['plant'] = 'lever' if rng.uniform() < 0.6 else 'spur'
    ratio = p['ratio'] = _log_uniform(rng, 3.0, 100.0)
    accel = p['accel_time'] = float(rng.uniform(0.1, 0.3))
    p['travel'] = float(rng.uniform(0.3, 1.0))
    p['extend_time'] = float(rng.uniform(max(1.5, 2.0 * accel + 0.5), 4.0))
    p['retract_time'] = float(rng.uniform(max(1.2, 2.0 * accel + 0.5), 3.5))
    p['dwell_extended'] = float(rng.uniform(0.0, 2.0))
    p['dwell_retracted'] = float(rng.uniform(0.0, 2.0))
    p['air_load_preload'] = float(rng.uniform(5.0, 40.0))
    p['air_load_stiffness'] = float(rng.uniform(20.0, 100.0))
    p['load_inertia'] = _log_uniform(rng, 0.1, 1.0)
    p['motor_inertia'] = _log_uniform(rng, 0.02, 0.5) * p['load_inertia'] / ratio ** 2
    torque = p['air_load_preload'] + 0.5 * p['air_load_stiffness'] * p['travel']
    speed = p['travel'] / (p['extend_time'] - accel)
    p['noise_effort_load'] = _log_uniform(rng, 1e-3, 1e-2) * torque
    p['noise_effort_motor'] = _log_uniform(rng, 1e-3, 1e-2) * torque / ratio
    p['noise_velocity_load'] = _log_uniform(rng, 3e-3, 3e-2) * speed
    p['noise_velocity_motor'] = _log_uniform(rng, 3e-3, 3e-2) * speed * ratio
    if p['plant'] == 'spur':
        teeth = p['pinion_teeth'] = float(rng.integers(18, 31))
        base_radius = 0.5 * 1e-3 * teeth * math.cos(math.radians(20.0))
        p['bearing_radius_1'] = float(rng.uniform(0.0, 0.015)) * base_radius
        p['bearing_radius_2'] = float(rng.uniform(0.0, 0.015)) * base_radius * ratio


def _draw_architecture(rng: np.random.Generator, p: dict[str, Any]) -> None:
    """Replace the drawn plant by one of ARCHITECTURE_PLANTS with its geometry (docs/lives.md).

    The spur geometry of the paper draw goes back to its defaults.
    """
    base = defaults(BASE_PARAMETERS)
    for name in ('pinion_teeth', 'bearing_radius_1', 'bearing_radius_2'):
        p[name] = base[name]
    plant = p['plant'] = ARCHITECTURE_PLANTS[int(rng.integers(len(ARCHITECTURE_PLANTS)))]
    if plant in ('gear_train', 'planetary'):
        p['pinion_teeth'] = float(rng.integers(18, 31))
    else:
        p['lead_angle'] = math.radians(float(rng.uniform(*LEAD_ANGLE_RANGE_DEG)))


def _friction_max(p: dict[str, Any]) -> float:
    """Largest friction coefficient searched for the end of life of a non-lever plant [-].

    Worm and screw: the friction angle at 0.8 of the way from 0 to where the thread jams
    (gamma + phi' = 90 deg), at the worm's 20 deg normal pressure angle (a screw's thread,
    15 deg, has the smaller friction angle). The gear plants: SPUR_FRICTION_MAX.
    """
    if p['plant'] in ('worm', 'screw'):
        return math.cos(math.radians(20.0)) * math.tan(0.8 * (0.5 * math.pi - p['lead_angle']))
    return SPUR_FRICTION_MAX


def _eta_d(parameters: dict[str, Any], friction: float) -> float:
    config = config_from_parameters(parameters)
    return float(config.plant.efficiencies(friction)[1])


def _friction_for(parameters: dict[str, Any], eta: float, low: float, high: float) -> float:
    """Friction value in [low, high] whose eta_D is ``eta`` (bisection, eta_D decreasing)."""
    for _ in range(80):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if _eta_d(parameters, middle) > eta else (low, middle)
    return 0.5 * (low + high)


def random_life(seed: int, rate: float = 100.0, prior: str = 'paper') -> Life:
    """Draw life ``seed`` (an integer >= 0) for a record at ``rate`` [Hz] from ``prior``.

    ``prior`` is one of :data:`PRIORS`; the bench prior draws the paper prior's quantities
    (the same values) and then the real-gearbox effects from its own stream. The
    architectures prior draws the paper prior's plant quantities, then replaces the plant
    by one of :data:`ARCHITECTURE_PLANTS` from its own stream; its friction is drawn as the
    spur plant's. Raises ValueError on a bad seed, rate or prior.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f'seed must be an integer >= 0, got {seed!r}')
    if not (math.isfinite(rate) and rate > 0.0):
        raise ValueError(f'rate must be > 0 Hz, got {rate!r}')
    if prior not in PRIORS:
        raise ValueError(f'prior must be one of {", ".join(PRIORS)}; got {prior!r}')
    rng = np.random.default_rng([int(seed), LIFE_STREAM])
    p: dict[str, Any] = dict(defaults(PARAMETERS if prior == 'bench' else BASE_PARAMETERS))
    _draw_plant(rng, p)
    if prior == 'architectures':
        _draw_architecture(np.random.default_rng([int(seed), ARCHITECTURE_STREAM]), p)
    ratio = p['ratio']
    features: list[str] = []
    if p['plant'] == 'lever':
        eta0 = float(rng.uniform(0.80, 0.97))
        f0 = float(u_from_eta_opposing(eta0, ratio))
        drop = float(rng.uniform(0.03, 0.20))
        if rng.uniform() < 0.35:
            features.append('mismatch')
            sign = 1.0 if rng.uniform() < 0.5 else -1.0
            p['direction_offset'] = sign * float(rng.uniform(0.05, 0.25)) * f0
    else:
        f0 = float(rng.uniform(0.03, 0.10))
        eta0 = _eta_d(p, f0)
        drop = min(float(rng.uniform(0.02, 0.08)),
                   0.8 * (eta0 - _eta_d(p, _friction_max(p))))
    eta_min = max(eta0 - drop, 0.5)
    u_eol = float(u_from_eta_opposing(eta_min, ratio))
    duration = float(round(_log_uniform(rng, *DURATION_RANGE)))
    family = FAMILIES[int(rng.choice(len(FAMILIES), p=FAMILY_WEIGHTS))]
    p['friction_initial'] = f0
    bench = None
    record = duration             # elapsed length of the record, an idle gap included
    if prior == 'bench':
        bench = _draw_bench(np.random.default_rng([int(seed), BENCH_STREAM]), p, duration)
        record = duration + p['idle_gap_duration']
        features += [f for f in BENCH_FEATURES if bench[f]]
    if family == 'healthy':
        p['seed'] = int(seed) * SEED_TRIES
        return Life(int(seed), family, tuple(features), p, record, float(rate), eta0,
                    eta_min, u_eol, None, None, 1, prior, _bench_json(bench, p))
    if p['plant'] == 'lever':
        f_eol = u_eol
    else:
        f_eol = _friction_for(p, eta_min, f0, _friction_max(p))
    budget = f_eol - f0
    onset = 0.0
    if rng.uniform() < 0.7:
        features.append('onset')
        onset = float(rng.uniform(0.05, 0.6)) * duration
    t_eol = onset + float(rng.uniform(0.80, 0.92)) * (duration - onset)
    running_in = 0.0
    if rng.uniform() < 0.4:
        features.append('running_in')
        running_in = p['running_in'] = float(rng.uniform(0.1, 0.5)) * budget
        p['running_in_time'] = float(rng.uniform(0.01, 0.08)) * duration
    if rng.uniform() < 0.5:
        features.append('offset')
        p['friction_base'] = float(rng.uniform(0.3, 0.9)) * f0
    initial = p['friction_initial'] = f0 - p['friction_base']
    p['wear_onset'] = onset
    if rng.uniform() < 0.3:
        features.append('regime')
        p['regime_time'] = onset + float(rng.uniform(0.3, 0.8)) * (t_eol - onset)
        factor = _log_uniform(rng, 1.5, 4.0)
        p['regime_factor'] = factor if rng.uniform() < 0.75 else 1.0 / factor
    tau_eol = float(config_from_parameters(p).wear.clock(t_eol))
    # the mean friction at t_eol is f_eol: the wear part makes up what running-in leaves
    wear = budget - running_in * math.exp(-t_eol / p['running_in_time'])
    _wear_law(rng, p, family, wear, tau_eol, initial)
    process = ('none', 'gamma', 'wiener')[int(rng.choice(3, p=(0.4, 0.3, 0.3)))]
    if process != 'none':
        features.append(process)
        p['wear_process'] = process
        p['wear_process_scale'] = float(rng.uniform(0.05, 0.3)) ** 2 * wear
    life_features = tuple(f for f in FEATURES + BENCH_FEATURES if f in features)
    for attempt in range(SEED_TRIES):
        p['seed'] = int(seed) * SEED_TRIES + attempt
        config = config_from_parameters(p)
        eol = end_of_life(config, u_eol, record, rate)
        eta_end = config.plant.efficiencies(config.wear_path().value(duration))[1]
        tail = max(EOL_TAIL * (duration - onset), 1.0)
        start = config.idle_gap.elapsed(onset)
        if eol is not None and start < eol < record - tail and float(eta_end) > 0.05:
            return Life(int(seed), family, life_features, p, record, float(rate), eta0,
                        eta_min, u_eol, start, eol, attempt + 1, prior,
                        _bench_json(bench, p))
    msg = f'life {seed}: no seed of {SEED_TRIES} crosses the end of life inside the record'
    raise ValueError(msg)


def _draw_bench(rng: np.random.Generator, p: dict[str, Any], duration: float
                ) -> dict[str, Any]:
    """Draw the bench prior's effects into ``p`` (docs/lives.md); return their truth.

    ``duration`` [s]: the record's operating length.
    """
    ratio = p['ratio']
    peak = p['air_load_preload'] + p['air_load_stiffness'] * p['travel']   # load [N m]
    rated = peak / ratio                    # rated input torque [N m]
    speed = ratio * p['travel'] / (p['extend_time'] - p['accel_time'])   # motor [rad/s]
    share = float(rng.uniform(0.005, 0.05))
    split = float(rng.uniform(0.0, 1.0))
    p['no_load_coulomb'] = split * share * rated
    p['no_load_viscous'] = (1.0 - split) * share * rated / speed
    p['no_load_cold_factor'] = float(rng.uniform(1.5, 4.0))
    ambient = p['oil_ambient_temperature'] = float(rng.uniform(5.0, 30.0))
    p['oil_running_temperature'] = ambient + float(rng.uniform(25.0, 55.0))
    warm = p['oil_warm_time_constant'] = float(rng.uniform(5.0, 40.0)) * 60.0
    p['oil_cool_time_constant'] = float(rng.uniform(1.0, 2.0)) * warm
    p['load_scale_min'] = float(rng.uniform(0.2, 0.4))
    p['load_scale_max'] = 1.0
    p['load_modulation'] = float(rng.uniform(0.05, 0.2))
    p['load_modulation_frequency'] = float(rng.uniform(0.1, 0.5))
    for channel, full_scale in (('effort_motor', 2.0 * rated), ('effort_load', 2.0 * peak)):
        p[f'bias_{channel}'] = float(rng.uniform(-0.01, 0.01)) * full_scale
        p[f'gain_{channel}'] = float(rng.uniform(-0.005, 0.005))
        p[f'ripple_{channel}'] = float(rng.uniform(0.001, 0.005)) * full_scale
        p[f'quantum_{channel}'] = 2.0 * full_scale / 2.0 ** int(rng.integers(12, 17))
    teeth = float(rng.integers(15, 41))
    if p['plant'] == 'lever':
        p['mesh_teeth'] = teeth
    p['encoder_counts_motor'] = int(2 ** int(rng.integers(12, 17)))
    p['encoder_counts_load'] = int(2 ** int(rng.integers(16, 21)))
    p['publish_temperature'] = bool(rng.uniform() < 0.5)
    restart = bool(rng.uniform() < COLD_RESTART_SHARE)
    at = float(rng.uniform(0.2, 0.8)) * duration
    gap = float(round(float(rng.uniform(4.0, 12.0)) * 3600.0))
    if restart:         # at the end of a cycle: the surface retracted, at rest
        period = config_from_parameters(p).duty_cycle.period
        p['idle_gap_at'] = max(round(at / period), 1) * period
        p['idle_gap_duration'] = gap
    return {'cold_restart': restart, 'oil_temperature': p['publish_temperature'],
            'rated_input_torque': rated, 'reference_speed': speed, 'drag_share': share,
            'operating_duration': duration}


def _bench_json(bench: dict[str, Any] | None, p: dict[str, Any]) -> dict[str, Any] | None:
    """Return the bench prior's truth for life.json (None for the paper prior)."""
    if bench is None:
        return None
    speed = bench['reference_speed']
    gap = p['idle_gap_duration']
    return {'operating_duration_s': bench['operating_duration'],
            'idle_gap_s': [p['idle_gap_at'], gap] if gap else None,
            'no_load': {
                'coulomb_warm': p['no_load_coulomb'], 'viscous_warm': p['no_load_viscous'],
                'cold_factor': p['no_load_cold_factor'],
                'reference_speed': speed,
                'torque_warm_at_reference': p['no_load_coulomb'] + p['no_load_viscous'] * speed,
                'rated_input_torque': bench['rated_input_torque'],
                'share_of_rated_input': bench['drag_share']}}


def _wear_law(rng: np.random.Generator, p: dict[str, Any], family: str, wear: float,
              tau_eol: float, initial: float) -> None:
    """Set the wear law's parameters so that its wear part is ``wear`` [-] at ``tau_eol`` [s]."""
    exponent = _log_uniform(rng, 0.6, 4.0)
    if family == 'linear':
        p['wear'], p['wear_rate'] = 'linear', wear / tau_eol
    elif family == 'power':
        p['wear'], p['wear_exponent'] = 'power', exponent
        p['wear_rate'] = wear / tau_eol ** exponent
    elif family == 'exponential':
        p['wear'] = 'exponential'
        if initial <= 0.0:
            raise ValueError(f'exponential wear needs friction_initial > 0, got {initial!r}')
        p['wear_rate'] = math.log1p(wear / initial) / tau_eol
    else:
        terms = int(rng.integers(2, 4))                  # 2 or 3 of the three terms
        chosen = rng.permutation(3)[:terms]
        shares = np.zeros(3)
        shares[chosen] = rng.dirichlet(np.ones(terms))
        growth = float(rng.uniform(1.0, 5.0))            # exp_rate tau_eol
        p['wear'], p['wear_exponent'] = 'mixed', exponent
        p['wear_rate'] = float(shares[0]) * wear / tau_eol
        p['wear_exp_rate'] = growth / tau_eol
        p['wear_exp_amplitude'] = float(shares[1]) * wear / math.expm1(growth)
        p['wear_power_coefficient'] = float(shares[2]) * wear / tau_eol ** exponent


def end_of_life(config: SimulationConfig, u_eol: float, duration: float,
                rate: float) -> float | None:
    """Time [s] of the first sample k / rate < duration whose true u >= u_eol, or None.

    Searched on a 1 s grid, then at the sample times of the interval before the first grid
    crossing (the friction between grid points is at most that at the ends: linear wear path
    plus a decaying running-in). Times are elapsed times: the wear runs on the operating time
    of the config's idle gap, whose samples are not published.
    """
    path = config.wear_path()
    plant = config.plant
    count = int(math.floor(duration * rate + 1e-9))
    grid = np.arange(0.0, math.floor(duration) + 1.0)
    u = plant.efficiencies(path.value(config.operating_time(grid)))[0]
    crossed = np.flatnonzero(u >= u_eol)
    if crossed.size:          # the interval before the first grid crossing
        first, last = max(int(crossed[0]) - 1, 0), int(math.ceil(grid[crossed[0]] * rate)) + 1
    else:                     # only the samples after the last grid point are left
        first, last = len(grid) - 1, count
    index = np.arange(int(math.floor(grid[first] * rate)), min(last, count))
    if config.idle_gap.enabled:
        index = index[~config.idle_gap.idle(index / rate)]
    u = plant.efficiencies(path.value(config.operating_time(index / rate)))[0]
    hits = np.flatnonzero(u >= u_eol)
    return float(index[hits[0]] / rate) if hits.size else None
