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
