"""The random-life priors of gear_phm.simulation.lives: paper unchanged, bench with the effects."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gear_phm.simulation.lives import BENCH_FEATURES, random_life
from gear_phm.simulation.parameters import BASE_PARAMETERS

SEEDS = range(200)


@pytest.fixture(scope='module')
def bench() -> list[dict[str, object]]:
    return [random_life(seed, 100.0, 'bench').to_json() for seed in SEEDS]


@pytest.mark.parametrize('seed, family, plant, ratio, duration, eol, friction', [
    (0, 'linear', 'lever', 3.717821252117981, 953.0, 859.73, 0.12751444917610497),
    (3, 'mixed', 'spur', 85.94601850064495, 15162.0, 14031.13, 0.0152453292137959),
    (7, 'power', 'lever', 18.164080574761574, 9651.0, 8630.95, 0.014010923392613867),
    (42, 'mixed', 'spur', 47.31139662003777, 326.0, 266.87, 0.07387418459292937),
])
def test_the_paper_prior_draws_today_s_lives(seed: int, family: str, plant: str, ratio: float,
                                             duration: float, eol: float,
                                             friction: float) -> None:
    """The values the paper prior drew before the bench prior existed, exactly."""
    life = random_life(seed, 100.0)
    assert life == random_life(seed, 100.0, 'paper')
    record = life.to_json()
    assert (record['family'], record['plant'], record['ratio'], record['duration_s'],
            record['end_of_life_s'], record['parameters']['friction_initial']) == (
        family, plant, ratio, duration, eol, friction)
    assert set(record['parameters']) == {spec.name for spec in BASE_PARAMETERS}
    assert 'prior' not in record and 'no_load' not in record


def test_the_bench_prior_keeps_the_paper_draws(bench: list[dict[str, object]]) -> None:
    for seed in (0, 3, 7, 42):
        paper = random_life(seed, 100.0).to_json()
        record = bench[seed]
        for key in ('family', 'plant', 'ratio', 'eta_healthy', 'eta_opposing_min', 'u_eol'):
            assert record[key] == paper[key], (seed, key)
        params = record['parameters']
        assert isinstance(params, dict)
        for name in ('travel', 'air_load_preload', 'noise_effort_load', 'friction_initial'):
            assert params[name] == paper['parameters'][name]
        assert record['operating_duration_s'] == paper['duration_s']


def test_the_bench_prior_is_deterministic() -> None:
    assert random_life(11, 100.0, 'bench').to_json() == random_life(11, 100.0, 'bench').to_json()
    assert random_life(11, 100.0, 'bench').to_json() != random_life(12, 100.0, 'bench').to_json()


def test_the_bench_prior_s_ranges(bench: list[dict[str, object]]) -> None:
    shares, splits, restarts = [], [], 0
    for record in bench:
        p = record['parameters']
        no_load = record['no_load']
        assert isinstance(p, dict) and isinstance(no_load, dict)
        ratio = p['ratio']
        peak = p['air_load_preload'] + p['air_load_stiffness'] * p['travel']
        speed = ratio * p['travel'] / (p['extend_time'] - p['accel_time'])
        warm_drag = p['no_load_coulomb'] + p['no_load_viscous'] * speed
        share = warm_drag / (peak / ratio)
        assert 0.005 <= share <= 0.05 and share == pytest.approx(
            no_load['share_of_rated_input'])
        assert warm_drag == pytest.approx(no_load['torque_warm_at_reference'])
        shares.append(share)
        splits.append(p['no_load_coulomb'] / warm_drag)
        assert 1.5 <= p['no_load_cold_factor'] <= 4.0
        assert 300.0 <= p['oil_warm_time_constant'] <= 2400.0
        assert p['oil_running_temperature'] > p['oil_ambient_temperature']
        assert 0.2 <= p['load_scale_min'] <= 0.4 and p['load_scale_max'] == 1.0
        assert 0.0 < p['load_modulation'] <= 0.2
        for channel, full_scale in (('effort_motor', 2 * peak / ratio),
                                    ('effort_load', 2 * peak)):
            assert abs(p[f'bias_{channel}']) <= 0.01 * full_scale
            assert abs(p[f'gain_{channel}']) <= 0.005
            assert 0.0 < p[f'ripple_{channel}'] <= 0.005 * full_scale
            assert 2 * full_scale / 2**16 <= p[f'quantum_{channel}'] <= 2 * full_scale / 2**12
        assert 4096 <= p['encoder_counts_motor'] <= 65536
        assert 65536 <= p['encoder_counts_load'] <= 2**20
        gap = record['idle_gap_s']
        assert ('cold_restart' in record['features']) == (gap is not None)
        if gap is not None:
            restarts += 1
            at, length = gap
            assert 4 * 3600 <= length <= 12 * 3600
            assert record['duration_s'] == record['operating_duration_s'] + length
            assert 0.0 < at < record['operating_duration_s']
            # the oil is back near ambient: within 10 % of the warm-up span
            cooled = math.exp(-length / p['oil_cool_time_constant'])
            assert cooled < 0.1
            if record['end_of_life_s'] is not None:
                assert not at <= record['end_of_life_s'] < at + length
    assert 0.2 <= restarts / len(bench) <= 0.4                 # about 30 %
    assert np.mean(shares) == pytest.approx(0.0275, abs=0.004)
    assert min(splits) < 0.1 and max(splits) > 0.9             # Coulomb and viscous both
    assert {f for r in bench for f in r['features']} >= set(BENCH_FEATURES)


def test_a_bad_prior_is_refused() -> None:
    with pytest.raises(ValueError, match='prior must be one of paper, bench'):
        random_life(1, 100.0, 'lab')
