"""``ros2 run gear_phm estimator``: the friction estimator node.

A thin adapter over :class:`gear_phm.estimation.EstimatorPipeline`.

Takes JointState in and publishes each :class:`~gear_phm.estimation.FrictionEstimate` through
the live transport (:mod:`gear_phm.nodes.transport`; topics in docs/architecture.md), stamped
with the sample time, plus its own ``/diagnostics`` status
``gear_phm estimator: <node name>`` with drop counters by reason and the samples missing.
A bad message is dropped and counted, never fatal. Parameters: config/estimator.yaml.

The per-message path is as short as rclpy allows: JointState arrives serialized (``raw``
subscription, no Python message object), its stamp, speeds and torques are read with one
``struct`` call (:class:`~gear_phm.codec.JointStateDecoder`) and appended to a
buffer. The buffer is processed as one vectorised batch when an output is due: its stamp
crosses the publish_rate grid, or the sample closes an energy window (power-flow phase change,
window length, gap); otherwise ``batch_period`` after its first sample, or at 200 samples.
So the batch cost is paid about publish_rate times a second whatever the input rate, and
outputs leave as soon as their sample arrives. Timers run only while samples flow: idle, the
node wakes only for its status.

Parameters: a parameter set at run time (``ros2 param set``) applies live and keeps what was
learned (:meth:`~gear_phm.estimation.EstimatorPipeline.reconfigure`); the structural ones
(ratio, joints, effort signs, motor_inertia, ``transmissions``, state file, executor and
periods) are read-only and refused with rclpy's reason. Learning is reset only on purpose: the
``~/reset`` service (``std_srvs/srv/Trigger``; per drive ``~/<drive>/reset`` with many) logs
a line and counts in the status key ``resets``; the state file is written at once.

A managed node (:mod:`gear_phm.nodes.lifecycle`; ``autostart`` true by default): configure
validates the parameters and loads the state file, activate subscribes, deactivate publishes
what the buffer gives and saves. ``load_torque_topic`` takes the load torque from a
``geometry_msgs/WrenchStamped`` matched by stamp (:mod:`gear_phm.estimation.load_torque`).

With the ``transmissions`` parameter non-empty the node serves many drives in one stream
(:mod:`gear_phm.nodes.estimator_drives`; parameters :mod:`gear_phm.nodes.drives`); empty (the
default), it is the single transmission above, unchanged.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import fields, replace
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
import numpy as np
from rcl_interfaces.msg import SetParametersResult
from rclpy.validate_full_topic_name import validate_full_topic_name

from gear_phm import interfaces
from gear_phm.codec import JointStateDecoder
from gear_phm.estimation import EstimatorConfig, EstimatorPipeline, PARAMETERS
from gear_phm.estimation.load_torque import LoadTorqueMatcher
from gear_phm.estimation.powerflow import classify_sample
from gear_phm.interfaces import DiagnosticsOut
from gear_phm.nodes.common import (ConfigError, declare_parameters, OUTPUT_QOS, qualified,
                                   reset_service, RESETS, run_node, SENSOR_QOS, to_rclpy)
from gear_phm.nodes.drives import declare_drives, declare_transmissions, refuse_changes
from gear_phm.nodes.estimator_drives import DrivesEstimator
from gear_phm.nodes.executors import executor_parameter, spin_executor
from gear_phm.nodes.lifecycle import AUTOSTART, ManagedNode
from gear_phm.nodes.state import estimator_identity, state_parameters, StateKeeper
from gear_phm.nodes.transport import (EstimatePublisher, JointNames, OUTPUTS_MATCHED,
                                      SampleLossPublisher, subscribe_joint_states_raw)
from gear_phm.parameters import LOAD_JOINT, MOTOR_JOINT, ParamSpec
from gear_phm.run import DriveEstimator, DriveNames

#: Parameters of the node itself (the estimator's are :data:`gear_phm.estimation.PARAMETERS`).
NODE_PARAMETERS: tuple[ParamSpec, ...] = (
    MOTOR_JOINT,
    LOAD_JOINT,
    ParamSpec('frame_id', '', 'frame_id written in the output headers'),
    ParamSpec('hardware_id', 'gearbox', "hardware_id of the estimator's /diagnostics status: "
              "the drive's name (the diagnostics node's default transmission_name is the same "
              "'gearbox'); with transmissions each drive's name"),
    ParamSpec('diagnostics_period', 1.0, '/diagnostics status period', 's', 0.01, 3600.0,
              read_only=True),
    ParamSpec('batch_period', 0.1, 'buffered samples are processed at the latest this long '
              'after the first of them arrived (at once when an output is due, or at 200 '
              'samples); outputs are stamped with sample time', 's', 0.0001, 10.0,
              read_only=True),
    ParamSpec('load_torque_topic', '', 'geometry_msgs/WrenchStamped topic of a force/torque '
              'sensor on the output whose torque is the load torque, matched to each JointState '
              "by stamp (the load joint's effort is then ignored); empty: the JointState "
              'effort. One transmission only', read_only=True),
    ParamSpec('load_torque_axis', 'z', 'axis of the wrench torque that is the load torque',
              choices=('x', 'y', 'z'), read_only=True),
    ParamSpec('load_torque_sign', 1, '+1: the wrench torque along the axis is the load '
              'effort (load_effort_sign then applies as to an effort); -1: its opposite', '-',
              -1, 1, read_only=True),
    ParamSpec('load_torque_tolerance', 0.001, 'a sample takes the wrench of the nearest stamp '
              'within this (0: the same stamp only); a sample without one is dropped '
              '(dropped_no_load_torque)', 's', 0.0, 1.0, read_only=True),
    executor_parameter(),
    AUTOSTART,
    *state_parameters('the filter state, its adaptation, counters, operating time and '
                      'open energy window'),
)
CONFIG_FIELDS = tuple(f.name for f in fields(EstimatorConfig))
#: A buffer this long is processed at once.
MAX_BUFFER = 200


def config_from_values(values: dict[str, Any]) -> EstimatorConfig:
    """Build an EstimatorConfig from parameter values; ValueError with the reason."""
    return EstimatorConfig(**{name: values[name] for name in CONFIG_FIELDS if name in values})


def state_identity(values: dict[str, Any]) -> dict[str, Any]:
    """Return what a state_file must match: the ratio and the joint names."""
    return estimator_identity(values['ratio'], values['motor_joint'], values['load_joint'])


def joint_names_problem(values: dict[str, Any]) -> str:
    """'' or why motor_joint/load_joint are unusable."""
    if not values['motor_joint'] or values['motor_joint'] == values['load_joint']:
        return (f'motor_joint and load_joint must be two different non-empty names, got '
                f'{values["motor_joint"]!r} and {values["load_joint"]!r}')
    return ''


class EstimatorNode(ManagedNode):
    """Friction estimator; a parameter set at run time keeps what was learned (module doc).

    A managed node (:mod:`gear_phm.nodes.lifecycle`): the parameters are declared here,
    :meth:`configure` validates them and builds the pipeline; ``autostart`` does both now.
    """

    def __init__(self) -> None:
        super().__init__('estimator')
        self.names = declare_transmissions(self)
        self.values = declare_parameters(self, PARAMETERS + NODE_PARAMETERS)
        self.drive_specs = declare_drives(self, self.names, PARAMETERS, self.values) \
            if self.names else ()
        self.drives: DrivesEstimator | None = None
        if self.values['autostart']:
            self.autostart()

    def configure(self) -> None:
        """Validate the parameters, load the state file, make outputs, timers and services.

        Raises ConfigError naming the problem. The subscription is made at activate.
        """
        values = self.values = {name: self.get_parameter(name).value for name in self.values}
        if self.drive_specs:        # many drives: gear_phm.nodes.estimator_drives
            if values['load_torque_topic']:
                msg = 'parameter load_torque_topic: one transmission only (transmissions is set)'
                raise ConfigError(msg)
            first = self.drive_specs[0]
            _warm_up(first.estimator_config(), first.motor_joint, first.load_joint)
            self.drives = DrivesEstimator(self, self.drive_specs, values)
            self.add_on_set_parameters_callback(refuse_changes)
            return
        problem = joint_names_problem(values)
        try:
            if problem:
                raise ValueError(problem)
            self.config = config_from_values(values)
        except ValueError as exc:
            raise ConfigError(f'estimator parameters: {exc}') from None
        self.load_torque = self._load_torque_matcher(values)
        self.run = DriveEstimator(self.config, DriveNames.single(
            estimator_status=f'gear_phm estimator: {qualified(self, self.get_name())}'))
        self.pipeline = self.run.pipeline
        self.state = StateKeeper(self, values, 'estimator', state_identity(values),
                                 self._current_state)
        self.state.load(self.pipeline.from_state)
        self.outputs = EstimatePublisher(self, values['frame_id'],
                                         no_load=self.pipeline.config.no_load_model)
        self.loss_outputs = SampleLossPublisher(self, values['frame_id'])
        self.diag_pub = self.create_publisher(DiagnosticArray, interfaces.DIAGNOSTICS,
                                              OUTPUT_QOS)
        _warm_up(self.config, values['motor_joint'], values['load_joint'])
        self.messages_received = 0
        self.stamps: list[int] = []               # the buffer: stamps [ns] ...
        self.rows: list[tuple[float, float, float, float]] = []   # ... w_m, tau_m, w_l, tau_l
        self.batch_period: float = values['batch_period']
        self.decoder = JointStateDecoder(values['motor_joint'], values['load_joint'])
        self.joint_names = JointNames()           # of messages without the joints
        self._due: int | None = None              # stamp from which an output is due [ns]
        self._set_window_watch()
        self.last_batch_ns: int | None = None     # node clock at the newest batch [ns]
        # one-shot timers, restarted by samples: the buffer's tail, the sensor timeout
        self.batch_timer = self.create_timer(self.batch_period, self._on_batch_timer)
        self.batch_timer.cancel()
        self.watchdog = self._make_watchdog()
        self.create_timer(values['diagnostics_period'], self._on_diagnostics_timer)
        subscribe_joint_states_raw(self, self._on_message)
        if self.load_torque is not None:
            self.create_subscription(WrenchStamped, values['load_torque_topic'], self._on_wrench,
                                     SENSOR_QOS)
        self.add_on_set_parameters_callback(self._check_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        reset_service(self, '~/reset', self._reset)
        self.state.start_timer(self._save_state)

    def _load_torque_matcher(self, values: dict[str, Any]) -> LoadTorqueMatcher | None:
        """Return the wrench matcher of ``load_torque_topic`` (None: none); raises ConfigError."""
        topic = values['load_torque_topic']
        self.unmatched = 0              # samples without a wrench within the tolerance
        self._wrenches_seen = 0         # wrenches received at the last flush
        if not topic:
            return None
        if values['load_torque_sign'] not in (-1, 1):
            msg = f'load_torque_sign must be 1 or -1, got {values["load_torque_sign"]!r}'
            raise ConfigError(msg)
        try:
            validate_full_topic_name(self.resolve_topic_name(topic))
        except Exception as exc:  # rclpy's InvalidTopicNameException and others
            msg = f'parameter load_torque_topic: {" ".join(str(exc).split())}'
            raise ConfigError(msg) from None
        self._axis = values['load_torque_axis']
        self._torque_sign = float(values['load_torque_sign'])
        return LoadTorqueMatcher(int(round(values['load_torque_tolerance'] * 1e9)),
                                 int(self.config.sensor_timeout * 1e9))

    def _on_wrench(self, msg: WrenchStamped) -> None:
        """Keep one load torque for the samples of its stamp (gear_phm.estimation.load_torque)."""
        if self.load_torque is not None:
            stamp = msg.header.stamp
            self.load_torque.add(stamp.sec * 10**9 + stamp.nanosec,
                                 self._torque_sign * getattr(msg.wrench.torque, self._axis))

    def activating(self) -> None:
        """Log the one line that says the node is ready."""
        joints = ', '.join(f'{d.name}: {d.motor_joint}/{d.load_joint}'
                           for d in self.drive_specs) or \
            f'{self.values["motor_joint"]}/{self.values["load_joint"]}'
        where = f'state file {self.values["state_file"]}' if self.values['state_file'] \
            else 'no state file'
        self.get_logger().info(f'ready: estimating from {self.resolve_topic_name("joint_states")}'
                               f' (motor/load joints {joints}), {where}')

    def deactivating(self) -> None:
        """Publish what the buffer gives, save the state file."""
        if self.drives is not None:
            self.drives.flush()
            self.drives.state.save()
            return
        self._save_state()

    def cleaning_up(self) -> None:
        """Save the state once more and forget the pipeline (back to unconfigured)."""
        if self.drives is not None:
            self.drives.close()
            self.drives = None
        else:
            self.state.save()

    def _current_state(self) -> tuple[dict[str, Any], int | None]:
        """Return the pipeline's state and its newest stamp (for a save)."""
        state = self.pipeline.to_state()
        return state, state['last_stamp']

    def _save_state(self) -> None:
        """Timer: publish what the buffer gives, then save."""
        self._flush()
        self.state.save()

    def destroy_node(self) -> None:
        """Process the buffer without publishing, save the state, then destroy.

        Nothing is published because the context may be shut down. SIGINT/SIGTERM and normal exits
        pass here.
        """
        if not self.configured:
            super().destroy_node()
            return
        if self.drives is not None:
            self.drives.close()
            super().destroy_node()
            return
        if self.state.enabled and self.stamps:
            stamps, rows = self.stamps, self.rows
            self.stamps, self.rows = [], []
            if self.load_torque is not None:
                matched = self.load_torque.match(stamps, rows, final=True)
                stamps, rows = matched.stamps, matched.rows
            try:
                columns = np.array(rows, dtype=float).reshape(-1, 4).T
                self.pipeline.on_batch(np.array(stamps, dtype=np.int64), *columns)
            except ValueError:
                pass
        self.state.save()
        super().destroy_node()

    def _set_window_watch(self) -> None:
        """Thresholds of the per-sample guess of when an energy window closes."""
        c = self.config
        self._speed_threshold, self._power_threshold = c.speed_threshold, c.power_threshold
        # the powers' signs as the pipeline reads them (motor_effort_sign, load_effort_sign)
        self._motor_sign, self._load_sign = float(c.motor_effort_sign), -float(c.load_effort_sign)
        self._window_ns = int(c.window * 1e9)
        self._min_window_ns = int(c.min_window * 1e9)
        self._gap_ns = int(c.sensor_timeout * 1e9)
        self._grid_pending = c.publish_rate > 0.0    # outputs due before the grid is known
        self._code = 0                  # power-flow code of the previous sample
        self._prev_stamp = 0            # its stamp [ns]
        self._window_start = 0          # stamp where the current window (guess) began [ns]

    def _make_watchdog(self) -> Any:
        timer = self.create_timer(self.config.sensor_timeout, self._on_watchdog)
        timer.cancel()
        return timer

    # --- callbacks -----------------------------------------------------------------------------
    def _on_message(self, raw: bytes) -> None:
        """One serialized JointState: decode and buffer it.

        Process the buffer when an output is due.
        """
        try:
            sample = self.decoder.decode(raw)
        except Exception:  # never die on data; count it
            sample = 'bad_message'
        if isinstance(sample, str):
            self.messages_received += 1
            self.pipeline.reject_message(sample)
            if sample in ('missing_joint', 'short_arrays'):
                self.joint_names.note(raw, (0,), (len(raw),))
            return
        stamp, w_m, tau_m, w_l, tau_l = sample
        self.stamps.append(stamp)
        self.rows.append((w_m, tau_m, w_l, tau_l))
        # the power-flow code, as estimation.powerflow.classify (NaN gives idle)
        code = classify_sample(self._motor_sign * tau_m * w_m, self._load_sign * tau_l * w_l,
                               w_m, self._power_threshold, self._speed_threshold)
        due = False
        previous = self._prev_stamp
        if code != self._code or not 0 < stamp - previous <= self._gap_ns:
            # a window of the previous phase, if long enough to be used, closes here
            due = self._code > 0 and previous - self._window_start >= self._min_window_ns
            self._code, self._window_start = code, stamp
        elif code > 0 and stamp - self._window_start >= self._window_ns:
            due, self._window_start = True, stamp       # a window reached its length
        self._prev_stamp = stamp
        output = self._due
        if output is None:              # no grid yet (first samples): it starts with them
            due = due or self._grid_pending
        elif stamp >= output:
            due = True
        if due or len(self.stamps) >= MAX_BUFFER:
            self._flush()
        elif len(self.stamps) == 1:
            self.batch_timer.reset()

    def _on_batch_timer(self) -> None:
        """Process the buffer's tail; with a wrench topic, decide what no new wrench can."""
        matcher = self.load_torque
        final = matcher is not None and matcher.received == self._wrenches_seen
        self._flush(final)

    def _flush(self, final: bool = False) -> None:
        """Process the buffered samples as one batch and publish what is due.

        Same results as one by one. With ``load_torque_topic`` the samples whose wrench may
        still come stay buffered; ``final`` (no wrench came for a batch_period): they are
        decided with the wrenches at hand.
        """
        self.batch_timer.cancel()
        stamps = self.stamps
        if not stamps:
            return
        rows = self.rows
        self.stamps, self.rows = [], []
        if self.load_torque is not None:
            matched = self.load_torque.match(stamps, rows, final)
            self._wrenches_seen = self.load_torque.received
            self.stamps, self.rows = matched.pending_stamps, matched.pending_rows
            self.messages_received += matched.dropped
            self.unmatched += matched.dropped
            if self.stamps:
                self.batch_timer.reset()        # again once their wrenches may have come
            stamps, rows = matched.stamps, matched.rows
            if not stamps:
                return
        self.messages_received += len(stamps)
        self.last_batch_ns = self.get_clock().now().nanoseconds
        self.watchdog.reset()           # one-shot: fires after sensor_timeout without a batch
        pipeline = self.pipeline
        try:
            columns = np.array(rows, dtype=float).reshape(-1, 4).T
            outputs = pipeline.on_batch(np.array(stamps, dtype=np.int64), *columns)
        except Exception as exc:  # never die on data; count it
            pipeline.reject_message('bad_message', len(stamps))
            self.get_logger().warn(f'dropped {len(stamps)} joint_states sample(s): {exc}',
                                   throttle_duration_sec=5.0)
            return
        self.outputs.publish(outputs)
        self._due = pipeline.next_output_stamp()

    def _on_watchdog(self) -> None:
        """No batch for sensor_timeout (node clock): flag the sensor timeout once.

        Then stop until samples flow again (each batch restarts this timer). Publishes nothing.
        """
        if self.last_batch_ns is None:
            return
        silence_s = (self.get_clock().now().nanoseconds - self.last_batch_ns) * 1e-9
        if silence_s > self.config.sensor_timeout:
            self.pipeline.on_silence(silence_s)
            self.watchdog.cancel()

    def _on_diagnostics_timer(self) -> None:
        now = self.get_clock().now().nanoseconds
        self._flush()
        status = self.state.flagged(self.joint_names.status(
            self.run.status(self.messages_received),
            self.pipeline.samples_seen, self.values['motor_joint'], self.values['load_joint']))
        status = replace(status, hardware_id=self.values['hardware_id'], values=status.values + (
            (OUTPUTS_MATCHED, str(self.outputs.matched())), (RESETS, str(self.run.resets))) + (
            (('dropped_no_load_torque', str(self.unmatched)),) if self.load_torque else ()))
        self.diag_pub.publish(to_rclpy(DiagnosticsOut(now, (status,))))
        self.loss_outputs.publish(self.pipeline)

    def _check_parameters(self, params: Sequence[Any]) -> SetParametersResult:
        """On-set: the whole resulting configuration must be valid (else the reason).

        The read-only (structural) parameters never get here: rclpy refuses them first.
        """
        try:
            config_from_values({**self.values, **{p.name: p.value for p in params}})
        except ValueError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params: Sequence[Any]) -> None:
        """Post-set: apply the new values live; the learned state is kept (reconfigure)."""
        self._flush()
        self.values = {**self.values, **{p.name: p.value for p in params}}
        self.outputs.frame_id = self.loss_outputs.frame_id = self.values['frame_id']
        config = config_from_values(self.values)
        if config != self.config:
            timeout_changed = config.sensor_timeout != self.config.sensor_timeout
            self.pipeline.reconfigure(config)
            self.config = config
            self._set_window_watch()
            self._due = self.pipeline.next_output_stamp()       # a new publish_rate's grid
            if timeout_changed:
                self.destroy_timer(self.watchdog)
                self.watchdog = self._make_watchdog()
        names = ', '.join(f'{p.name}={p.value!r}' for p in params)
        self.get_logger().info(f'parameters set: {names}; the learned state is kept')

    def _reset(self) -> str:
        """``~/reset``: forget what was learned, save the state file at once."""
        self._flush()
        self.run.reset()
        self._set_window_watch()
        self._due = None
        self.state.save()
        c = self.config
        return (f'learning reset ({self.run.resets} since start): u back to the prior '
                f'{c.initial_u:g} (sigma {c.initial_u_sigma:g})')


def _spin(node: EstimatorNode) -> None:
    spin_executor(node, node.values['executor'])


def _warm_up(config: EstimatorConfig, motor_joint: str, load_joint: str) -> None:
    """Run a throw-away pipeline over 4 s of simulated samples before subscribing.

    The samples are serialized and decoded as the node does.

    The first window close, filter update and numpy/LAPACK calls cost ~100 ms once; paid
    while the queue is filling, that stall dropped live samples at 1 kHz.
    """
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    from gear_phm.simulation import SimulationConfig, simulate
    t = np.arange(4000) / 1000.0
    run = simulate(SimulationConfig(), t)     # any plant exercises the code paths
    pipeline = EstimatorPipeline(config)
    stamps = (t * 1e9).astype(np.int64) + 1_000_000_000
    raws = []
    for i in range(0, t.size, 400):
        msg = JointState(name=[motor_joint, load_joint])
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(stamps[i]), 10 ** 9)
        msg.velocity = [float(run.velocity_motor[i]), float(run.velocity_load[i])]
        msg.effort = [float(run.effort_motor[i]), float(run.effort_load[i])]
        raws.append(serialize_message(msg))
    decoder = JointStateDecoder(motor_joint, load_joint)
    for raw in raws:
        decoder.decode(raw)
    # batches of 5 samples for the first 0.2 s (the node's small batches), then of 200 (its
    # largest): the same code paths at a seventh of the cost (0.38 -> 0.05 s of CPU per start)
    edges = [*range(0, 200, 5), *range(200, t.size + 200, 200)]
    for first, end in zip(edges, edges[1:]):
        part = slice(first, end)
        pipeline.on_batch(stamps[part], run.velocity_motor[part], run.effort_motor[part],
                          run.velocity_load[part], run.effort_load[part])
        pipeline.next_output_stamp()
    pipeline.status('warm-up', 0)


def main(args: Sequence[str] | None = None) -> int:
    """Entry point of ``ros2 run gear_phm estimator``."""
    return run_node(EstimatorNode, args, spin=_spin)


if __name__ == '__main__':
    raise SystemExit(main())
