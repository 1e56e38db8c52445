"""``ros2 run gear_phm estimator``: the friction estimator node.

A thin adapter over :class:`gear_phm.estimation.EstimatorPipeline`.

Subscribes ``joint_states`` (sensor QoS), publishes ``gear_phm/friction``,
``gear_phm/friction_covariance``, ``gear_phm/efficiency``, ``gear_phm/innovation`` and
``gear_phm/counts`` (geometry_msgs/Vector3Stamped, stamped with the sample time) and its own
``/diagnostics`` status ``gear_phm estimator: <node name>`` with drop counters by reason.
A bad message is dropped and counted, never fatal. Parameters: config/estimator.yaml.
"""
from __future__ import annotations

from collections.abc import Sequence
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3Stamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from sensor_msgs.msg import JointState

from gear_phm import interfaces
from gear_phm.estimation import EstimatorConfig, EstimatorPipeline, PARAMETERS
from gear_phm.interfaces import DiagnosticsOut
from gear_phm.nodes.common import (ConfigError, declare, OUTPUT_QOS, OutputPublisher, run_node,
                                   SENSOR_QOS, to_rclpy)

STRING_PARAMETERS = {
    'motor_joint': ('motor', 'name of the motor joint in joint_states'),
    'load_joint': ('load', 'name of the load joint in joint_states'),
    'backwards_policy': ('reset', "stamps going backwards (bag loop): 'reset' the estimator "
                                  "or 'skip' the samples"),
    'frame_id': ('', 'frame_id written in the output headers'),
}


def config_from_values(values: dict[str, Any]) -> EstimatorConfig:
    """Build an EstimatorConfig from parameter values (ints accepted for doubles); ValueError."""
    fields = {name: values[name] for name in PARAMETERS if name in values}
    fields['backwards_policy'] = values.get('backwards_policy', 'reset')
    return EstimatorConfig(**fields)


class EstimatorNode(Node):
    """Friction estimator; every parameter can be changed at run time (the filter restarts)."""

    def __init__(self) -> None:
        super().__init__('estimator')
        defaults = EstimatorConfig()
        values: dict[str, Any] = {}
        try:
            for name, (low, high, unit, text) in PARAMETERS.items():
                default = getattr(defaults, name)
                default = int(default) if name == 'max_consecutive_gated' else float(default)
                values[name] = declare(self, name, default, f'{text} [{unit}]',
                                       low=low, high=min(high, 1e300))
            for name, (default, text) in STRING_PARAMETERS.items():
                values[name] = declare(self, name, default, text)
            values['diagnostics_period'] = declare(
                self, 'diagnostics_period', 1.0, '/diagnostics status period [s]',
                low=0.01, high=3600.0)
            values['batch_period'] = declare(
                self, 'batch_period', 0.005, 'samples are buffered and processed every '
                'batch_period (or 200 samples); outputs are stamped with sample time [s]',
                low=0.0001, high=1.0)
            self.config = config_from_values(values)
            self.pipeline = EstimatorPipeline(self.config, values['motor_joint'],
                                              values['load_joint'], values['frame_id'])
        except Exception as exc:  # rclpy parameter exceptions and ValueError alike
            raise ConfigError(f'estimator parameters: {str(exc).splitlines()[0]}') from None
        self.values = values
        self.outputs = OutputPublisher(self, [(t, Vector3Stamped)
                                              for t in interfaces.ESTIMATOR_TOPICS])
        self.diag_pub = self.create_publisher(DiagnosticArray, interfaces.DIAGNOSTICS,
                                              OUTPUT_QOS)
        _warm_up(self.config)
        self.create_subscription(JointState, interfaces.JOINT_STATES, self._on_joint_state,
                                 SENSOR_QOS)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.messages_received = 0
        self.status_name = f'gear_phm estimator: {self.get_name()}'
        self.create_timer(values['diagnostics_period'], self._on_diagnostics_timer)
        self.buffer: list[interfaces.JointSample] = []
        self.last_arrival_ns: int | None = None   # node clock at the newest arrival [ns]
        self.batch_period: float = values['batch_period']
        self.last_flush = time.monotonic()        # wall time, only paces the batching [s]
        self.max_buffer = 200
        self.create_timer(values['batch_period'], self._on_clock_timer)

    # --- callbacks -----------------------------------------------------------------------------
    def _on_joint_state(self, msg: JointState) -> None:
        self.messages_received += 1
        self.last_arrival_ns = self.get_clock().now().nanoseconds
        sample = self.pipeline.sample_from_message(msg)
        if sample is not None:
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
            if param.name in ('diagnostics_period', 'batch_period'):
                return SetParametersResult(successful=False,
                                           reason=f'{param.name} is fixed at start-up')
            values[param.name] = param.value
        if not values['motor_joint'] or values['motor_joint'] == values['load_joint']:
            return SetParametersResult(
                successful=False, reason=f'motor_joint and load_joint must be two different '
                f'non-empty names, got {values["motor_joint"]!r} and {values["load_joint"]!r}')
        try:
            config = config_from_values(values)
        except ValueError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        self._flush()
        self.values = values
        self.config = config
        self.pipeline.motor_joint = values['motor_joint']
        self.pipeline.load_joint = values['load_joint']
        self.pipeline.frame_id = values['frame_id']
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
