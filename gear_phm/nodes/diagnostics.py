"""Diagnostics node: efficiency, remaining useful life and health level on /diagnostics.

``ros2 run gear_phm diagnostics``. Subscribes to the five estimator topics (identical stamps
per update, docs/architecture.md), feeds each complete update to the ROS-free
:class:`gear_phm.prognostics.HealthMonitor`, publishes ``gear_phm/health/rul`` and
``gear_phm/health/efficiency`` per update and ``/diagnostics`` at ``rate`` Hz (one status
``gear_phm: <transmission_name>``). STALE is judged on this node's clock (``use_sim_time``
respected) against the arrival time of the last estimator message.

Recording (``record_path`` non-empty): a rosbag2 MCAP directory with every topic this node
publishes (and its inputs with ``record_inputs``). Messages are serialized in the callbacks
(``rclpy.serialization.serialize_message``) and handed to a writer thread through a queue;
only that thread touches the file. It flushes the open chunk at least every
``record_flush_period`` seconds, also when no message arrives, so after ``kill -9`` all data
older than that is recoverable with ``gear_phm.bagio.recover``. On SIGINT/SIGTERM rclpy's
signal handler stops spinning and ``destroy_node`` closes the bag (summary + metadata.yaml).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import fields, replace
import math
import queue
import threading
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3Stamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message

from gear_phm.bagio import Rosbag2McapWriter
from gear_phm.interfaces import (DIAGNOSTIC_ARRAY_TYPE, DIAGNOSTICS, HEALTH_EFFICIENCY, HEALTH_RUL,
                                 stamp_to_ns, VECTOR3_STAMPED_TYPE)
from gear_phm.nodes.common import ConfigError, declare, OUTPUT_QOS, run_node, to_rclpy
from gear_phm.prognostics import (cross_field_problem, HealthConfig, HealthStatus, PARAMETERS,
                                  waiting_status)
from gear_phm.prognostics.config import TRENDS
from gear_phm.prognostics.pipeline import HealthPipeline, INPUTS

#: Estimator outputs are reliable; a deeper queue absorbs bursts of a fast replay.
INPUT_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
HEALTH_FIELDS = tuple(f.name for f in fields(HealthConfig))
#: Node-only parameters: (default, description, low, high, read_only).
NODE_PARAMETERS: dict[str, tuple[Any, str, Any, Any, bool]] = {
    'transmission_name': ('gearbox', 'status name is "gear_phm: <transmission_name>"',
                          None, None, False),
    'hardware_id': ('gearbox', 'hardware_id of the /diagnostics status', None, None, False),
    'rate': (1.0, '/diagnostics publishing rate [Hz]', 0.01, 1000.0, True),
    'record_path': ('', 'rosbag2 MCAP directory to record to (empty: no recording); must '
                        'not exist or be empty', None, None, True),
    'record_inputs': (False, 'also record the five estimator input topics', None, None, True),
    'record_compression': ('', 'MCAP chunk compression: "" (none), zstd or lz4', None, None,
                           True),
    'record_flush_period': (0.5, 'the recording is flushed at least this often [s] (data '
                                 'older than this survives kill -9)', 0.01, 60.0, True),
}


def _flat(exc: BaseException) -> str:
    return ' '.join(str(exc).split())


class Recorder:
    """Writer thread around :class:`Rosbag2McapWriter`; ``put`` is safe from any thread."""

    def __init__(self, directory: str, topics: Sequence[tuple[str, str]], compression: str,
                 flush_period: float) -> None:
        self.writer = Rosbag2McapWriter(directory, compression=compression or None,
                                        flush_period_s=flush_period)
        for topic, msgtype in topics:
            self.writer.add_topic(topic, msgtype)
        self.flush_period = flush_period
        self.queue: queue.SimpleQueue[tuple[str, int, bytes] | None] = queue.SimpleQueue()
        self.error: str | None = None
        self.written = 0
        self._closed = False
        self._thread = threading.Thread(target=self._run, name='diagnostics-recorder',
                                        daemon=True)
        self._thread.start()

    def put(self, topic: str, t_ns: int, data: bytes) -> None:
        if not self._closed:
            self.queue.put((topic, t_ns, data))

    def _run(self) -> None:
        dirty = False
        while True:
            try:
                item = self.queue.get(timeout=self.flush_period / 2)
            except queue.Empty:
                if dirty and self.error is None:
                    self._guard(self.writer.flush)
                    dirty = False
                continue
            if item is None:
                return
            if self.error is None:
                self._guard(lambda: self.writer.write_raw(*item))
                self.written += 1
                dirty = True

    def _guard(self, action: Any) -> None:
        try:
            action()
        except (OSError, ValueError, KeyError) as exc:
            self.error = _flat(exc)

    def close(self) -> None:
        """Drain the queue, then write the summary, footer and metadata.yaml."""
        if self._closed:
            return
        self._closed = True
        self.queue.put(None)
        self._thread.join(timeout=30.0)
        self.writer.close()


class DiagnosticsNode(Node):
    """The diagnostics node; configuration errors at start raise ConfigError (one line)."""

    def __init__(self) -> None:
        super().__init__('diagnostics')
        values = self._declare_all()
        self.transmission_name: str = values['transmission_name']
        self.hardware_id: str = values['hardware_id']
        try:
            self.health_config = HealthConfig(**{k: values[k] for k in HEALTH_FIELDS})
        except ValueError as exc:
            raise ConfigError(f'invalid health parameters: {exc}') from None
        self.health = HealthPipeline(self.health_config, self.transmission_name,
                                     self.hardware_id)
        self.last_arrival_ns: int | None = None
        self.received = 0
        self.status_count = 0
        self.diag_pub = self.create_publisher(DiagnosticArray, DIAGNOSTICS, OUTPUT_QOS)
        self.rul_pub = self.create_publisher(Vector3Stamped, HEALTH_RUL, OUTPUT_QOS)
        self.eff_pub = self.create_publisher(Vector3Stamped, HEALTH_EFFICIENCY, OUTPUT_QOS)
        self.recorder: Recorder | None = None
        self._record_names: dict[str, str] = {}
        if values['record_path']:
            self._start_recorder(values)
        for topic in INPUTS:
            self.create_subscription(Vector3Stamped, topic,
                                     lambda msg, topic=topic: self._on_input(topic, msg),
                                     INPUT_QOS)
        self.add_on_set_parameters_callback(self._check_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self.create_timer(1.0 / values['rate'], self._publish_diagnostics)

    # -- parameters -------------------------------------------------------------------------
    def _declare_all(self) -> dict[str, Any]:
        specs = dict(NODE_PARAMETERS)
        defaults = HealthConfig()
        for name in HEALTH_FIELDS:
            default = getattr(defaults, name)
            if name in PARAMETERS:
                low, high, unit, description = PARAMETERS[name]
                specs[name] = (default, f'{description} [{unit}]', low, high, False)
            elif name == 'trend':
                specs[name] = (default, f'RUL trend model, one of {TRENDS}', None, None, False)
            else:
                specs[name] = (default, 'count the self-locking onset (eta_I <= 0, u >= 1) '
                                        'as end of life (ERROR)', None, None, False)
        values: dict[str, Any] = {}
        for name, (default, description, low, high, read_only) in specs.items():
            if isinstance(default, int) and not isinstance(default, bool):
                low, high = int(low), int(high)
            try:
                values[name] = declare(self, name, default, description, low=low, high=high,
                                       read_only=read_only)
            except ParameterException as exc:
                raise ConfigError(f'parameter {name}: {_flat(exc)}') from None
        if values['record_compression'] not in ('', 'zstd', 'lz4'):
            raise ConfigError('parameter record_compression must be "", zstd or lz4, got '
                              f'{values["record_compression"]!r}')
        return values

    def _check_parameters(self, params: Sequence[Any]) -> SetParametersResult:
        """On-set: types, choices and cross-field rules of the whole resulting config."""
        merged = self.health_config.as_dict()
        for param in params:
            if param.name in merged:
                merged[param.name] = param.value
        try:
            HealthConfig(**merged)
        except (ValueError, TypeError) as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        problem = cross_field_problem(merged)
        return SetParametersResult(successful=not problem, reason=problem)

    def _apply_parameters(self, params: Sequence[Any]) -> None:
        changed = {p.name: p.value for p in params if p.name in HEALTH_FIELDS}
        for param in params:
            if param.name == 'transmission_name':
                self.transmission_name = self.health.transmission_name = param.value
            elif param.name == 'hardware_id':
                self.hardware_id = self.health.hardware_id = param.value
        if changed:
            self.health_config = self.health_config.replace(**changed)
            self.health = HealthPipeline(self.health_config, self.transmission_name,
                                         self.hardware_id)
            self.get_logger().info(f'health parameters changed: {changed}; monitor restarted')

    # -- recording --------------------------------------------------------------------------
    def _start_recorder(self, values: dict[str, Any]) -> None:
        topics = [(self.diag_pub.topic_name, DIAGNOSTIC_ARRAY_TYPE),
                  (self.rul_pub.topic_name, VECTOR3_STAMPED_TYPE),
                  (self.eff_pub.topic_name, VECTOR3_STAMPED_TYPE)]
        self._record_names = {DIAGNOSTICS: topics[0][0], HEALTH_RUL: topics[1][0],
                              HEALTH_EFFICIENCY: topics[2][0]}
        if values['record_inputs']:
            for topic in INPUTS:
                name = self.resolve_topic_name(topic)
                self._record_names[topic] = name
                topics.append((name, VECTOR3_STAMPED_TYPE))
        try:
            self.recorder = Recorder(values['record_path'], topics,
                                     values['record_compression'],
                                     values['record_flush_period'])
        except (OSError, ValueError) as exc:
            raise ConfigError(f'cannot record to {values["record_path"]!r}: {_flat(exc)}') \
                from None
        self.get_logger().info(f'recording {len(topics)} topics to {values["record_path"]}')

    def _record(self, topic: str, msg: Any) -> None:
        name = self._record_names.get(topic)
        if self.recorder is not None and name is not None:
            self.recorder.put(name, self.get_clock().now().nanoseconds,
                              serialize_message(msg))

    def destroy_node(self) -> None:
        if self.recorder is not None:
            self.recorder.close()
            self.recorder = None
        super().destroy_node()

    # -- inputs -----------------------------------------------------------------------------
    def _on_input(self, topic: str, msg: Vector3Stamped) -> None:
        self.received += 1
        self.last_arrival_ns = self.get_clock().now().nanoseconds
        self._record(topic, msg)
        outputs = self.health.on_input(topic, stamp_to_ns(msg.header.stamp), msg.vector)
        for output in outputs:
            publisher = self.rul_pub if output.topic == HEALTH_RUL else self.eff_pub
            out_msg = to_rclpy(output)
            publisher.publish(out_msg)
            self._record(output.topic, out_msg)

    # -- /diagnostics -----------------------------------------------------------------------
    def current_status(self) -> HealthStatus:
        """Latest status, turned STALE when the last input is older than stale_timeout."""
        now_ns = self.get_clock().now().nanoseconds
        latest = self.health.latest
        if latest is None:
            return waiting_status(now_ns, self.health.monitor.u_eol)
        silence = math.inf if self.last_arrival_ns is None \
            else (now_ns - self.last_arrival_ns) * 1e-9
        if silence > self.health_config.stale_timeout:
            return latest.as_stale(silence)
        return latest

    def _publish_diagnostics(self) -> None:
        status = self.current_status()
        if self.health.dropped:
            drops = ', '.join(f'{k}={v}' for k, v in sorted(self.health.dropped.items()))
            status = replace(status, message=f'{status.message}; dropped {drops}')
        if self.recorder is not None and self.recorder.error is not None:
            status = replace(status, message=f'{status.message}; recording failed: '
                                             f'{self.recorder.error}')
        diagnostics, _, efficiency = status.outputs(self.transmission_name, self.hardware_id)
        msg = to_rclpy(diagnostics)
        self.diag_pub.publish(msg)
        self._record(DIAGNOSTICS, msg)
        self.status_count += 1
        if status.level == 3 and self.health.latest is not None:
            eff_msg = to_rclpy(efficiency)       # z = 3: numeric topic shows STALE too
            self.eff_pub.publish(eff_msg)
            self._record(HEALTH_EFFICIENCY, eff_msg)


def main(args: Sequence[str] | None = None) -> int:
    """Entry point (``ros2 run gear_phm diagnostics``); returns the exit status."""
    return run_node(DiagnosticsNode, args=args)


if __name__ == '__main__':
    raise SystemExit(main())
