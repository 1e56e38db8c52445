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

Parameters: a health parameter set at run time (``ros2 param set``) applies live and keeps
what was learned (:meth:`~gear_phm.prognostics.HealthAssessor.reconfigure`: the RUL history,
the level latches, the learned healthy efficiency); the structural ones (ratio,
``transmissions``, state file, recording, rate, executor) are read-only. Learning is reset
only on purpose: ``~/reset`` (``std_srvs/srv/Trigger``; with many drives also
``~/<drive>/reset``) logs a line, counts in the status key ``resets`` (after the health keys)
and writes the state file at once.

A managed node (:mod:`gear_phm.nodes.lifecycle`; ``autostart`` true by default): inactive it
publishes nothing, /diagnostics included (as nav2); deactivate saves the state file and
finishes the recording's file (a complete bag), a later activate records into the next file.
The /diagnostics header stamp is this node's clock; a failed recording is ERROR.

Recording (``record_path`` non-empty): a rosbag2 MCAP directory with every topic this node
publishes (and its inputs with ``record_inputs``). Messages are serialized in the callbacks
(``rclpy.serialization.serialize_message``) and handed to a writer thread through a queue;
only that thread touches the file. It flushes the open chunk at least every
``record_flush_period`` seconds, also when no message arrives, so after ``kill -9`` all data
older than that is recoverable with ``gear_phm.bagio.recover``. On SIGINT/SIGTERM the spin
loop ends (``gear_phm.nodes.common.stop_signals``) and ``destroy_node``, in the main thread,
closes the bag (summary + metadata.yaml).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import fields, replace
from functools import partial
import math
import queue
import threading
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3Stamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message

from gear_phm.interfaces import (DIAGNOSTIC_ARRAY_TYPE, DIAGNOSTICS, DiagnosticsOut,
                                 ESTIMATOR_TOPICS, SAMPLE_LOSS,
                                 VECTOR3_STAMPED_TYPE)
from gear_phm.nodes.common import (ConfigError, declare_parameters, OUTPUT_QOS, qualified,
                                   reset_service, RESETS, run_node, to_rclpy)
from gear_phm.nodes.drives import declare_drives, declare_transmissions, refuse_changes
from gear_phm.nodes.executors import executor_parameter, spin_executor
from gear_phm.nodes.lifecycle import AUTOSTART, ManagedNode
from gear_phm.nodes.state import (DRIVES_IDENTITY, drives_restorer, drives_state,
                                  state_parameters, StateKeeper)
from gear_phm.nodes.transport import EstimateAssembler, HealthPublisher
from gear_phm.parameters import (DIAGNOSTICS_RATE, HARDWARE_ID, ParamSpec,
                                 TRANSMISSION_NAME)
from gear_phm.prognostics import (HealthAssessor, HealthConfig, HealthState, PARAMETERS,
                                  waiting_state)
from gear_phm.run import DriveHealth, DriveNames
from gear_phm.status import ERROR, STALE, StatusOut, WARN

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
    ParamSpec('record_inputs', False, 'also record the seven estimator input topics',
              read_only=True),
    ParamSpec('record_compression', '', 'MCAP chunk compression ("": none)',
              choices=('', 'zstd', 'lz4'), read_only=True),
    ParamSpec('record_flush_period', 0.5, 'the recording is flushed at least this often, so '
              'data older than this survives kill -9', 's', 0.01, 60.0, read_only=True),
    *state_parameters('the RUL history and fit, the level latches and the NIS window'),
    executor_parameter('single'),
    AUTOSTART,
)


def _flat(exc: BaseException) -> str:
    return ' '.join(str(exc).split())


def silent_among_others(silence: float, timeout: float, others_silence: float,
                        behind: Callable[[], float]) -> bool:
    """Whether a drive of many is WARN for silence while the other drives have input.

    ``silence`` [s]: since its last input; ``others_silence`` [s]: since the other drives'
    last; ``behind()`` [s]: how far its newest input stamp is behind theirs. WARN while the
    others' input is fresh (within a quarter of ``timeout``) and the drive is silent for 3/4
    of ``timeout``, or for half of it with its stamp a quarter of it behind the others'
    (wall-clock silence alone also grows when a loaded executor serves a drive late). Below
    ``timeout`` only: then STALE. Under a load that slows the estimates below one per quarter
    of ``timeout``, a drive can go from OK to STALE with no WARN between.
    """
    if silence >= timeout or silence < timeout / 2 or not others_silence < timeout / 4:
        return False
    return silence >= 0.75 * timeout or behind() >= timeout / 4


class Recorder:
    """Writer thread around :class:`Rosbag2McapWriter`; ``put`` is safe from any thread."""

    def __init__(self, directory: str, topics: Sequence[tuple[str, str]], compression: str,
                 flush_period: float) -> None:
        # imported here: gear_phm.bagio (rosbags' type store) costs a node that does not
        # record about 0.15 s of CPU at every start
        from gear_phm.bagio import Rosbag2McapWriter
        self.writer = Rosbag2McapWriter(directory, compression=compression or None,
                                        flush_period_s=flush_period)
        for topic, msgtype in topics:
            self.writer.add_topic(topic, msgtype)
        self.flush_period = flush_period
        self.queue: queue.SimpleQueue[tuple[str, int, bytes] | threading.Event | None] = \
            queue.SimpleQueue()
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
            if isinstance(item, threading.Event):     # finish_file()
                if self.error is None:
                    self._guard(self.writer.finish_file)
                dirty = False
                item.set()
                continue
            if self.error is None:
                self._guard(lambda: self.writer.write_raw(*item))
                self.written += 1
                dirty = True

    def _guard(self, action: Any) -> None:
        try:
            action()
        except (OSError, ValueError, KeyError) as exc:
            self.error = _flat(exc)

    def finish_file(self, timeout: float = 30.0) -> bool:
        """Write what is queued, then finish the file (the bag is complete); wait for it.

        The next message starts the bag's next file. Returns whether it was done in time.
        """
        if self._closed:
            return True
        done = threading.Event()
        self.queue.put(done)
        return done.wait(timeout)

    def close(self) -> None:
        """Drain the queue, then write the summary, footer and metadata.yaml."""
        if self._closed:
            return
        self._closed = True
        self.queue.put(None)
        self._thread.join(timeout=30.0)
        self.writer.close()


class Channel:
    """One drive's health run (:class:`~gear_phm.run.DriveHealth`) with its ROS ends.

    Its estimator inputs, health topics and status, named by the run's
    :class:`~gear_phm.run.DriveNames`: the single transmission's are today's topics, a drive
    of ``transmissions`` has topics ``gear_phm/<drive>/...`` and status ``gear_phm: <drive>``.
    """

    def __init__(self, node: DiagnosticsNode, run: DriveHealth) -> None:
        self.node = node
        self.run = run
        self.assembler = EstimateAssembler()
        self.last_arrival_ns: int | None = None
        self.samples_missing = 0          # from the estimator's gear_phm/sample_loss
        self._stale_published = False
        topics = run.names.topic
        self.health_pub = HealthPublisher(node, node._record, topics)
        self.stale_timer = self._make_stale_timer()
        self.assembler.subscribe(node, INPUT_QOS, self._on_estimates, self._on_message, topics)
        node.create_subscription(Vector3Stamped, topics(SAMPLE_LOSS),
                                 self._on_sample_loss, INPUT_QOS)

    @property
    def assessor(self) -> HealthAssessor:
        """Return the run's assessor."""
        return self.run.assessor

    def _make_stale_timer(self) -> Any:
        """One-shot: fires stale_timeout after the last arrival (restarted by each)."""
        timer = self.node.create_timer(self.run.config.stale_timeout, self._on_stale_timer)
        timer.cancel()
        return timer

    def reconfigure(self, changed: dict[str, Any]) -> None:
        """Apply new health parameters; the assessor keeps what it learned."""
        self.run.reconfigure(changed)
        if 'stale_timeout' in changed:
            self.node.destroy_timer(self.stale_timer)
            self.stale_timer = self._make_stale_timer()

    @property
    def dropped(self) -> dict[str, int]:
        """Unusable estimator inputs by reason."""
        return {**self.assembler.dropped, **self.assessor.rejected}

    def _on_message(self, topic: str, msg: Any) -> None:
        node = self.node
        node.received += 1
        self.last_arrival_ns = node.last_arrival_ns = node.get_clock().now().nanoseconds
        self.stale_timer.reset()
        self._stale_published = False
        node._record(topic, msg)

    def _on_sample_loss(self, msg: Vector3Stamped) -> None:
        if math.isfinite(msg.vector.x) and msg.vector.x >= 0.0:
            self.samples_missing = int(msg.vector.x)

    def _on_stale_timer(self) -> None:
        self.stale_timer.cancel()
        self.node._publish_diagnostics()

    def _on_estimates(self, estimates: list[Any]) -> None:
        for estimate in estimates:
            state = self.assessor.on_estimate(estimate)
            if state is not None:
                self.health_pub.publish(state)

    def current_status(self, now_ns: int) -> HealthState:
        """Latest state, turned STALE when the last input is older than stale_timeout.

        Before any input: OK "waiting for data" (nothing is known to be wrong). STALE only
        once input has been seen and has stopped. A drive of many is WARN first while another
        drive's input still arrives: once silent for 3/4 of its stale_timeout, or for half
        of it with its newest stamp a quarter of it behind the other drives'.
        """
        latest = self.assessor.latest
        if self.last_arrival_ns is None:
            return latest if latest is not None else waiting_state(now_ns, self.assessor.u_eol)
        if latest is None:
            latest = waiting_state(now_ns, self.assessor.u_eol)
        silence = (now_ns - self.last_arrival_ns) * 1e-9
        timeout = self.run.config.stale_timeout
        if silence >= timeout:
            return latest.as_stale(silence)
        others = self.node.last_arrival_ns
        if len(self.node.channels) > 1 and others is not None and silent_among_others(
                silence, timeout, (now_ns - others) * 1e-9, self._behind_others):
            return replace(latest, level=max(latest.level, WARN),
                           message=f'no estimator input for {silence:.3g} s while other '
                                   f'drives have input (last: {latest.message})')
        return latest

    def _behind_others(self) -> float:
        """How far [s] this drive's newest input stamp is behind the other drives' newest.

        The drives' estimates come from one JointState stream, so their stamps advance
        together; only a drive whose own input stopped falls behind in stamp time. Wall-clock
        silence alone also grew when a loaded executor served one drive's callbacks late
        (a healthy drive of eight went WARN under load 9 on 2 cores).
        """
        own = self.assessor.latest
        newest = max((c.assessor.latest.stamp_ns for c in self.node.channels
                      if c is not self and c.assessor.latest is not None), default=None)
        if own is None or newest is None:
            return math.inf if newest is not None else 0.0
        return (newest - own.stamp_ns) * 1e-9

    def status(self, now_ns: int, problems: Sequence[tuple[int, str]]
               ) -> tuple[StatusOut, HealthState]:
        """Return this transmission's DiagnosticStatus and the state behind it.

        ``problems``: the node's (level, text) (recording, state file).
        """
        state = self.current_status(now_ns)
        if self.samples_missing > state.samples_missing:
            state = replace(state, samples_missing=self.samples_missing)
        dropped = self.dropped
        if dropped:
            drops = ', '.join(f'{k}={v}' for k, v in sorted(dropped.items()))
            state = replace(state, message=f'{state.message}; dropped {drops}')
        for level, problem in problems:
            state = replace(state, level=max(state.level, level),
                            message=f'{state.message}; {problem}')
        status = self.run.status_of(state)
        return replace(status, values=status.values + ((RESETS, str(self.run.resets)),)), state

    def mark_stale(self, state: HealthState) -> None:
        """After a STALE status: the STALE marker on the health topic, once per outage."""
        if state.level == STALE and self.assessor.latest is not None \
                and not self._stale_published and self.last_arrival_ns is not None:
            # z = 3 shows STALE too, once per outage, stamped with the last estimate's stamp
            # plus the silence (an output about no input carries no input's stamp)
            self._stale_published = True
            silence_ns = max(self.node.get_clock().now().nanoseconds - self.last_arrival_ns,
                             1)
            self.health_pub.publish(replace(state, stamp_ns=state.stamp_ns + silence_ns),
                                    efficiency_only=True)


class DiagnosticsNode(ManagedNode):
    """The diagnostics node; configuration errors at configure raise ConfigError (one line).

    ``transmissions`` non-empty: one :class:`Channel` per drive (parameters
    ``<drive>.<health parameter>``, default the global one; read-only), one status per drive
    in each /diagnostics array; else one channel of the global parameters. A managed node
    (:mod:`gear_phm.nodes.lifecycle`): the parameters are declared here, :meth:`configure`
    builds the rest; ``autostart`` does it now.
    """

    def __init__(self) -> None:
        super().__init__('diagnostics')
        self.names = declare_transmissions(self)
        self.values = declare_parameters(self, PARAMETERS + NODE_PARAMETERS)
        self.drive_specs = declare_drives(self, self.names, PARAMETERS, self.values) \
            if self.names else ()
        self.executor_kind = str(self.values['executor'])
        self.recorder: Recorder | None = None
        if self.values['autostart']:
            self.autostart()

    def configure(self) -> None:
        """Validate the parameters, load the state file, open the recording, make outputs.

        Raises ConfigError naming the problem. The subscriptions are made at activate.
        """
        values = self.values = {name: self.get_parameter(name).value for name in self.values}
        names = self.names
        self.received = 0
        self.status_count = 0
        self.last_arrival_ns: int | None = None   # of any channel's input
        self._record_names: dict[str, str] = {}
        self.diag_pub = self.create_publisher(DiagnosticArray, DIAGNOSTICS, OUTPUT_QOS)
        if names:
            drives = self.drive_specs
            self.channels = [Channel(self, DriveHealth(drive.health_config(), replace(
                DriveNames.of(drive.name), transmission_name=qualified(self, drive.name))))
                             for drive in drives]
            identities = {d.name: {'ratio': d.ratio, 'motor_joint': d.motor_joint,
                                   'load_joint': d.load_joint} for d in drives}
            self.state = StateKeeper(self, values, 'diagnostics', DRIVES_IDENTITY,
                                     self._current_state)
            self.state.load(drives_restorer(self.state, identities, {
                channel.run.names.drive: channel.assessor.from_state
                for channel in self.channels}))
            self._identities = identities
            self.add_on_set_parameters_callback(refuse_changes)
        else:
            try:
                config = HealthConfig(**{k: values[k] for k in HEALTH_FIELDS})
            except ValueError as exc:
                raise ConfigError(f'invalid health parameters: {exc}') from None
            single = DriveNames.single(qualified(self, values['transmission_name']),
                                       values['hardware_id'] or values['transmission_name'])
            self.channels = [Channel(self, DriveHealth(config, single))]
            run = self.channels[0].run
            self.state = StateKeeper(self, values, 'diagnostics', run.identity(),
                                     run.current_state)
            self.state.load(self.channels[0].assessor.from_state)
            self.add_on_set_parameters_callback(self._check_parameters)
            self.add_post_set_parameters_callback(self._apply_parameters)
        if values['record_path'] and self.recorder is None:
            self._start_recorder(values)
        for channel in self.channels:        # a drive of transmissions: a reset of its own
            if channel.run.names.listed:
                reset_service(self, f'~/{channel.run.names.drive}/reset',
                              partial(self._reset, [channel]))
        reset_service(self, '~/reset', partial(self._reset, self.channels))
        self.create_timer(1.0 / values['rate'], self._publish_diagnostics)
        self.state.start_timer()

    def activating(self) -> None:
        """Log the one line that says the node is ready."""
        names = ', '.join(c.run.names.transmission_name for c in self.channels)
        recording = f'recording to {self.values["record_path"]}' if self.recorder is not None \
            else 'not recording'
        self.get_logger().info(f'ready: assessing {names} from the estimator topics, '
                               f'/diagnostics at {self.values["rate"]:g} Hz, {recording}')

    def deactivating(self) -> None:
        """Save the state file, finish the recording's file (a complete bag)."""
        self.state.save()
        if self.recorder is not None and not self.recorder.finish_file():
            self.get_logger().error('the recording did not finish its file within 30 s')

    def cleaning_up(self) -> None:
        """Save the state once more (back to unconfigured; the recording stays open)."""
        self.state.save()

    def _current_state(self) -> tuple[dict[str, Any], int | None]:
        parts = {}
        for channel in self.channels:
            state, stamp_ns = channel.run.current_state()
            drive = channel.run.names.drive
            parts[drive] = (self._identities[drive], state, stamp_ns)
        return drives_state(parts)

    def _reset(self, channels: list[Channel]) -> str:
        """Forget what ``channels`` learned (a reset service); save the state file at once."""
        for channel in channels:
            channel.run.reset()
        self.state.save()
        names = ', '.join(channel.run.names.transmission_name for channel in channels)
        return f'learning reset of {names}: RUL history, levels and healthy efficiency'

    # -- parameters (one transmission; with transmissions they are read-only) ----------------
    def _check_parameters(self, params: Sequence[Any]) -> SetParametersResult:
        """On-set: types, choices and cross-field rules of the whole resulting config."""
        merged: dict[str, Any] = self.channels[0].run.config.as_dict()
        for param in params:
            if param.name in merged:
                merged[param.name] = param.value
        try:
            HealthConfig(**merged)
        except (ValueError, TypeError) as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params: Sequence[Any]) -> None:
        channel = self.channels[0]
        changed = {p.name: p.value for p in params if p.name in HEALTH_FIELDS}
        renamed = {p.name: p.value for p in params
                   if p.name in ('transmission_name', 'hardware_id')}
        if renamed:
            channel.run.names = replace(channel.run.names, **renamed)
        if changed:
            channel.reconfigure(changed)
            self.state.identity = channel.run.identity()
            self.get_logger().info(f'health parameters set: {changed}; the learned state is '
                                   f'kept')

    # -- recording --------------------------------------------------------------------------
    def _start_recorder(self, values: dict[str, Any]) -> None:
        topics = [(self.diag_pub.topic_name, DIAGNOSTIC_ARRAY_TYPE)]
        self._record_names = {DIAGNOSTICS: topics[0][0]}
        for channel in self.channels:
            for topic, name in channel.health_pub.topic_names().items():
                self._record_names[topic] = name
                topics.append((name, VECTOR3_STAMPED_TYPE))
            if values['record_inputs']:
                for topic in ESTIMATOR_TOPICS:
                    topic = channel.run.names.topic(topic)
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
        if self.configured:
            self.state.save()
        if self.recorder is not None:
            self.recorder.close()
            self.recorder = None
        super().destroy_node()

    # -- /diagnostics -----------------------------------------------------------------------
    def _publish_diagnostics(self) -> None:
        now_ns = self.get_clock().now().nanoseconds
        problems = []
        if self.recorder is not None and self.recorder.error is not None:
            problems.append((ERROR, f'recording failed: {self.recorder.error}'))
        if self.state.problem:
            problems.append((WARN, self.state.problem))
        statuses = [channel.status(now_ns, problems) for channel in self.channels]
        msg = to_rclpy(DiagnosticsOut(now_ns, tuple(status for status, _ in statuses)))
        self.diag_pub.publish(msg)
        self._record(DIAGNOSTICS, msg)
        self.status_count += 1
        for channel, (_, state) in zip(self.channels, statuses):
            channel.mark_stale(state)


def main(args: Sequence[str] | None = None) -> int:
    """Entry point (``ros2 run gear_phm diagnostics``); returns the exit status."""
    return run_node(DiagnosticsNode, args=args,
                    spin=lambda node: spin_executor(node, node.executor_kind))


if __name__ == '__main__':
    raise SystemExit(main())
