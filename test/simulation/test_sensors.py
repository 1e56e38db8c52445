"""Sensor imperfections (gear_phm.simulation.sensors): offset, gain, ripple, steps, encoders."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gear_phm.simulation import Channel, SimulationConfig, SimulationResult, Simulator
from gear_phm.simulation.parameters import config_from_parameters
from gear_phm.simulation.sensors import differenced, encoder_reading, Sensors

T = np.arange(0.0, 30.0, 0.001)


def _quiet(**kwargs: object) -> dict[str, object]:
    values: dict[str, object] = {f'noise_{c}': 0.0 for c in (
        'velocity_motor', 'velocity_load', 'effort_motor', 'effort_load')}
    values.update(kwargs)
    return values


def _run(**kwargs: object) -> tuple[SimulationConfig, SimulationResult]:
    config = config_from_parameters(_quiet(**kwargs))
    return config, Simulator(config).sample(T)


def test_offset_and_gain_errors() -> None:
    _, r = _run(bias_effort_load=0.4, gain_effort_load=0.005, bias_effort_motor=-0.01,
                gain_effort_motor=-0.004)
    np.testing.assert_allclose(r.effort_load, 1.005 * r.true_effort_load + 0.4,
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.effort_motor, 0.996 * r.true_effort_motor - 0.01,
                               rtol=0, atol=1e-12)


def test_quantisation_rounds_to_the_step() -> None:
    _, r = _run(quantum_effort_load=0.05, quantum_effort_motor=0.002)
    for measured, true, step in ((r.effort_load, r.true_effort_load, 0.05),
                                 (r.effort_motor, r.true_effort_motor, 0.002)):
        np.testing.assert_allclose(measured / step, np.round(measured / step), atol=1e-9)
        assert np.abs(measured - true).max() <= step / 2 + 1e-12
        assert np.abs(measured - true).max() > step / 4          # it did round


def test_mesh_ripple_at_teeth_times_shaft_speed() -> None:
    _, r = _run(ripple_effort_load=0.3, ripple_effort_motor=0.01, mesh_teeth=17.0)
    angle = 17.0 * r.position_motor
    np.testing.assert_allclose(r.effort_load - r.true_effort_load, 0.3 * np.sin(angle),
                               atol=1e-12)
    np.testing.assert_allclose(r.effort_motor - r.true_effort_motor, 0.01 * np.sin(angle),
                               atol=1e-12)
    # its frequency on the constant-speed part of the extension: teeth x motor speed / 2 pi
    w = r.true_velocity_motor
    steady = (T > 0.3) & (T < 2.2)
    assert np.ptp(w[steady]) < 1e-9
    ripple = (r.effort_load - r.true_effort_load)[steady]
    spectrum = np.abs(np.fft.rfft(ripple * np.hanning(ripple.size)))
    peak = np.fft.rfftfreq(ripple.size, 0.001)[np.argmax(spectrum)]
    assert peak == pytest.approx(17.0 * w[steady][0] / (2 * math.pi), rel=0.03)


def test_the_spur_plant_ripples_at_its_pinion_teeth() -> None:
    config = config_from_parameters(_quiet(plant='spur', pinion_teeth=23.0, mesh_teeth=17.0,
                                           ripple_effort_load=0.3))
    r = Simulator(config).sample(T)
    np.testing.assert_allclose(r.effort_load - r.true_effort_load,
                               0.3 * np.sin(23.0 * r.position_motor), atol=1e-12)


def test_encoder_positions_and_differenced_speeds() -> None:
    counts = 4096
    _, r = _run(encoder_counts_motor=counts, encoder_counts_load=65536)
    step = 2 * math.pi / counts
    true_motor = SimulationConfig().plant.ratio * Simulator(
        config_from_parameters(_quiet())).sample(T).position_load
    np.testing.assert_allclose(r.position_motor, np.floor(true_motor / step) * step)
    assert np.all(true_motor - r.position_motor >= -1e-12)
    assert np.all(true_motor - r.position_motor < step)
    expected = np.diff(r.position_motor) / 0.001
    np.testing.assert_allclose(r.velocity_motor[1:], expected, rtol=1e-9, atol=1e-9)
    assert r.velocity_motor[0] == 0.0
    # a count is 1.5 mrad: at 1 kHz each speed is off by up to one count per ms, their mean not
    error = r.velocity_motor - r.true_velocity_motor
    assert np.abs(error).max() > 0.5 * step / 0.001
    assert abs(error[1:].mean()) < 1e-3


def test_encoder_differencing_runs_on_across_chunks() -> None:
    config = config_from_parameters(_quiet(encoder_counts_motor=2048, encoder_counts_load=8192,
                                           noise_velocity_motor=0.01))
    whole = Simulator(config).sample(T[:5000])
    simulator = Simulator(config)
    parts = [simulator.sample(T[a:b]) for a, b in ((0, 1), (1, 1234), (1234, 5000))]
    for name in ('position_motor', 'velocity_motor', 'velocity_load'):
        np.testing.assert_array_equal(np.concatenate([getattr(p, name) for p in parts]),
                                      getattr(whole, name))


def test_encoder_helpers() -> None:
    np.testing.assert_array_equal(encoder_reading(np.array([0.1, -0.1]), 4),
                                  [0.0, -math.pi / 2])
    velocity = differenced(np.array([1.0, 1.5, 1.5]), np.array([2.0, 2.5, 3.0]), (1.0, 0.0))
    np.testing.assert_allclose(velocity, [1.0, 1.0, 0.0])


def test_defaults_change_nothing() -> None:
    default = Simulator(SimulationConfig(seed=5)).sample(T[:3000])
    explicit = Simulator(config_from_parameters({'seed': 5})).sample(T[:3000])
    for name in ('position_motor', 'velocity_motor', 'effort_motor', 'effort_load'):
        np.testing.assert_array_equal(getattr(explicit, name), getattr(default, name))
    assert not Sensors().encoders


def test_bad_sensor_errors_are_refused() -> None:
    with pytest.raises(ValueError, match='gain must be > -1'):
        Channel(gain=-1.0)
    with pytest.raises(ValueError, match='encoder_counts_motor must be an integer >= 0'):
        Sensors(encoder_counts_motor=-3)
