"""Consistency of the adaptive estimator (issue 12): NIS and NEES, the mismatch variance.

Lever-model plant (helpers/plant.py, wearing with its operating time, the filter's
time axis), defaults only. Lives of 300 s, 3000 s and
30 000 s (u 0.05 -> 0.30) are compressed into 300 s runs: the 300 s life is run whole, the
longer ones from mid-life at their own wear rate. Bounds are two-sided 95 % chi-square bounds:
NIS pooled over all updates after 60 s of the seeds (K updates, chi2(K)/K); NEES of the final
posterior of each seed (M independent runs, chi2(2M)/M; NEES along one run is autocorrelated).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gear_phm.estimation import EstimatorConfig, EstimatorPipeline
from gear_phm.models import SpurGear
from gear_phm.models.lever import u_from_eta_aiding, u_from_eta_opposing
from gear_phm.models.power_flow import OPPOSING
from helpers.plant import lever_plant

NOISE = {'motor_torque_noise': 0.05, 'motor_speed_noise': 0.01, 'load_torque_noise': 0.05,
         'load_speed_noise': 0.01}
CONFIG = EstimatorConfig(ratio=3.0, motor_inertia=0.01, **NOISE)
SEEDS = range(6)


def _wear(law: str, life: float, start: float):
    """u(t) and du/dt(t) over a run that starts at ``start`` [s] into a life of ``life`` [s]."""
    if law == 'linear':
        rate = 0.25 / life
        return (lambda t: 0.05 + rate * (t + start)), (lambda t: np.full(np.shape(t), rate))
    k = math.log(6.0) / life
    return ((lambda t: 0.05 * np.exp(k * (t + start))),
            (lambda t: 0.05 * k * np.exp(k * (t + start))))


def _run(run, config: EstimatorConfig = CONFIG) -> tuple[EstimatorPipeline, np.ndarray]:
    """Pipeline after the run, and per window: t [s], direction, NIS, accepted, x, P."""
    pipeline = EstimatorPipeline(config)
    rows: list[tuple] = []
    pipeline.on_measurement = lambda m, ok: rows.append(
        (m.t, 0 if m.code == OPPOSING else 1, pipeline.filter.last.nis, ok,
         *pipeline.filter.x, *pipeline.filter.P.ravel()))
    pipeline.on_batch(run.stamp_ns, run.motor_velocity, run.motor_effort, run.load_velocity,
                      run.load_effort)
    return pipeline, np.array(rows, dtype=float)


def _bounds(k: int, dof: int = 1) -> tuple[float, float]:
    from scipy.stats import chi2         # here, not at collection: 0.7 s of CPU per worker
    low, high = chi2.ppf([0.025, 0.975], dof * k) / k
    return float(low), float(high)


@pytest.mark.parametrize('law', ['linear', 'exponential'])
@pytest.mark.parametrize('rate', [100.0, 1000.0])
def test_nis_and_nees_consistent_at_every_life_and_rate(law: str, rate: float) -> None:
    """Pooled NIS and final NEES inside their 95 % bounds for each life.

    Measured (6 seeds): NIS 0.93-1.01 and final NEES 0.91-2.3 (2 dof), bounds ~[0.91, 1.10]
    and [0.73, 3.89]; before windows were fused at their mid-time (H = [1, -T/2]) the 300 s
    life at 1 kHz had NEES 9.9 (the estimate lagged by half a window). Linear 300 s at 1 kHz
    is conservative (final NEES 0.65): the wear-law floor on q expects acceleration
    (docs/estimation.md), so there only NEES <= the upper bound and >= 0.5 is asserted.
    """
    for life in (300.0, 3000.0, 30000.0):
        start = 0.0 if life <= 300.0 else 0.5 * life
        u, du = _wear(law, life, start)
        nis, nees = [], []
        for seed in SEEDS:
            run = lever_plant(seed, 300.0, u, rate=rate, wear_clock='operating')
            _, rows = _run(run)
            rows = rows[rows[:, 3] > 0]
            t = rows[:, 0]
            nis.append(rows[t > 60.0, 2])
            s = float(np.interp(t[-1], run.t, run.operating_time))  # the filter's time [s]
            err = rows[-1, 4:6] - np.array([u(s), du(s)])
            nees.append(float(err @ np.linalg.solve(rows[-1, 6:].reshape(2, 2), err)))
        pooled = np.concatenate(nis)
        low, high = _bounds(pooled.size)
        assert low <= pooled.mean() <= high, (life, pooled.mean(), low, high)
        low, high = _bounds(len(nees), 2)
        conservative = law == 'linear' and rate == 1000.0 and life == 300.0
        assert (0.5 if conservative else low) <= np.mean(nees) <= high, (life, nees)


@pytest.mark.parametrize('rate', [100.0, 1000.0])
def test_no_mismatch_is_learned_on_a_lever_plant(rate: float) -> None:
    """Constant u on the lever model: no mismatch, NIS of each direction in its bounds.

    Before the fix the opposing sigma came out 0.045-0.052 (= the prior's error 0.05 at the
    first update, kept by the matching) and the opposing NIS was 0.001.
    """
    for seed in (0, 1):
        pipeline, rows = _run(lever_plant(seed, 300.0, 0.1, rate=rate))
        summary = pipeline.summary()
        assert summary['mismatch_sigma_opposing'] < 1e-3
        assert summary['mismatch_sigma_aiding'] < 1e-3
        assert abs(summary['direction_offset']) < 1e-3
        late = rows[(rows[:, 0] > 60.0) & (rows[:, 3] > 0)]
        for direction in (0, 1):
            nis = late[late[:, 1] == direction, 2]
            low, high = _bounds(nis.size)
            # per direction and seed: about 90 updates, so 95 % bounds [0.73, 1.30]
            assert low <= nis.mean() <= high, (seed, direction, nis.mean())


def _spur_run(rate: float, seed: int):
    gear = SpurGear(20, 60, friction=0.08, bearing_radius_1=1e-3, bearing_radius_2=3e-3)
    eta_d, eta_i = gear.efficiencies()
    run = lever_plant(seed, 300.0, 0.0, rate=rate, eta_pair=(
        lambda t: np.full(t.shape, eta_d), lambda t: np.full(t.shape, eta_i)))
    gap = float(u_from_eta_opposing(eta_d, 3.0) - u_from_eta_aiding(eta_i, 3.0))
    return run, gap


@pytest.mark.parametrize('rate', [100.0, 1000.0])
def test_direction_offset_of_a_spur_gear_plant_is_measured(rate: float) -> None:
    """Spur stage with bearing friction: the direction offset is a learned state.

    Its opposing windows read u = 0.180, its aiding ones 0.161 (a 12-sigma disagreement per
    1 kHz window). The offset d = aiding minus opposing reading is learned (-0.01859..-0.01887
    of -0.01884, sigma 0.00008-0.00016), each direction's bias is -/+ d/2, u is the midpoint
    (0.1706-0.1709), and the variance learned on top is small (sigma <= 0.00035): the offset
    is not counted twice. Without adaptation (no offset state) the filter re-initialises
    about every third window (49-53 times in 300 s; adaptive: 0). (Before the offset was a
    state: offset 0.0175-0.0187 with the other sign, u 0.1688-0.1709, re-initialisations 0-4.)
    """
    for seed in (0, 1):
        run, gap = _spur_run(rate, seed)
        pipeline, _ = _run(run)
        summary = pipeline.summary()
        offset = summary['direction_offset']
        assert abs(-offset / gap - 1.0) < 0.03, offset
        assert summary['direction_offset_sigma'] < 0.02 * gap
        assert pipeline.filter.direction_bias(0) == -0.5 * offset
        assert pipeline.filter.direction_bias(1) == 0.5 * offset
        assert pipeline.filter.x[0] == pytest.approx(0.1705, abs=0.001)
        for name in ('mismatch_sigma_opposing', 'mismatch_sigma_aiding'):
            assert summary[name] < 0.05 * gap, summary
        fixed, _ = _run(run, CONFIG.replace(adaptive=False))
        assert fixed.counts['reinitialised'] > 5 * max(pipeline.counts['reinitialised'], 1)


@pytest.mark.parametrize('rate', [100.0, 1000.0])
def test_nis_in_bounds_once_the_spur_gear_mismatch_is_learned(rate: float) -> None:
    """After 150 s of a 300 s run the pooled NIS of 3 seeds is inside its 95 % bounds.

    Measured: per seed 0.68-1.04 (100 Hz), 0.88-1.01 (1 kHz). Before the direction bias was
    taken off the measurements, 1.45-1.75 and 1.6-3.4: the windows of one direction had
    innovations of one sign, the whiteness test raised q to ~3e-6 and the filter chased each
    direction.
    """
    nis = []
    for seed in range(3):
        run, _ = _spur_run(rate, seed)
        _, rows = _run(run)
        nis.append(rows[(rows[:, 0] > 150.0) & (rows[:, 3] > 0), 2])
    pooled = np.concatenate(nis)
    low, high = _bounds(pooled.size)
    assert low <= pooled.mean() <= high, pooled.mean()
