"""The health assessor (gear_phm.prognostics.assessor): levels, status keys, operating time.

Also alpha-lambda on simulated wear through the real Kalman filter.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gear_phm import interfaces
from gear_phm.estimation import FrictionEstimate
from gear_phm.estimation.kalman import FrictionFilter
from gear_phm.prognostics import HealthConfig, HealthState
from gear_phm.prognostics.assessor import HealthAssessor
from gear_phm.prognostics.metrics import evaluate
from gear_phm.simulation.wear import Wear
from gear_phm.status import ERROR, OK, WARN


def test_monitor_reports_levels_along_linear_wear() -> None:
    monitor = HealthAssessor(HealthConfig(warn_horizon=600.0, eta_warn=0.6, level_dwell=0.0))
    levels = []
    for t in np.arange(0.0, 4000.0, 10.0):
        u = 0.05 + 1.5e-4 * t
        estimate = FrictionEstimate(int(t * 1e9), u, 1.5e-4, (1e-6, 0.0, 1e-12))
        levels.append(monitor.on_estimate(estimate).level)
    first = {level: levels.index(level) for level in (OK, WARN, ERROR)}
    assert first[OK] < first[WARN] < first[ERROR]
    # eta_D < 0.6 at u > 0.4286 (t > 2524 s); RUL p5 < 600 s at t > 3067 s; EOL at 3667 s
    assert first[WARN] * 10.0 == pytest.approx(2530.0, abs=10.0)
    assert first[ERROR] * 10.0 == pytest.approx(3670.0, abs=10.0)
    assert monitor.on_estimate(FrictionEstimate(0, math.nan, 0.0, (1.0, 0.0, 1.0))) is None
    assert monitor.rejected == {'non_finite_estimate': 1}


def test_status_key_values_exact_keys_and_inf() -> None:
    monitor = HealthAssessor(HealthConfig())
    status = monitor.on_estimate(FrictionEstimate(5_000_000_000, 0.1, 0.0, (1e-4, 0.0, 1e-10),
                                                  samples_used=7, samples_rejected=2,
                                                  power_flow=1))
    values = dict(interfaces.health_key_values(status))
    assert list(values) == ['u', 'u_sigma', 'eta_opposing', 'eta_aiding', 'rul_s', 'rul_p5_s',
                            'rul_p95_s', 'power_flow', 'samples_used', 'samples_rejected',
                            'samples_missing', 'operating_time_s', 'rul_operating_s',
                            'rul_operating_p5_s', 'rul_operating_p95_s', 'utilisation',
                            'eta_healthy', 'eta_warn']
    assert values['rul_s'] == 'inf' and values['samples_used'] == '7'
    # settled (sigma_u 0.01 <= 0.1 (u_eol 0.6 - u 0.1)): the healthy eta_D is this one's
    eta_healthy = (3.0 - 0.1) / (3.0 * 1.1)
    assert float(values['eta_healthy']) == pytest.approx(eta_healthy)
    assert float(values['eta_warn']) == pytest.approx(0.5 + 0.25 * (eta_healthy - 0.5))
    assert values['rul_operating_s'] == 'inf' and values['operating_time_s'] == 'nan'
    assert values['utilisation'] == '1.0'
    assert float(values['u_sigma']) == pytest.approx(0.01)
    assert float(values['eta_opposing']) == pytest.approx((3.0 - 0.1) / (3.0 * 1.1))
    diagnostic = interfaces.health_status(status, 'left_aileron', 'hw1')
    rul, efficiency = interfaces.health_outputs(status)
    assert diagnostic.name == 'gear_phm: left_aileron' and diagnostic.hardware_id == 'hw1'
    assert rul.stamp_ns == efficiency.stamp_ns == 5_000_000_000 and efficiency.z == float(OK)


def _linear_wear(utilisation: float, gap: float = 0.0) -> HealthAssessor:
    """Assessor after linear wear u = 0.05 + 1.5e-4 s (s: operating time [s]).

    Estimated every 10 s of operation, each step taking 10 / ``utilisation`` s of stamp time,
    and a stamp gap of ``gap`` [s] without operation halfway; WARN below 3000 s of RUL.
    """
    monitor = HealthAssessor(HealthConfig(warn_horizon=3000.0, eta_warn=0.6, level_dwell=0.0))
    for k, s in enumerate(np.arange(0.0, 2000.0, 10.0)):
        t = s / utilisation + (gap if k >= 100 else 0.0)
        u = 0.05 + 1.5e-4 * s
        assert monitor.on_estimate(FrictionEstimate(int(t * 1e9), u, 1.5e-4, (1e-6, 0.0, 1e-12),
                                                    operating_time=s)) is not None
    return monitor


def test_rul_runs_on_operating_time_and_converts_by_the_utilisation() -> None:
    """Issue 13: the fit runs on operating time, so rul_operating is the same whatever the stamps.

    rul (elapsed time) = rul_operating / utilisation, here 0.25. A week-long idle gap lowers
    the utilisation to operating / elapsed over the whole history; the elapsed RUL takes the
    duty of the newest RUL's worth of operation, which holds the week.
    """
    full, quarter = _linear_wear(1.0).latest, _linear_wear(0.25).latest
    assert full is not None and quarter is not None
    # u_eol 0.6 (eta_opposing_min 0.5, R 3) at s = 3666.7 s; the newest estimate is at 1990 s
    for state in (full, quarter):
        assert state.rul_operating.median == pytest.approx(3666.7 - 1990.0, rel=0.01)
        assert state.operating_time == 1990.0
    assert quarter.rul_operating == full.rul_operating
    assert full.utilisation == pytest.approx(1.0)
    assert full.rul.median == pytest.approx(full.rul_operating.median, rel=1e-12)
    assert quarter.utilisation == pytest.approx(0.25)
    for name in ('median', 'p95'):                # the recent duty: 0.25 to its first update
        assert getattr(quarter.rul, name) == pytest.approx(
            getattr(quarter.rul_operating, name) / 0.25, rel=5e-3)
    # the lower bound: the gearbox could run without a pause from now on
    assert quarter.rul.p5 == quarter.rul_operating.p5
    values = dict(interfaces.health_key_values(quarter))
    assert float(values['rul_s']) == pytest.approx(4.0 * float(values['rul_operating_s']),
                                                   rel=5e-3)
    assert float(values['operating_time_s']) == 1990.0
    # a week idle halfway: the same operating RUL, utilisation 1990 / (1990 + 604800)
    week = _linear_wear(1.0, gap=7 * 86400.0)
    gapped = week.latest
    assert gapped is not None and gapped.rul_operating == full.rul_operating
    assert gapped.utilisation == pytest.approx(1990.0 / (1990.0 + 7 * 86400.0))
    # the newest ~1680 s of operation (the median RUL) reach back over the week
    assert gapped.rul.median == pytest.approx(full.rul.median + 7 * 86400.0, rel=1e-6)
    # the level's horizon is on the operating RUL: median ~1680 s < 3000 s < ~6600 s elapsed
    assert quarter.rul.median > 3000.0 > quarter.rul_operating.median
    assert quarter.level == WARN and quarter.message.startswith('RUL 16')
    restored = HealthAssessor(week.config)
    restored.from_state(week.to_state())
    assert restored.utilisation.fraction == gapped.utilisation
    assert restored.latest == gapped
    # an update without operating time in a stream that has it (the first one a restarted
    # diagnostics node assembles) keeps the operating time: the history is not disturbed
    stamp_ns = gapped.stamp_ns + 10**9
    bare = restored.on_estimate(FrictionEstimate(stamp_ns, 0.05 + 1.5e-4 * 1990.0, 1.5e-4,
                                                 (1e-6, 0.0, 1e-12)))
    assert bare is not None and bare.operating_time == 1990.0
    assert bare.rul_operating.median == pytest.approx(gapped.rul_operating.median, rel=1e-3)


def test_updates_without_operating_time_at_the_start_join_the_operating_history() -> None:
    """Updates without operating time at the start join the history once it arrives.

    The first updates of a stream may come without it (its topic matched late): the history
    moves onto the operating axis, as if in motion throughout, instead of restarting; with
    continuous motion the RUL is exactly that of the whole stream (dropping the first three
    points moves it by 0.9 % here, by 4 % in test_state_file).
    """
    def run(missing: int) -> HealthState:
        monitor = HealthAssessor(HealthConfig())
        for k, s in enumerate(np.arange(0.0, 400.0, 2.0)):
            t = 1.7e9 + s                                         # continuous motion
            u = 0.05 + 0.3 * (s / 400.0) ** 2
            state = monitor.on_estimate(FrictionEstimate(
                int(t * 1e9), u, 1.5e-3 * s / 400.0, (1e-6, 0.0, 1e-12),
                operating_time=math.nan if k < missing else s))
        assert state is not None
        return state
    full, late = run(0), run(3)
    assert math.isfinite(full.rul_operating.median)
    assert late.rul_operating.median == pytest.approx(full.rul_operating.median, rel=1e-6)
    assert late.utilisation == pytest.approx(1.0, rel=1e-9)


# --- acceptance: alpha-lambda on simulated wear through the real filter ----------------------
def _run(kind: str, seed: int) -> dict:
    """Noisy 1-s pseudo-measurements of u (sigma 0.01) of wear reaching u_eol at 3600 s.

    Filtered by the estimator's FrictionFilter, scored from t_start = 60 s.
    """
    monitor = HealthAssessor(HealthConfig(mc_samples=500))
    wear = Wear.reaching(kind, 0.05, monitor.u_eol, 3600.0, exponent=3.0)
    kf = FrictionFilter(0.05, 0.5, 1e-3, 1e-12, 10.83, 3)
    rng = np.random.default_rng(seed)
    times, ruls, bands = [], [], []
    for t in np.arange(0.0, 3600.0, 2.0):
        result = kf.update(float(wear.value(t) + 0.01 * rng.standard_normal()), 1e-4,
                           float(t))
        x, p = kf.x, kf.P
        estimate = FrictionEstimate(int(t * 1e9), x[0], x[1], (p[0, 0], p[0, 1], p[1, 1]),
                                    innovation=result.innovation,
                                    innovation_variance=result.innovation_variance,
                                    nis=result.nis)
        status = monitor.on_estimate(estimate)
        times.append(t)
        ruls.append(status.rul.median)
        bands.append((status.rul.p5, status.rul.p95))
    result = evaluate(times, ruls, 3600.0, t_start=60.0)
    for check in result['alpha_lambda']:
        check['band'] = bands[int(np.searchsorted(times, check['t_lambda'], 'right')) - 1]
    return result


@pytest.mark.parametrize('kind', ['linear', 'exponential', 'power'])
@pytest.mark.parametrize('seed', [0, 1, 2])
def test_alpha_lambda_passes_at_three_quarter_life_and_the_band_holds(kind: str,
                                                                      seed: int) -> None:
    """Whole-history fit, no tuning.

    At half life exponential and power-law (p = 3) wear are not always told apart through this
    slow filter (process_noise 1e-12): the median can be off by more than alpha, but the p5-p95
    band holds the true RUL. (At 3/4 of life the band is a few % wide and the filter's lag, which
    P does not carry, can put the truth outside.)
    """
    result = _run(kind, seed)
    checks = {check['lam']: check for check in result['alpha_lambda']}
    assert checks[0.75]['passed'], checks[0.75]
    p5, p95 = checks[0.5]['band']
    assert p5 <= checks[0.5]['true_rul'] <= p95, checks[0.5]
    if kind == 'linear':
        assert checks[0.5]['passed'], checks[0.5]
    assert result['prognostic_horizon_s'] > 1000.0


def test_end_of_life_on_the_opposing_reading_when_the_directions_disagree() -> None:
    """eta_opposing_min is about the opposing windows' reading, u + its direction bias.

    The estimator reports u as the midpoint of the two directions' readings and each
    efficiency at its own reading (FrictionFilter.direction_bias): here the opposing windows
    read u + 0.01, the aiding ones u - 0.01. End of life (u_eol 0.6) comes when u + 0.01
    reaches it, and the ratio check still sees the same ratio on both sides.
    """
    from gear_phm.models.lever import efficiencies
    monitor = HealthAssessor(HealthConfig(level_dwell=0.0, eta_warn=0.6))
    first_error = None
    for t in np.arange(0.0, 600.0, 1.0):
        u = 0.05 + 1e-3 * t
        eta_d = efficiencies(u + 0.01, 3.0)[0]
        eta_i = efficiencies(u - 0.01, 3.0)[1]
        state = monitor.on_estimate(FrictionEstimate(int(t * 1e9), u, 1e-3, (1e-8, 0.0, 1e-12),
                                                     eta_d, eta_i))
        assert state is not None and 'ratio mismatch' not in state.message
        if state.level == ERROR and first_error is None:
            first_error = t
            assert state.message.startswith('end of life (eta_opposing_min)')
    # u + 0.01 - 1.645e-4 >= 0.6 at t = 540.2 s; u alone would reach it at 550.2 s
    assert first_error == pytest.approx(541.0, abs=1.0)


def test_utilisation_is_measured_from_the_first_update_with_operating_time() -> None:
    """A first update without operating time does not count as motion.

    Its operating time is lost to a callback race, or it comes from an older estimator: the
    utilisation of a gearbox moving half the time is 0.5.

    Measured in the suite (integration/test_diagnostics_node.py, live node): 0.5013 while the first
    interval was taken as motion throughout.
    """
    monitor = HealthAssessor(HealthConfig())
    for k, t in enumerate(np.arange(0.0, 4000.0, 10.0)):
        u = 0.05 + 1.5e-4 * t
        operating = 0.5 * t if k else math.nan
        state = monitor.on_estimate(FrictionEstimate(int(t * 1e9), u, 1.5e-4,
                                                     (1e-6, 0.0, 1e-12),
                                                     operating_time=operating))
        assert state is not None
    assert state.utilisation == pytest.approx(0.5, abs=1e-12)
    assert state.operating_time == 0.5 * 3990.0
