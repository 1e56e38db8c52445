"""The no-load loss learned jointly with u (gear_phm.estimation.no_load, through the pipeline)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gear_phm.estimation import EstimatorConfig, EstimatorPipeline
from gear_phm.estimation.no_load import NoLoadLearner
from gear_phm.models import eta_aiding, eta_opposing

RATIO = 30.0
U = 0.06                        # eta_D 0.909, eta_I 0.938 at R 30
RATE = 200.0                    # Hz
STROKE = 2.0                    # s per stroke, extend (opposing) then retract (aiding)
SPEED = 1.0                     # rad/s peak load speed
FORCE = 40.0                    # N m nominal load torque


def drive(duration: float, *, coulomb: float = 0.0, viscous: float = 0.0,
          load_range: tuple[float, float] = (1.0, 1.0), cold_factor: float = 1.0,
          warm_time: float = 600.0, load_offset: float = 0.0, start: float = 0.0,
          seed: int = 1) -> tuple[np.ndarray, ...]:
    """Return (stamps [ns], w_m, tau_m, w_l, tau_l) of an actuator with a no-load loss.

    Strokes of STROKE s, a half-sine speed profile; the load torque of each cycle is FORCE
    times a factor drawn from ``load_range``, plus a spring part; the no-load torque at the
    motor is (T_0 sign(w_m) + c_v w_m) times a factor that decays from ``cold_factor`` to 1
    with ``warm_time``. ``load_offset`` [N m] is added to the load torque reading.
    """
    rng = np.random.default_rng(seed)
    t = start + np.arange(int(duration * RATE)) / RATE
    phase = np.mod(t - start, 2.0 * STROKE)
    sign = np.where(phase < STROKE, 1.0, -1.0)
    w_l = sign * SPEED * np.sin(np.pi * np.mod(phase, STROKE) / STROKE)
    cycle = np.floor((t - start) / (2.0 * STROKE)).astype(int)
    factors = rng.uniform(*load_range, size=cycle.max() + 1)[cycle]
    position = np.cumsum(w_l) / RATE
    force = FORCE * factors * (1.0 + 0.2 * position)
    eta_d, eta_i = float(eta_opposing(U, RATIO)), float(eta_aiding(U, RATIO))
    w_m = RATIO * w_l
    mesh = np.where(sign > 0, force / (RATIO * eta_d), force * eta_i / RATIO)
    heat = 1.0 + (cold_factor - 1.0) * np.exp(-(t - start) / warm_time)
    drag = heat * (coulomb * np.sign(w_m) + viscous * w_m)
    noise = rng.normal(0.0, 1e-3, size=(2, t.size))
    tau_m = mesh + drag + 0.01 * noise[0]
    tau_l = force + load_offset + 0.3 * noise[1]
    stamps = np.round(t * 1e9).astype(np.int64)
    return stamps, w_m, tau_m, w_l, tau_l


def run(pipeline: EstimatorPipeline, data: tuple[np.ndarray, ...]) -> None:
    """Feed ``data`` in batches of 1000 samples."""
    for start in range(0, data[0].size, 1000):
        pipeline.on_batch(*(column[start:start + 1000] for column in data))


def config(**changes: float | bool | str) -> EstimatorConfig:
    return EstimatorConfig(ratio=RATIO, no_load_model=True, **changes)


def test_drag_and_friction_are_separated_on_a_varying_load() -> None:
    # 2.5 % of the input torque at nominal load as drag, the load 0.3-1.0 of nominal
    drag = 0.025 * FORCE / RATIO
    pipeline = EstimatorPipeline(config())
    run(pipeline, drive(600.0, coulomb=0.7 * drag, viscous=0.3 * drag / (RATIO * SPEED * 0.64),
                        load_range=(0.3, 1.0)))
    summary = pipeline.summary()
    assert summary['filter_updates'] > 50
    assert summary['eta_opposing'] == pytest.approx(float(eta_opposing(U, RATIO)), abs=0.005)
    assert summary['u'] == pytest.approx(U, abs=0.006)
    assert summary['no_load_identified'] is True
    # the no-load torque at the typical speed: T_0 + c_v w_typ within 15 % of the drag
    speed = summary['no_load_reference_speed']
    truth = 0.7 * drag + 0.3 * drag / (RATIO * SPEED * 0.64) * speed
    assert summary['no_load_torque'] == pytest.approx(truth, rel=0.15)


def test_the_paper_model_reads_the_same_drag_as_friction() -> None:
    drag = 0.025 * FORCE / RATIO
    pipeline = EstimatorPipeline(EstimatorConfig(ratio=RATIO))
    run(pipeline, drive(300.0, coulomb=drag, load_range=(0.3, 1.0)))
    # without the no-load model the drag lowers eta_D by about its share
    assert pipeline.summary()['eta_opposing'] < float(eta_opposing(U, RATIO)) - 0.01


def test_warming_drag_does_not_move_u() -> None:
    drag = 0.025 * FORCE / RATIO
    pipeline = EstimatorPipeline(config())
    u_seen = []
    data = drive(1500.0, coulomb=drag, cold_factor=3.0, warm_time=300.0, load_range=(0.3, 1.0))
    for start in range(0, data[0].size, 20_000):
        pipeline.on_batch(*(column[start:start + 20_000] for column in data))
        if pipeline.filter.updates:
            u_seen.append(pipeline.summary()['u'])
    late = u_seen[len(u_seen) // 3:]
    assert max(late) - min(late) < 0.01
    assert np.mean(late) == pytest.approx(U, abs=0.006)
    # the drag fell with the oil's warming: the cold value is above the warm one
    summary = pipeline.summary()
    assert summary['no_load_cold_torque'] > 1.5 * summary['no_load_torque']


def test_a_load_sensor_offset_biases_eta_by_at_most_half_a_percent() -> None:
    pipeline = EstimatorPipeline(config())
    run(pipeline, drive(600.0, load_range=(0.3, 1.0), load_offset=0.4))
    summary = pipeline.summary()
    assert summary['eta_opposing'] == pytest.approx(float(eta_opposing(U, RATIO)), abs=0.005)
    assert summary['eta_aiding'] == pytest.approx(float(eta_aiding(U, RATIO)), abs=0.005)


def test_a_constant_load_is_not_identifiable_and_holds_u() -> None:
    drag = 0.075 * FORCE / RATIO                # a cold drag, three times 2.5 %
    pipeline = EstimatorPipeline(config())
    run(pipeline, drive(300.0, coulomb=drag))
    summary = pipeline.summary()
    assert summary['counts']['not_identifiable'] > 50
    assert summary['filter_updates'] == 0
    assert summary['u'] == pytest.approx(0.05)      # the prior, not moved
    status = pipeline.status('test')
    assert status.level == 0
    assert 'not identifiable' in status.message
    assert dict(status.values)['windows_rejected_not_identifiable'] == str(
        summary['counts']['not_identifiable'])


def test_a_cold_restart_after_an_idle_gap_starts_from_the_cold_value() -> None:
    drag = 0.025 * FORCE / RATIO
    pipeline = EstimatorPipeline(config())
    run(pipeline, drive(1200.0, coulomb=drag, cold_factor=3.0, warm_time=200.0,
                        load_range=(0.3, 1.0)))
    learner = pipeline.no_load
    warm = learner.estimate()
    assert warm.cold_torque > 2.0 * warm.torque
    # the next day: a gap longer than no_load_cool_gap, the state restored from a file
    restored = EstimatorPipeline(config())
    restored.from_state(pipeline.to_state())
    assert restored.no_load.estimate() == warm
    run(restored, drive(20.0, coulomb=drag, cold_factor=3.0, warm_time=200.0,
                        load_range=(0.3, 1.0), start=1200.0 + 86_400.0, seed=2))
    after = restored.no_load.estimate()
    # it began from the cold value, not the warm one, and is still near it 20 s later
    assert after.torque > 0.7 * warm.cold_torque
    assert after.torque > 2.0 * warm.torque


def test_the_learner_refuses_a_malformed_state() -> None:
    learner = NoLoadLearner()
    state = learner.to_state()
    state['cold'] = [1.0]
    with pytest.raises(ValueError, match='malformed'):
        learner.from_state(state)


def test_total_efficiency_at_the_rated_point() -> None:
    drag = 0.025 * FORCE / RATIO
    pipeline = EstimatorPipeline(config(rated_load_torque=FORCE, rated_speed=SPEED))
    run(pipeline, drive(600.0, coulomb=drag, load_range=(0.3, 1.0)))
    summary = pipeline.summary()
    eta = summary['eta_opposing']
    expected = 1.0 / (1.0 / eta + RATIO * summary['no_load_torque'] / FORCE)
    assert summary['total_efficiency'] == pytest.approx(expected, rel=0.02)
    assert summary['total_efficiency'] < eta - 0.015
    assert math.isnan(EstimatorPipeline(config()).summary()['total_efficiency'])


def test_a_grown_drag_is_warn_and_a_cold_start_is_not() -> None:
    drag = 0.025 * FORCE / RATIO
    pipeline = EstimatorPipeline(config(no_load_band_time=600.0))
    # the first run starts cold, warms up: the band holds its cold value
    run(pipeline, drive(900.0, coulomb=drag, cold_factor=3.0, warm_time=150.0,
                        load_range=(0.3, 1.0)))
    assert pipeline.status('test').level == 0
    # the next day starts cold again: not a fault
    run(pipeline, drive(300.0, coulomb=drag, cold_factor=3.0, warm_time=150.0,
                        load_range=(0.3, 1.0), start=900.0 + 86_400.0, seed=2))
    status = pipeline.status('test')
    assert status.level == 0, status.message
    assert pipeline.summary()['u'] == pytest.approx(U, abs=0.006)
    # a seal fault: the warm drag five times what it was
    run(pipeline, drive(600.0, coulomb=5.0 * drag, load_range=(0.3, 1.0),
                        start=2 * 86_400.0, seed=3))
    status = pipeline.status('test')
    assert status.level == 1
    assert 'above its healthy band' in status.message
    # drag, not wear: u stays where it was
    assert pipeline.summary()['u'] == pytest.approx(U, abs=0.006)
