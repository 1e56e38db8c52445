"""One drive's estimator: its status under its names, its resets and its sensor watch."""
from __future__ import annotations

import numpy as np

from gear_phm.estimation import EstimatorConfig
from gear_phm.run import DriveEstimator, DriveNames


def test_status_reset_and_watch() -> None:
    run = DriveEstimator(EstimatorConfig(ratio=3.0, sensor_timeout=0.5), DriveNames.of('rudder'))
    assert run.status(0).name == 'gear_phm estimator: rudder'
    assert run.refusal() == ''
    stamps = np.arange(1, 51, dtype=np.int64) * 10_000_000
    speed = np.full(50, 3.0)
    run.pipeline.on_batch(stamps, speed, np.full(50, 1.0), speed / 3.0, np.full(50, -2.5))
    run.watch(2_000_000_000)                    # no sample seen by the caller: no watch
    assert 'sensor timeout' not in run.status(50).message
    run.last_sample_ns = 0
    run.watch(2_000_000_000)                    # 2 s without a sample: the timeout
    assert run.status(50).message.startswith('sensor timeout')
    run.reset()
    assert run.resets == 1 and run.pipeline.samples_seen == 50     # the counters stay
