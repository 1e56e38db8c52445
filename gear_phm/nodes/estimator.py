"""``ros2 run gear_phm estimator``: the friction estimator node.

A thin adapter over :class:`gear_phm.estimation.EstimatorPipeline`.

Takes JointState in and publishes each :class:`~gear_phm.estimation.FrictionEstimate` through
the live transport (:mod:`gear_phm.nodes.transport`; topics in docs/architecture.md), stamped
with the sample time, plus its own ``/diagnostics`` status
``gear_phm estimator: <node name>`` with drop counters by reason.
A bad message is dropped and counted, never fatal. Parameters: config/estimator.yaml.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import fields
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node

from gear_phm import interfaces
from gear_phm.estimation import EstimatorConfig, EstimatorPipeline, JointSample, PARAMETERS
from gear_phm.interfaces import DiagnosticsOut
from gear_phm.nodes.common import ConfigError, declare_parameters, OUTPUT_QOS, run_node, to_rclpy
from gear_phm.nodes.transport import EstimatePublisher, subscribe_joint_states
from gear_phm.parameters import ParamSpec

#: Parameters of the node itself (the estimator's are :data:`gear_phm.estimation.PARAMETERS`).
NODE_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec('motor_joint', 'motor', 'name of the motor joint in joint_states'),
    ParamSpec('load_joint', 'load', 'name of the load joint in joint_states'),
    ParamSpec('frame_id', '', 'frame_id written in the output headers'),
    ParamSpec('diagnostics_period', 1.0, '/diagnostics status period', 's', 0.01, 3600.0,
              read_only=True),
    ParamSpec('batch_period', 0.005, 'samples are buffered and processed every batch_period '
              '(or 200 samples); outputs are stamped with sample time', 's', 0.0001, 1.0,
              read_only=True),
)
CONFIG_FIELDS = tuple(f.name for f in fields(EstimatorConfig))


def config_from_values(values: dict[str, Any]) -> EstimatorConfig:
    """EstimatorConfig from parameter values; ValueError with the reason."""
    return EstimatorConfig(**{name: values[name] for name in CONFIG_FIELDS if name in values})


def joint_names_problem(values: dict[str, Any]) -> str:
    """'' or why motor_joint/load_joint are unusable."""
    if not values['motor_joint'] or values['motor_joint'] == values['load_joint']:
        return (f'motor_joint and load_joint must be two different non-empty names, got '
                f'{values["motor_joint"]!r} and {values["load_joint"]!r}')
    return ''


class EstimatorNode(Node):
    """Friction estimator; every parameter can be changed at run time (the filter restarts)."""

    def __init__(self) -> None:
        super().__init__('estimator')
        values = declare_parameters(self, PARAMETERS + NODE_PARAMETERS)
        problem = joint_names_problem(values)
        try:
            if problem:
                raise ValueError(problem)
            self.config = config_from_values(values)
        except ValueError as exc:
            raise ConfigError(f'estimator parameters: {exc}') from None
        self.pipeline = EstimatorPipeline(self.config)
        self.values = values
        self.outputs = EstimatePublisher(self, values['frame_id'])
        self.diag_pub = self.create_publisher(DiagnosticArray, interfaces.DIAGNOSTICS,
                                              OUTPUT_QOS)
        _warm_up(self.config)
        self.messages_received = 0
        self.buffer: list[JointSample] = []
        self.last_arrival_ns: int | None = None   # node clock at the newest arrival [ns]
        self.batch_period: float = values['batch_period']
        self.last_flush = time.monotonic()        # wall time, only paces the batching [s]
        self.max_buffer = 200
        subscribe_joint_states(self, lambda: self.values['motor_joint'],
                               lambda: self.values['load_joint'], self._on_sample,
                               self._on_reject)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.status_name = f'gear_phm estimator: {self.get_name()}'
        self.create_timer(values['diagnostics_period'], self._on_diagnostics_timer)
        self.create_timer(values['batch_period'], self._on_clock_timer)

    # --- callbacks -----------------------------------------------------------------------------
    def _arrived(self) -> None:
        self.messages_received += 1
        self.last_arrival_ns = self.get_clock().now().nanoseconds

    def _on_reject(self, reason: str) -> None:
        self._arrived()
        self.pipeline.reject_message(reason)

    def _on_sample(self, sample: JointSample) -> None:
        self._arrived()
        self.buffer.append(sample)
        now = time.monotonic()
        # in a stream, process as soon as batch_period has passed (latency); the timer
        # only handles the tail of a stream
        if len(self.buffer) >= self.max_buffer or now - self.last_flush >= self.batch_period:
            self._flush()

    def _flush(self) -> None:
        """Process buffered samples as one batch (same results as one by one)."""
        self.last_flush = time.monotonic()
        if not self.buffer:
            return
        samples, self.buffer = self.buffer, []
        try:
            outputs = self.pipeline.on_samples(samples)
        except Exception as exc:  # never die on data; count it
            self.pipeline.reject_message('bad_message', len(samples))
            self.get_logger().warn(f'dropped {len(samples)} joint_states sample(s): {exc}',
                                   throttle_duration_sec=5.0)
            return
        self.outputs.publish(outputs)

    def _on_clock_timer(self) -> None:
        self._flush()
        if self.last_arrival_ns is not None:
            silence_s = (self.get_clock().now().nanoseconds - self.last_arrival_ns) * 1e-9
            self.outputs.publish(self.pipeline.on_silence(silence_s))

    def _on_diagnostics_timer(self) -> None:
        now = self.get_clock().now().nanoseconds
        status = self.pipeline.status(self.status_name, self.messages_received)
        self.diag_pub.publish(to_rclpy(DiagnosticsOut(now, (status,))))

    def _on_set_parameters(self, params: Sequence[Any]) -> SetParametersResult:
        values = dict(self.values)
        for param in params:
            values[param.name] = param.value
        problem = joint_names_problem(values)
        if problem:
            return SetParametersResult(successful=False, reason=problem)
        try:
            config = config_from_values(values)
        except ValueError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        self._flush()
        self.values = values
        self.config = config
        self.outputs.frame_id = values['frame_id']
        self.pipeline.reconfigure(config)
        return SetParametersResult(successful=True)


def _warm_up(config: EstimatorConfig) -> None:
    """Run a throw-away pipeline over 4 s of simulated samples before subscribing.

    The first window close, filter update and numpy/LAPACK calls cost ~100 ms once; paid
    while the queue is filling, that stall dropped live samples at 1 kHz.
    """
    import numpy as np

    from gear_phm.simulation import SimulationConfig, simulate
    t = np.arange(4000) / 1000.0
    run = simulate(SimulationConfig(), t)     # any plant exercises the code paths
    pipeline = EstimatorPipeline(config)
    stamps = (t * 1e9).astype(np.int64) + 1_000_000_000
    for first in range(0, t.size, 5):
        part = slice(first, first + 5)
        pipeline.on_batch(stamps[part], run.velocity_motor[part], run.effort_motor[part],
                          run.velocity_load[part], run.effort_load[part])
    pipeline.status('warm-up', 0)


def main(args: Sequence[str] | None = None) -> int:
    """Entry point of ``ros2 run gear_phm estimator``."""
    return run_node(EstimatorNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
