"""The RUL's wear history takes the filter's window measurements (docs/prognostics.md)."""
from __future__ import annotations

from dataclasses import replace
import math
from types import SimpleNamespace

import numpy as np
import pytest

from gear_phm import interfaces
from gear_phm.estimation import EstimatorConfig, EstimatorPipeline
from gear_phm.estimation.records import FrictionEstimate
from gear_phm.prognostics import HealthAssessor
from gear_phm.prognostics.config import HealthConfig
from helpers.plant import lever_plant

CONFIG = EstimatorConfig(ratio=3.0, motor_torque_noise=0.05, load_torque_noise=0.05,
                         motor_inertia=0.01)


def _run(sizes: list[int] | None) -> list[FrictionEstimate]:
    """Return the estimates of a 120 s, 100 Hz run of u = 0.1 + 0.001 t.

    Fed in batches of ``sizes`` (cycled; None: one batch).
    """
    run = lever_plant(5, 120.0, lambda t: 0.1 + 0.001 * t, rate=100.0)
    columns = [run.stamp_ns, run.motor_velocity, run.motor_effort, run.load_velocity,
               run.load_effort]
    pipeline = EstimatorPipeline(CONFIG)
    out: list[FrictionEstimate] = []
    start, k = 0, 0
    n = run.stamp_ns.size
    while start < n:
        size = n if sizes is None else sizes[k % len(sizes)]
        out += pipeline.on_batch(*[c[start:start + size] for c in columns])
        start, k = start + size, k + 1
    return out


def test_measurements_ride_on_estimates_whatever_the_batch_split() -> None:
    whole = _run(None)
    rng = np.random.default_rng(3)
    split = _run([int(v) for v in rng.integers(1, 40, 50)])
    pick = (lambda estimates: [(e.stamp_ns, e.measurement, e.measurement_variance)
                               for e in estimates if math.isfinite(e.measurement)])
    a, b = pick(whole), pick(split)
    assert len(a) > 50                 # a window per second of motion (67; the plant dwells)
    assert [s for s, _, _ in a] == [s for s, _, _ in b]
    assert np.allclose([(z, v) for _, z, v in a], [(z, v) for _, z, v in b], rtol=1e-9)
    # each measures u at its estimate's time: unbiased, within its own sigma
    truth = np.array([0.1 + 0.001 * (s - whole[0].stamp_ns) * 1e-9 for s, _, _ in a])
    z = np.array([m for _, m, _ in a])
    sigma = np.sqrt([v for _, _, v in a])
    assert abs(float(np.mean((z - truth) / sigma))) < 0.3
    assert 0.5 < float(np.std((z - truth) / sigma)) < 2.0


def test_operating_time_topic_carries_the_measurement() -> None:
    estimate = FrictionEstimate(7 * 10 ** 9, 0.2, 1e-4, (1e-6, 0.0, 1e-10),
                                operating_time=6.5, measurement=0.201,
                                measurement_variance=4e-6)
    vectors = {out.topic: SimpleNamespace(x=out.x, y=out.y, z=out.z)
               for out in interfaces.estimate_outputs(estimate)}
    back = interfaces.estimate_from_vectors(estimate.stamp_ns, vectors)
    assert (back.operating_time, back.measurement, back.measurement_variance) == (
        6.5, 0.201, 4e-6)
    # recordings from before 2026-11-25 hold y = z = 0 there: no measurement
    vectors[interfaces.OPERATING_TIME] = SimpleNamespace(x=6.5, y=0.0, z=0.0)
    legacy = interfaces.estimate_from_vectors(estimate.stamp_ns, vectors)
    assert math.isnan(legacy.measurement) and math.isnan(legacy.measurement_variance)


@pytest.mark.parametrize('measured', [True, False])
def test_assessor_history_holds_measurements_else_posteriors(measured: bool) -> None:
    assessor = HealthAssessor(HealthConfig(eta_opposing_min=0.5, mc_samples=200))
    noise = np.random.default_rng(4).standard_normal(80)
    for k in range(80):
        e = FrictionEstimate(10 ** 9 * (k + 1), 0.1 + 0.002 * k, 0.002, (1e-6, 0.0, 1e-10),
                             operating_time=float(k + 1))
        if measured and k % 2 == 0:              # a window every other estimate
            e = replace(e, measurement=e.u + 2e-3 * noise[k], measurement_variance=4e-6)
        assessor.on_estimate(e)
    history = assessor.predictor.history
    assert history.independent == measured
    t, u, precision = history.arrays()
    assert len(t) == (40 if measured else 80)
    if measured:                 # summed precision of the measurements in each bin
        assert precision == pytest.approx(np.full(40, 1.0 / 4e-6))
    state = assessor.latest
    assert state is not None and math.isfinite(state.rul.median)


def test_direction_offset_topic_round_trips() -> None:
    estimate = FrictionEstimate(7 * 10 ** 9, 0.2, 1e-4, (1e-6, 0.0, 1e-10),
                                operating_time=6.5, measurement=0.201,
                                measurement_variance=4e-6, direction_offset=0.03,
                                measurement_direction=-0.5, measurement_bias=-0.01)
    vectors = {out.topic: SimpleNamespace(x=out.x, y=out.y, z=out.z)
               for out in interfaces.estimate_outputs(estimate)}
    assert (vectors[interfaces.DIRECTION_OFFSET].x, vectors[interfaces.DIRECTION_OFFSET].y,
            vectors[interfaces.DIRECTION_OFFSET].z) == (0.03, -0.5, -0.01)
    back = interfaces.estimate_from_vectors(estimate.stamp_ns, vectors)
    assert (back.direction_offset, back.measurement_direction, back.measurement_bias) == (
        0.03, -0.5, -0.01)
    # an estimator from before the topic: NaN, and the history does not re-correct
    del vectors[interfaces.DIRECTION_OFFSET]
    legacy = interfaces.estimate_from_vectors(estimate.stamp_ns, vectors)
    assert math.isnan(legacy.direction_offset) and math.isnan(legacy.measurement_bias)


def test_measurements_carry_their_direction_and_the_bias_taken_off() -> None:
    estimates = [e for e in _run(None) if math.isfinite(e.measurement)]
    directions = {e.measurement_direction for e in estimates}
    assert directions <= {-0.5, 0.5} and len(directions) == 2       # both load directions
    for e in estimates:
        # the bias taken off is the direction's share of the offset as it was then: h d,
        # with the d of the filter before this window's update (not the one after it)
        assert math.isfinite(e.direction_offset)
        assert abs(e.measurement_bias) <= 0.5 * abs(e.direction_offset) + 0.05


def _mismatched(k: int, d_learned: float) -> FrictionEstimate:
    """Return estimate k (1 s apart) of a healthy gearbox with u 0.2 and offset d 0.04.

    Its aiding windows read u + d/2 and opposing ones u - d/2; the measurement as fused with
    ``d_learned``.
    """
    h = 0.5 if k % 2 else -0.5
    reading = 0.2 + h * 0.04 + 1e-3 * math.sin(1.7 * k)
    bias = h * d_learned
    return FrictionEstimate(10 ** 9 * (k + 1), 0.2, 0.0, (1e-6, 0.0, 1e-10),
                            operating_time=float(k + 1), measurement=reading - bias,
                            measurement_variance=1e-6, direction_offset=d_learned,
                            measurement_direction=h, measurement_bias=bias)


def test_the_history_re_corrects_windows_fused_before_the_offset_was_learned() -> None:
    # the first 40 s all opposing windows, fused with d = 0 (not learned yet): they read
    # u - d/2 = 0.18, then both directions with d learned: 0.20. Without the re-correction
    # the history rises by 0.02, which the fit takes for wear (random lives 26 and 98)
    assessor = HealthAssessor(HealthConfig(eta_opposing_min=0.5, mc_samples=200))
    states = []
    for k in range(200):
        e = _mismatched(2 * k if k < 40 else k, 0.0 if k < 40 else 0.04)
        states.append(assessor.on_estimate(replace(e, stamp_ns=10 ** 9 * (k + 1),
                                                   operating_time=float(k + 1))))
    _, u, _ = assessor.predictor.history.arrays()
    assert np.ptp(u) < 0.005 and abs(float(np.mean(u)) - 0.2) < 0.002
    assert all(s is not None and s.level == 0 and math.isinf(s.rul.median) for s in states)
    # the same history without the offset learned (NaN: an estimator from before the topic)
    legacy = HealthAssessor(HealthConfig(eta_opposing_min=0.5, mc_samples=200))
    finite = 0
    for k in range(200):
        e = _mismatched(2 * k if k < 40 else k, 0.0 if k < 40 else 0.04)
        state = legacy.on_estimate(replace(
            e, stamp_ns=10 ** 9 * (k + 1), operating_time=float(k + 1),
            direction_offset=math.nan, measurement_direction=math.nan,
            measurement_bias=math.nan))
        finite += state is not None and math.isfinite(state.rul.median)
    _, u_legacy, _ = legacy.predictor.history.arrays()
    assert np.ptp(u_legacy) > 0.015            # the step the re-correction takes out
    assert finite > 100                        # ... read as wear (160 of 200 finite RULs)


def test_history_state_keeps_the_direction_sums_and_reads_older_files() -> None:
    from gear_phm.prognostics.history import WearHistory
    history = WearHistory(16)
    history.independent = True
    for k in range(40):                     # merges twice: the sums move with the bins
        h = 0.5 if k % 3 else -0.5
        bias = h * 0.02 if k >= 10 else 0.0     # d = 0.02, learned from the 10th window on
        history.add(float(k), 0.2 + h * 0.02 - bias, 1e-6, h, bias)
    history.offset = 0.02
    assert np.allclose(history.arrays()[1], 0.2)
    state = history.to_state()
    back = WearHistory(16)
    back.from_state(state)
    assert all(np.array_equal(a, b) for a, b in zip(history.arrays(), back.arrays()))
    assert back.offset == 0.02
    # a file from before 2026-11-27: no direction sums, so no re-correction
    older = {k: v for k, v in state.items() if k not in ('wh', 'wb', 'offset')}
    old = WearHistory(16)
    old.from_state(older)
    assert old.offset == 0.0
    t, u, _ = old.arrays()
    _, u_now, _ = history.arrays()
    assert t.size == u_now.size and not np.allclose(u, u_now)
