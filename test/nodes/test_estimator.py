"""The estimator node's per-message callback, without DDS.

It batches samples, yet processes each output as soon as the sample it is stamped with (or
the next) has arrived, and the outputs equal one offline pass over the same samples.
"""
from __future__ import annotations

import types

import numpy as np
import pytest

pytest.importorskip('rclpy')
from gear_phm.estimation import EstimatorConfig, EstimatorPipeline  # noqa: E402
from gear_phm.nodes.estimator import EstimatorNode  # noqa: E402
from gear_phm.simulation import simulate, SimulationConfig  # noqa: E402


class _Timer:
    def reset(self) -> None:
        pass

    def cancel(self) -> None:
        pass


def test_outputs_leave_with_their_sample_and_equal_offline() -> None:
    rate = 1000.0
    t = np.arange(int(30 * rate)) / rate
    run = simulate(SimulationConfig(), t)
    stamps = (t * 1e9).astype(np.int64) + 1_700_000_000 * 10 ** 9
    columns = (stamps, run.velocity_motor, run.effort_motor, run.velocity_load,
               run.effort_load)
    config = EstimatorConfig()
    node = types.SimpleNamespace(config=config, pipeline=EstimatorPipeline(config),
                                 stamps=[], rows=[], _due=None, messages_received=0,
                                 batch_timer=_Timer(),
                                 decoder=types.SimpleNamespace(decode=lambda raw: raw))
    EstimatorNode._set_window_watch(node)
    delays, outputs, batches = [], [], [0]

    def flush() -> None:
        if not node.stamps:
            return
        part = np.array(node.stamps)
        values = np.array(node.rows).T
        node.stamps, node.rows = [], []
        batches[0] += 1
        for estimate in node.pipeline.on_batch(part, *values):
            outputs.append(estimate)
            arrived = np.searchsorted(stamps, part[-1])
            delays.append(int(arrived - np.searchsorted(stamps, estimate.stamp_ns)))
        node._due = node.pipeline.next_output_stamp()

    node._flush = flush
    for row in zip(*(c.tolist() for c in columns)):
        EstimatorNode._on_message(node, row)
    flush()
    offline = EstimatorPipeline(config).on_batch(*columns)
    assert [e.stamp_ns for e in outputs] == [e.stamp_ns for e in offline]
    assert [e.u for e in outputs] == pytest.approx([e.u for e in offline], rel=1e-9)
    assert len(outputs) > 250 and max(delays[1:]) <= 1      # samples after its own
    assert delays[0] <= config.stamp_run
    assert batches[0] < len(outputs) * 2 + 30               # not one batch per sample
