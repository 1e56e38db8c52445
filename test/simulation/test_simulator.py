"""Simulator: the measured power ratio in steady phases matches the models' efficiencies."""
from __future__ import annotations

import numpy as np
import pytest

from gear_phm.models import eta_aiding, eta_opposing, SpurGear, u_from_eta_opposing
from gear_phm.models.power_flow import AIDING, IDLE, OPPOSING, SELF_LOCKING
from gear_phm.simulation import Channel, Plant, Sensors, Wear
from gear_phm.simulation.simulator import sample_times, simulate, SimulationConfig, Simulator

RATE = 200.0

#: Perfect sensors: no noise, no bias on any of the four channels.
NOISELESS = Sensors(Channel(), Channel(), Channel(), Channel())


def steady_segments(result) -> list[np.ndarray]:
    """Index arrays of the constant-speed (zero acceleration, moving) runs."""
    steady = (result.acceleration_motor == 0.0) & (result.true_velocity_load != 0.0)
    edges = np.flatnonzero(np.diff(steady.astype(int)))
    bounds = np.r_[0, edges + 1, len(steady)]
    return [np.arange(a, b) for a, b in zip(bounds[:-1], bounds[1:]) if steady[a] and b - a > 10]


def segment_efficiency(result, index: np.ndarray, sensors: Sensors) -> tuple[float, float, int]:
    """(measured efficiency, its 1-sigma noise, phase) of one steady segment from energies."""
    tm, wm = result.effort_motor[index], result.velocity_motor[index]
    tl, wl = result.effort_load[index], result.velocity_load[index]
    energy_motor = np.sum(tm * wm)          # sum of P_m (dt cancels in the ratio)
    energy_load = np.sum(-tl * wl)          # sum of P_l
    var_motor = np.sum(wm ** 2 * sensors.effort_motor.sigma ** 2
                       + tm ** 2 * sensors.velocity_motor.sigma ** 2)
    var_load = np.sum(wl ** 2 * sensors.effort_load.sigma ** 2
                      + tl ** 2 * sensors.velocity_load.sigma ** 2)
    phase = int(np.bincount(result.phase[index]).argmax())
    if phase == OPPOSING:
        eta = -energy_load / energy_motor
    else:
        eta = -energy_motor / energy_load
    rel = np.sqrt(var_motor / energy_motor ** 2 + var_load / energy_load ** 2)
    return float(eta), float(abs(eta) * rel), phase


def check_power_ratio(config: SimulationConfig, duration: float, z_max: float = 5.0) -> int:
    result = simulate(config, sample_times(duration, RATE))
    checked = 0
    for index in steady_segments(result):
        eta, sigma, phase = segment_efficiency(result, index, config.sensors)
        truth = result.eta_opposing if phase == OPPOSING else result.eta_aiding
        expected = float(np.mean(truth[index]))
        assert abs(eta - expected) <= z_max * sigma + 1e-9, (phase, eta, expected, sigma)
        checked += 1
    return checked


def test_steady_power_ratio_matches_lever_efficiencies_within_noise() -> None:
    config = SimulationConfig(wear=Wear('constant', 0.12), seed=3)
    assert check_power_ratio(config, 60.0) >= 20
    u = 0.12
    result = simulate(config, sample_times(60.0, RATE))
    assert np.allclose(result.eta_opposing, eta_opposing(u, 3.0))
    assert np.allclose(result.eta_aiding, eta_aiding(u, 3.0))


def test_noiseless_power_ratio_is_exact_in_each_phase() -> None:
    config = SimulationConfig(wear=Wear('constant', 0.2), sensors=NOISELESS)
    result = simulate(config, sample_times(30.0, RATE))
    p_motor = result.effort_motor * result.velocity_motor
    p_load = -result.effort_load * result.velocity_load
    steady = (result.acceleration_motor == 0.0)
    opposing = steady & (result.phase == OPPOSING)
    aiding = steady & (result.phase == AIDING)
    assert opposing.sum() > 1000 and aiding.sum() > 1000
    np.testing.assert_allclose(-p_load[opposing] / p_motor[opposing], eta_opposing(0.2, 3.0))
    np.testing.assert_allclose(-p_motor[aiding] / p_load[aiding], eta_aiding(0.2, 3.0))
    # signs of docs/architecture.md: opposing P_m > 0 > P_l, aiding P_m < 0 < P_l
    assert np.all(p_motor[opposing] > 0) and np.all(p_load[opposing] < 0)
    assert np.all(p_motor[aiding] < 0) and np.all(p_load[aiding] > 0)
    idle = result.phase == IDLE
    assert idle.sum() > 0 and np.all(result.true_velocity_load[idle] == 0.0)


def test_wearing_plant_power_ratio_tracks_true_efficiency() -> None:
    wear = Wear.reaching('linear', 0.05, 0.4, 120.0)
    config = SimulationConfig(wear=wear, seed=11)
    assert check_power_ratio(config, 120.0) >= 40
    result = simulate(config, np.array([0.0, 60.0, 120.0]))
    np.testing.assert_allclose(result.u, [0.05, 0.225, 0.4])
    np.testing.assert_allclose(result.friction, result.u)


def test_spur_plant_truth_and_power_ratio() -> None:
    plant = Plant(efficiency_model='spur', pinion_teeth=20, bearing_radius_1=2e-4)
    config = SimulationConfig(plant=plant, wear=Wear('linear', 0.1, 0.02), seed=5)
    assert check_power_ratio(config, 60.0) >= 20
    result = simulate(config, sample_times(60.0, 10.0))
    eta_d, eta_i = SpurGear(20, 60, friction=result.friction,
                            bearing_radius_1=2e-4).efficiencies()
    np.testing.assert_allclose(result.eta_opposing, eta_d)
    np.testing.assert_allclose(result.eta_aiding, eta_i)
    np.testing.assert_allclose(result.u, u_from_eta_opposing(eta_d, 3.0))
    np.testing.assert_allclose(result.friction, 0.1 + 0.02 * result.t)


def test_self_locking_motor_pushes_back() -> None:
    config = SimulationConfig(wear=Wear('constant', 1.4), sensors=NOISELESS)
    result = simulate(config, sample_times(12.0, RATE))
    locking = result.phase == SELF_LOCKING
    assert locking.sum() > 100
    p_motor = result.effort_motor * result.velocity_motor
    p_load = -result.effort_load * result.velocity_load
    steady = locking & (result.acceleration_motor == 0.0)
    assert np.all(p_motor[steady] > 0) and np.all(p_load[steady] > 0)
    np.testing.assert_allclose(-p_motor[steady] / p_load[steady], eta_aiding(1.4, 3.0))


def test_jammed_gearbox_is_reported() -> None:
    config = SimulationConfig(wear=Wear('linear', 0.05, 1.0))
    with pytest.raises(ValueError, match='jams'):
        simulate(config, sample_times(10.0, RATE))


def test_kinematics_and_positions() -> None:
    config = SimulationConfig(sensors=NOISELESS)
    duty = config.duty_cycle
    t = sample_times(3 * duty.period, 1000.0)
    result = simulate(config, t)
    np.testing.assert_allclose(result.true_velocity_motor, 3.0 * result.true_velocity_load)
    np.testing.assert_allclose(result.position_motor, 3.0 * result.position_load)
    # position is the integral of velocity (trapezoid rule error O(dt^2))
    integral = np.concatenate(([0.0], np.cumsum(0.5 * (result.true_velocity_load[1:]
                                                       + result.true_velocity_load[:-1])
                                                / 1000.0)))
    np.testing.assert_allclose(result.position_load, integral, atol=1e-6)
    assert result.position_load.max() == pytest.approx(duty.travel)
    assert result.position_load.min() == pytest.approx(0.0, abs=1e-12)
    assert result.true_velocity_load.max() == pytest.approx(duty.extend_speed)
    assert result.true_velocity_load.min() == pytest.approx(-duty.retract_speed)
    # every steady stroke lasts stroke time - 2 ramps, at least 1 s at the defaults
    lengths = [len(i) / 1000.0 for i in steady_segments(result)]
    assert min(lengths) >= 1.0
    # same values in any order
    shuffled = np.random.default_rng(0).permutation(t)
    again = simulate(config, shuffled)
    order = np.argsort(shuffled)
    np.testing.assert_array_equal(again.effort_motor[order], result.effort_motor)


def test_noise_statistics_match_sensor_config() -> None:
    sensors = Sensors(Channel(0.02, 0.1), Channel(0.01, -0.05), Channel(0.3, 0.0),
                      Channel(0.5, 1.0))
    config = SimulationConfig(sensors=sensors, seed=7)
    result = simulate(config, sample_times(100.0, RATE))
    for name, channel in (('velocity_motor', sensors.velocity_motor),
                          ('velocity_load', sensors.velocity_load),
                          ('effort_motor', sensors.effort_motor),
                          ('effort_load', sensors.effort_load)):
        error = getattr(result, name) - getattr(result, 'true_' + name)
        n = len(error)
        assert abs(error.mean() - channel.bias) < 5 * channel.sigma / np.sqrt(n), name
        assert error.std() == pytest.approx(channel.sigma, rel=0.02), name


def test_seeded_and_chunk_invariant() -> None:
    config = SimulationConfig(wear=Wear('exponential', 0.05, 0.01), seed=42)
    t = sample_times(20.0, RATE)
    first, second = simulate(config, t), simulate(config, t)
    np.testing.assert_array_equal(first.effort_load, second.effort_load)
    other = simulate(SimulationConfig(wear=config.wear, seed=43), t)
    assert not np.array_equal(first.effort_load, other.effort_load)
    simulator = Simulator(config)
    parts = [simulator.sample(chunk) for chunk in np.array_split(t, [7, 500, 1999])]
    for name in ('velocity_motor', 'velocity_load', 'effort_motor', 'effort_load'):
        joined = np.concatenate([getattr(p, name) for p in parts])
        np.testing.assert_array_equal(joined, getattr(first, name))


def test_other_invalid_inputs() -> None:
    with pytest.raises(ValueError, match='efficiency_model'):
        Plant(efficiency_model='hypoid')
    with pytest.raises(ValueError, match='kind'):
        Wear('quadratic')
    with pytest.raises(ValueError, match='seed'):
        SimulationConfig(seed=-1)
    with pytest.raises(ValueError, match='sigma'):
        Channel(-0.1)
    with pytest.raises(ValueError, match='z1'):
        Plant(efficiency_model='spur', pinion_teeth=5)
    with pytest.raises(ValueError, match='rate must be > 0'):
        sample_times(1.0, 0.0)
    with pytest.raises(ValueError, match='t must be finite'):
        simulate(SimulationConfig(), [0.0, np.nan])


@pytest.mark.parametrize('plant', ['lever', 'spur'])
def test_block_run_equals_sample_by_sample(plant: str) -> None:
    """One block call equals per-sample calls of a fresh simulator, to 1e-12.

    The same noise draws in the same order (4 normals per sample, row by row), the same truth.
    """
    config = SimulationConfig(plant=Plant(efficiency_model=plant), seed=7,
                              wear=Wear('exponential', 0.05 if plant == 'lever' else 0.08,
                                        0.01))
    t = sample_times(4.0, RATE) + 1.3
    block = Simulator(config).sample(t)
    single = Simulator(config)
    rows = [single.sample(t[i]) for i in range(len(t))]
    for name in block.__dataclass_fields__:
        expected = np.concatenate([getattr(r, name) for r in rows])
        np.testing.assert_allclose(getattr(block, name), expected, rtol=1e-12, atol=1e-12,
                                   err_msg=name)
    assert np.ptp(block.effort_load) > 10.0 and np.ptp(block.phase) > 0   # moving, phases
