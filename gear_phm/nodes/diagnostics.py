"""Diagnostics node: efficiency, remaining useful life and health level on /diagnostics.

``ros2 run gear_phm diagnostics``. Receives whole estimator updates (the live transport,
:mod:`gear_phm.nodes.transport`, reassembles the estimator's topics), feeds each to the ROS-free
:class:`gear_phm.prognostics.HealthAssessor`, publishes the health topics per update and
``/diagnostics`` at ``rate`` Hz (one status ``gear_phm: <transmission_name>``); the topics are
listed in docs/architecture.md. From start-up until the first input the status is OK "waiting
for data". STALE is judged on this node's clock (``use_sim_time`` respected) against the
arrival time of the last estimator message, and published at once when ``stale_timeout`` has
passed (a one-shot timer restarted by each arrival), not only at
the next status tick. The estimator publishes nothing about a sensor timeout, so only real
samples keep the input fresh. ``samples_missing`` comes from ``gear_phm/sample_loss``.

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
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message

from gear_phm.bagio import Rosbag2McapWriter
from gear_phm.interfaces import (DIAGNOSTIC_ARRAY_TYPE, DIAGNOSTICS, DiagnosticsOut,
                                 ESTIMATOR_TOPICS, HEALTH_EFFICIENCY, HEALTH_RUL, health_status,
                                 SAMPLE_LOSS, VECTOR3_STAMPED_TYPE)
from gear_phm.nodes.common import ConfigError, declare_parameters, OUTPUT_QOS, run_node, to_rclpy
from gear_phm.nodes.state import state_parameters, StateKeeper
from gear_phm.nodes.transport import EstimateAssembler, HealthPublisher
from gear_phm.parameters import (DIAGNOSTICS_RATE, HARDWARE_ID, ParamSpec,
                                 TRANSMISSION_NAME)
from gear_phm.prognostics import (HealthAssessor, HealthConfig, HealthState, PARAMETERS,
                                  waiting_state)
from gear_phm.status import STALE, WARN

#: Estimator outputs are reliable; a deeper queue absorbs bursts of a fast replay.
INPUT_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
HEALTH_FIELDS = tuple(f.name for f in fields(HealthConfig))
#: Parameters of the node itself (the health ones are :data:`gear_phm.prognostics.PARAMETERS`).
NODE_PARAMETERS: tuple[ParamSpec, ...] = (
    TRANSMISSION_NAME,
    HARDWARE_ID,
    DIAGNOSTICS_RATE,
    ParamSpec('record_path', '', 'rosbag2 MCAP directory to record to (empty: no recording); '
              'must not exist or be empty', read_only=True),
    ParamSpec('record_inputs', False, 'also record the six estimator input topics',
              read_only=True),
    ParamSpec('record_compression', '', 'MCAP chunk compression ("": none)',
              choices=('', 'zstd', 'lz4'), read_only=True),
    ParamSpec('record_flush_period', 0.5, 'the recording is flushed at least this often, so '
              'data older than this survives kill -9', 's', 0.01, 60.0, read_only=True),
    *state_parameters('the RUL history and fit, the level latches and the NIS window'),
)


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
        values = declare_parameters(self, PARAMETERS + NODE_PARAMETERS)
        self.transmission_name: str = values['transmission_name']
        self.hardware_id: str = values['hardware_id']
        try:
            self.health_config = HealthConfig(**{k: values[k] for k in HEALTH_FIELDS})
        except ValueError as exc:
            raise ConfigError(f'invalid health parameters: {exc}') from None
        self.assessor = HealthAssessor(self.health_config)
        self.state = StateKeeper(self, values, 'diagnostics', self._identity(),
                                 self._current_state)
        self.state.load(self.assessor.from_state)
        self.assembler = EstimateAssembler()
        self.last_arrival_ns: int | None = None
        self.received = 0
        self.status_count = 0
        self.diag_pub = self.create_publisher(DiagnosticArray, DIAGNOSTICS, OUTPUT_QOS)
        self.health_pub = HealthPublisher(self, self._record)
        self.recorder: Recorder | None = None
        self._record_names: dict[str, str] = {}
        if values['record_path']:
            self._start_recorder(values)
        self.samples_missing = 0          # from the estimator's gear_phm/sample_loss
        self._stale_published = False
        self.stale_timer = self._make_stale_timer()
        self.assembler.subscribe(self, INPUT_QOS, self._on_estimates, self._on_message)
        self.create_subscription(Vector3Stamped, SAMPLE_LOSS, self._on_sample_loss, INPUT_QOS)
        self.add_on_set_parameters_callback(self._check_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self.create_timer(1.0 / values['rate'], self._publish_diagnostics)
        self.state.start_timer()

    def _identity(self) -> dict[str, Any]:
        """Return what a state_file must match: the ratio (this node knows no joint names)."""
        return {'ratio': float(self.health_config.ratio)}

    def _current_state(self) -> tuple[dict[str, Any], int | None]:
        latest = self.assessor.latest
        return self.assessor.to_state(), None if latest is None else latest.stamp_ns

    def _make_stale_timer(self) -> Any:
        """One-shot: fires stale_timeout after the last arrival (restarted by each)."""
        timer = self.create_timer(self.health_config.stale_timeout, self._on_stale_timer)
        timer.cancel()
        return timer

    @property
    def dropped(self) -> dict[str, int]:
        """Unusable estimator inputs by reason."""
        return {**self.assembler.dropped, **self.assessor.rejected}

    # -- parameters -------------------------------------------------------------------------
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
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params: Sequence[Any]) -> None:
        changed = {p.name: p.value for p in params if p.name in HEALTH_FIELDS}
        for param in params:
            if param.name == 'transmission_name':
                self.transmission_name = param.value
            elif param.name == 'hardware_id':
                self.hardware_id = param.value
        if changed:
            self.health_config = self.health_config.replace(**changed)
            self.assessor = HealthAssessor(self.health_config)
            self.state.identity = self._identity()
            if 'stale_timeout' in changed:
                self.destroy_timer(self.stale_timer)
                self.stale_timer = self._make_stale_timer()
            self.get_logger().info(f'health parameters changed: {changed}; assessor restarted')

    # -- recording --------------------------------------------------------------------------
    def _start_recorder(self, values: dict[str, Any]) -> None:
        health_names = self.health_pub.topic_names()
        topics = [(self.diag_pub.topic_name, DIAGNOSTIC_ARRAY_TYPE),
                  (health_names[HEALTH_RUL], VECTOR3_STAMPED_TYPE),
                  (health_names[HEALTH_EFFICIENCY], VECTOR3_STAMPED_TYPE)]
        self._record_names = {DIAGNOSTICS: topics[0][0], HEALTH_RUL: topics[1][0],
                              HEALTH_EFFICIENCY: topics[2][0]}
        if values['record_inputs']:
            for topic in ESTIMATOR_TOPICS:
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
        """Save the state (SIGINT/SIGTERM pass here), close the recording, destroy."""
        self.state.save()
        if self.recorder is not None:
            self.recorder.close()
            self.recorder = None
        super().destroy_node()

    # -- inputs -----------------------------------------------------------------------------
    def _on_message(self, topic: str, msg: Any) -> None:
        self.received += 1
        self.last_arrival_ns = self.get_clock().now().nanoseconds
        self.stale_timer.reset()
        self._stale_published = False
        self._record(topic, msg)

    def _on_sample_loss(self, msg: Vector3Stamped) -> None:
        if math.isfinite(msg.vector.x) and msg.vector.x >= 0.0:
            self.samples_missing = int(msg.vector.x)

    def _on_stale_timer(self) -> None:
        self.stale_timer.cancel()
        self._publish_diagnostics()

    def _on_estimates(self, estimates: list[Any]) -> None:
        for estimate in estimates:
            state = self.assessor.on_estimate(estimate)
            if state is not None:
                self.health_pub.publish(state)

    # -- /diagnostics -----------------------------------------------------------------------
    def current_status(self) -> HealthState:
        """Latest state, turned STALE when the last input is older than stale_timeout.

        Before any input: OK "waiting for data" (nothing is known to be wrong). STALE only
        once input has been seen and has stopped.
        """
        now_ns = self.get_clock().now().nanoseconds
        latest = self.assessor.latest
        if self.last_arrival_ns is None:
            return latest if latest is not None else waiting_state(now_ns, self.assessor.u_eol)
        if latest is None:
            latest = waiting_state(now_ns, self.assessor.u_eol)
        silence = (now_ns - self.last_arrival_ns) * 1e-9
        if silence >= self.health_config.stale_timeout:
            return latest.as_stale(silence)
        return latest

    def _publish_diagnostics(self) -> None:
        state = self.current_status()
        if self.samples_missing > state.samples_missing:
            state = replace(state, samples_missing=self.samples_missing)
        dropped = self.dropped
        if dropped:
            drops = ', '.join(f'{k}={v}' for k, v in sorted(dropped.items()))
            state = replace(state, message=f'{state.message}; dropped {drops}')
        if self.recorder is not None and self.recorder.error is not None:
            state = replace(state, message=f'{state.message}; recording failed: '
                                           f'{self.recorder.error}')
        if self.state.problem:
            state = replace(state, level=max(state.level, WARN),
                            message=f'{state.message}; {self.state.problem}')
        status = health_status(state, self.transmission_name, self.hardware_id)
        msg = to_rclpy(DiagnosticsOut(state.stamp_ns, (status,)))
        self.diag_pub.publish(msg)
        self._record(DIAGNOSTICS, msg)
        self.status_count += 1
        if state.level == STALE and self.assessor.latest is not None \
                and not self._stale_published and self.last_arrival_ns is not None:
            # z = 3 shows STALE too, once per outage, stamped with the last estimate's stamp
            # plus the silence (an output about no input carries no input's stamp)
            self._stale_published = True
            silence_ns = max(self.get_clock().now().nanoseconds - self.last_arrival_ns, 1)
            self.health_pub.publish(replace(state, stamp_ns=state.stamp_ns + silence_ns),
                                    efficiency_only=True)


def main(args: Sequence[str] | None = None) -> int:
    """Entry point (``ros2 run gear_phm diagnostics``); returns the exit status."""
    return run_node(DiagnosticsNode, args=args)


if __name__ == '__main__':
    raise SystemExit(main())
