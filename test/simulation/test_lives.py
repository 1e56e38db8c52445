"""Lives that look like real ones (issue 23).

Onset, running-in, offset and mixed laws, regime change, gamma/Wiener wear paths, the lever
plant's direction mismatch, and the random-life generator of ``gear-phm simulate
--random-life``.
"""
from __future__ import annotations

from collections import Counter
import json
from pathlib import Path

import numpy as np
import pytest

from gear_phm.bagio.series import read_vector_topic
from gear_phm.cli.main import main as gear_phm
from gear_phm.interfaces import TRUTH_EFFICIENCY, TRUTH_FRICTION
from gear_phm.models import eta_aiding, eta_opposing
from gear_phm.offline.truth import truth_eol
from gear_phm.simulation import (config_from_parameters, Plant, sample_times, simulate,
                                 SimulationConfig, Simulator, Wear)
from gear_phm.simulation.lives import EOL_TAIL, FAMILIES, FEATURES, random_life

T = np.array([0.0, 5.0, 10.0, 20.0, 40.0, 80.0])


def test_onset_base_and_running_in_follow_their_formulas() -> None:
    wear = Wear('linear', 0.05, 1e-3, onset=10.0, base=0.02, running_in=0.03,
                running_in_time=4.0)
    expected = (0.02 + 0.05 + 1e-3 * np.maximum(T - 10.0, 0.0)
                + 0.03 * np.exp(-T / 4.0))
    np.testing.assert_allclose(wear.value(T), expected, rtol=1e-15)
    offset_exp = Wear('exponential', 0.01, 0.05, base=0.04)
    np.testing.assert_allclose(offset_exp.value(T), 0.04 + 0.01 * np.exp(0.05 * T), rtol=1e-15)


def test_mixed_law_is_the_sum_of_its_terms() -> None:
    wear = Wear('mixed', 0.05, rate=2e-4, exp_amplitude=1e-3, exp_rate=0.03,
                power_coefficient=1e-6, exponent=2.5, onset=5.0)
    tau = np.maximum(T - 5.0, 0.0)
    expected = 0.05 + 2e-4 * tau + 1e-3 * np.expm1(0.03 * tau) + 1e-6 * tau ** 2.5
    np.testing.assert_allclose(wear.value(T), expected, rtol=1e-14)
    assert wear.value(3.0) == wear.value(0.0) == 0.05           # plateau before the onset


def test_regime_change_steps_the_rate_and_keeps_the_value_continuous() -> None:
    wear = Wear('linear', 0.05, 1e-3, onset=10.0, regime_time=40.0, regime_factor=3.0)
    t = np.array([0.0, 10.0, 39.0, 40.0, 41.0, 60.0])
    np.testing.assert_allclose(
        wear.value(t), [0.05, 0.05, 0.05 + 0.029, 0.08, 0.08 + 0.003, 0.08 + 0.06], rtol=1e-12)
    rates = np.diff(wear.value(np.arange(0.0, 80.0)))
    np.testing.assert_allclose(rates[12:38], 1e-3, rtol=1e-9)
    np.testing.assert_allclose(rates[42:], 3e-3, rtol=1e-9)


def test_old_kinds_unchanged_when_new_fields_are_default() -> None:
    t = np.linspace(0.0, 100.0, 7)
    for wear, expected in ((Wear('linear', 0.05, 1e-3), 0.05 + 1e-3 * t),
                           (Wear('exponential', 0.05, 0.01), 0.05 * np.exp(0.01 * t)),
                           (Wear('power', 0.05, 1e-5, exponent=3.0), 0.05 + 1e-5 * t ** 3)):
        assert np.array_equal(wear.value(t), expected)
        assert np.array_equal(wear.path(3).value(t), expected)


def stochastic(process: str, scale: float = 2e-4) -> Wear:
    return Wear('linear', 0.05, 1e-3, onset=20.0, process=process, process_scale=scale)


@pytest.mark.parametrize('process', ['gamma', 'wiener'])
def test_stochastic_path_is_the_same_for_a_seed_whatever_the_block_size(process: str) -> None:
    config = SimulationConfig(wear=stochastic(process), seed=11)
    t = sample_times(120.0, 50.0)
    whole = simulate(config, t).friction
    simulator = Simulator(config)
    blocks = np.concatenate([simulator.sample(t[i:i + 7]).friction for i in range(0, len(t), 7)])
    one_by_one = Simulator(config)
    singles = np.array([one_by_one.sample(t[i:i + 1]).friction[0] for i in range(0, 600)])
    assert np.array_equal(whole, blocks)
    assert np.array_equal(whole[:600], singles)
    backwards = config.wear.path(11).value(t[::-1])              # any order, fresh cache
    assert np.array_equal(backwards[::-1], whole)
    assert not np.array_equal(whole, simulate(SimulationConfig(wear=stochastic(process),
                                                               seed=12), t).friction)
    shared = SimulationConfig(wear=stochastic(process), seed=99, wear_seed=11)  # a fleet unit
    assert np.array_equal(simulate(shared, t).friction, whole)
    assert np.all(whole[t <= 20.0] == 0.05)                       # no noise on the plateau
    assert np.abs(whole - config.wear.value(t)).max() > 1e-4      # noise after the onset


def test_long_life_path_spans_blocks_with_bounded_memory() -> None:
    path = stochastic('gamma').path(5)
    late = path.value(np.array([29_999.5]))
    assert len(path._levels) <= 30_000 + 4096 + 1                 # one float per 1 s step
    again = stochastic('gamma').path(5)
    for start in range(0, 30_000, 7_000):                          # walked in other blocks
        again.value(np.array([float(start)]))
    assert np.array_equal(again.value(np.array([29_999.5])), late)


def test_gamma_path_is_monotone_and_wiener_is_not() -> None:
    t = np.linspace(0.0, 2000.0, 20_001)
    gamma = stochastic('gamma', 1e-3).path(1).value(t)
    wiener = stochastic('wiener', 1e-3).path(1).value(t)
    assert np.all(np.diff(gamma) >= 0.0)
    assert np.any(np.diff(wiener) < 0.0)


@pytest.mark.parametrize('process', ['gamma', 'wiener'])
def test_stochastic_mean_and_variance_follow_the_mean_law(process: str) -> None:
    wear = stochastic(process, 1e-3)
    ends = np.array([wear.path(seed).value(np.array([520.0]))[0] for seed in range(400)])
    mean_wear = 1e-3 * 500.0                                      # W(520) = rate (520 - onset)
    assert abs(ends.mean() - 0.05 - mean_wear) < 4.0 * np.sqrt(1e-3 * mean_wear / 400)
    assert ends.var() == pytest.approx(1e-3 * mean_wear, rel=0.2)   # Var X = scale W


def test_running_in_falls_then_wear_rises() -> None:
    wear = Wear('exponential', 0.01, 0.01, base=0.04, onset=100.0, running_in=0.02,
                running_in_time=15.0)
    friction = wear.value(np.arange(0.0, 400.0))
    low = int(np.argmin(friction))
    assert 60 < low < 160
    assert np.all(np.diff(friction[:low]) < 0.0) and np.all(np.diff(friction[low + 1:]) > 0.0)
    assert friction[0] == pytest.approx(0.07) and friction[low] == pytest.approx(0.05, abs=2e-4)


def test_direction_offset_gives_eta_d_and_eta_i_of_different_u() -> None:
    config = SimulationConfig(plant=Plant(ratio=50.0, direction_offset=0.025),
                              wear=Wear('constant', 0.172))
    result = simulate(config, sample_times(12.0, 100.0))
    np.testing.assert_allclose(result.eta_opposing, eta_opposing(0.172, 50.0))
    np.testing.assert_allclose(result.eta_aiding, eta_aiding(0.197, 50.0))
    assert np.all(result.u == 0.172)
    aiding = result.phase == 2
    assert aiding.sum() > 100
    torque = result.true_effort_motor - 2e-3 * result.acceleration_motor
    np.testing.assert_allclose(torque[aiding], float(eta_aiding(0.197, 50.0))
                               * result.true_effort_load[aiding] / 50.0, rtol=1e-12)
    with pytest.raises(ValueError, match='direction_offset applies to the lever plant only'):
        Plant(efficiency_model='spur', direction_offset=0.01)
    assert config_from_parameters({'direction_offset': 0.025}).plant.direction_offset == 0.025


def test_invalid_new_wear_fields_raise_naming_them() -> None:
    for kwargs, name in (({'onset': -1.0}, 'onset'), ({'running_in_time': 0.0},
                                                      'running_in_time'),
                         ({'regime_factor': 0.0}, 'regime_factor'),
                         ({'process': 'levy'}, 'process'), ({'process_step': 0.0},
                                                            'process_step')):
        with pytest.raises(ValueError, match=name):
            Wear('linear', **kwargs)
    with pytest.raises(ValueError, match='continuous wear law'):
        Wear('step', process='gamma')


def test_random_life_draws_cover_every_family_and_feature() -> None:
    families: Counter[str] = Counter()
    features: Counter[str] = Counter()
    plants: Counter[str] = Counter()
    for seed in range(200):
        life = random_life(seed)
        families[life.family] += 1
        features.update(life.features)
        plants[life.parameters['plant']] += 1
        assert 300.0 <= life.duration <= 30_000.0
        assert 0.5 <= life.eta_opposing_min < life.eta_healthy
        if life.family == 'healthy':
            assert life.end_of_life is None and life.parameters['wear'] == 'constant'
        else:
            # the record runs on past the end of life by EOL_TAIL of the wear span: room for
            # the end-of-life ERROR (seed 65's gamma path crossed 4.7 s before the end)
            tail = EOL_TAIL * (life.duration - life.onset)
            assert life.onset < life.end_of_life < life.duration - tail
    assert random_life(65).attempts == 2
    assert set(families) == set(FAMILIES) and min(families.values()) >= 20
    assert 0.12 <= families['healthy'] / 200 <= 0.25
    assert set(features) == set(FEATURES) and min(features.values()) >= 20
    assert min(plants.values()) >= 50
    assert random_life(3) == random_life(3) and random_life(3) != random_life(4)


def short_lives(wear: int, healthy: int) -> list[int]:
    """Return the first ``wear`` wear lives and ``healthy`` healthy lives of at most 2000 s.

    Seeds 0 to 99 are drawn in order until both are found: this runs at collection, in every
    pytest-xdist worker (all 100 took 1.2 s of CPU each time; seed 14 ends it today).
    """
    found: dict[bool, list[int]] = {False: [], True: []}        # healthy? -> seeds
    wanted = {False: wear, True: healthy}
    for seed in range(100):
        life = random_life(seed, 20.0)
        is_healthy = life.end_of_life is None
        if life.duration <= 2000.0 and len(found[is_healthy]) < wanted[is_healthy]:
            found[is_healthy].append(seed)
        if all(len(found[k]) == n for k, n in wanted.items()):
            break
    return found[False] + found[True]


@pytest.mark.parametrize('seed', short_lives(4, 1))
def test_random_life_bag_and_life_json(tmp_path: Path, seed: int,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'life'
    assert gear_phm(['simulate', '--out', str(out), '--random-life', str(seed),
                     '--rate', '20']) == 0
    life = json.loads((out / 'life.json').read_text(encoding='utf-8'))
    assert json.loads(capsys.readouterr().out) == life
    assert life['seed'] == seed and life['rate_hz'] == 20.0
    stamps, friction = read_vector_topic(out, TRUTH_FRICTION)
    _, efficiency = read_vector_topic(out, TRUTH_EFFICIENCY)
    assert len(stamps) == int(life['duration_s'] * 20)
    if life['healthy']:
        assert life['end_of_life_s'] is None and life['onset_s'] is None
        assert np.ptp(friction[:, 1]) == 0.0                        # constant-mean friction
        assert np.all(efficiency[:, 0] > life['eta_opposing_min'])
        return
    eol = truth_eol(out, life['u_eol'])                                # evaluate's rule
    assert eol == pytest.approx(life['end_of_life_s'], abs=1e-6)
    assert life['onset_s'] < eol < life['duration_s']
    crossing = np.flatnonzero(efficiency[:, 0] <= life['eta_opposing_min'])[0]
    assert stamps[crossing] == pytest.approx(eol, abs=0.05 + 1e-6)
    again = config_from_parameters(life['parameters'])               # parameters reproduce it
    assert again == random_life(seed, 20.0).config()


def test_random_life_refuses_other_simulation_options(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    assert gear_phm(['simulate', '--out', str(tmp_path / 'x'), '--random-life', '1',
                     '--ratio', '5', '--duration', '60']) == 2
    assert '--random-life draws every simulation parameter; drop --ratio, --duration' \
        in capsys.readouterr().err
