"""``ros2 run gear_phm publisher``: simulate a wearing transmission, or replay a recorded bag.

mode ``simulate``: the seeded plant of :mod:`gear_phm.simulation` at ``rate`` [Hz] on
``joint_states`` plus the truth on ``gear_phm/truth/friction`` and ``gear_phm/truth/efficiency``.
mode ``replay``: the JointState topic of a rosbag2 (MCAP, sqlite3) or ROS1 bag, paced by its
log times divided by ``rate_factor``; optionally ``/clock`` and the bag's truth topics.

Everything is validated before spinning: a bad parameter or bag prints one line on stderr and
exits 2. Publishing runs in a dedicated thread that sleeps to each message's scheduled
monotonic time; the lateness of every publish (actual - scheduled) is reported as jitter
percentiles on /diagnostics. See docs/publisher.md.
"""
from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
import math
from pathlib import Path
import threading
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3Stamped
import numpy as np
from rcl_interfaces.msg import SetParametersResult
import rclpy
from rclpy.duration import Duration
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from gear_phm.bagio import BagError, BagReader
from gear_phm.interfaces import (CLOCK, decode_joint_states, DIAGNOSTICS, JOINT_STATE_TYPE,
                                 JOINT_STATES, OK, TRUTH_EFFICIENCY, TRUTH_FRICTION,
                                 VECTOR3_STAMPED_TYPE, WARN)
from gear_phm.nodes.common import (ConfigError, declare, DropCounter, OUTPUT_QOS, run_node, stamp,
                                   status_msg)
from gear_phm.simulation import config_from_parameters, PARAMETERS, SimulationConfig, Simulator

MODES = ('simulate', 'replay')
#: Samples generated per simulation chunk [s of simulated time].
SIM_CHUNK_S = 0.5
#: Jitter samples kept for the percentiles.
JITTER_WINDOW = 100_000


#: Node-only parameters: (name, default, description, low, high); the simulation ones
#: come from gear_phm.simulation.PARAMETERS.
NODE_PARAMETERS: tuple[tuple[str, Any, str, float | None, float | None], ...] = (
    ('mode', 'simulate', 'simulate | replay', None, None),
    ('motor_joint', 'motor', 'name of the motor joint in JointState', None, None),
    ('load_joint', 'load', 'name of the load joint in JointState', None, None),
    ('rate', 100.0, 'simulate: sample rate [Hz]', 1e-3, 10000.0),
    ('duration', 0.0, 'simulate: run length [s]; 0 runs until shut down', 0.0, None),
    ('bag_path', '', 'replay: rosbag2 directory, .mcap/.db3 in one, or ROS1 .bag',
     None, None),
    ('topic', '', 'replay: JointState topic in the bag; empty = auto-detect', None,
     None),
    ('remap', '', 'output topic of the joint states; empty = joint_states', None, None),
    ('rate_factor', 1.0, 'replay: speed-up of the bag time [-], > 0', 1e-3, 1000.0),
    ('loop', False, 'replay: start again at the end', None, None),
    ('start_offset', 0.0, 'replay: skip this much of the bag start [s]', 0.0, None),
    ('publish_clock', False, 'replay: publish /clock with the message stamps', None,
     None),
    ('restamp', False, 'replay: stamp messages with the node clock (start time + '
                       'scaled bag time) instead of the bag stamps', None, None),
    ('replay_truth', True, 'replay: also replay gear_phm/truth/* topics if present',
     None, None),
    ('wait_for_subscribers', 1, 'wait for this many joint_states subscribers before '
                                'the first message', 0, 1000),
    ('wait_timeout', 10.0, 'give up waiting for subscribers after this long and '
                           'start anyway [s]; 0 waits forever', 0.0, None),
)


class JitterStats:
    """Lateness of each publish, actual - scheduled [s], over the last JITTER_WINDOW sends."""

    def __init__(self) -> None:
        self._late: deque[float] = deque(maxlen=JITTER_WINDOW)

    def add(self, lateness_s: float) -> None:
        self._late.append(lateness_s)

    def percentiles(self) -> tuple[float, float, float]:
        """(p50, p99, max) lateness [s]; NaN before the first publish."""
        if not self._late:
            return math.nan, math.nan, math.nan
        late = np.fromiter(self._late, dtype=float)
        return (float(np.percentile(late, 50)), float(np.percentile(late, 99)),
                float(late.max()))

    def __len__(self) -> int:
        return len(self._late)


@dataclass
class ReplayMessage:
    """One bag message to publish: output topic key, log time [ns], CDR payload."""

    kind: str        # 'joint_states' | 'truth_friction' | 'truth_efficiency'
    t_ns: int
    raw: bytes


def _flat(exc: BaseException) -> str:
    return ' '.join(str(exc).split()) or type(exc).__name__


class PublisherNode(Node):
    """The publisher node; all checks happen in __init__ (ConfigError with one line)."""

    def __init__(self) -> None:
        super().__init__('publisher')
        self.pre_dropped: dict[str, int] = {}
        self.topic = ''
        p = self._declare_all()
        self.mode: str = p['mode']
        self.motor_joint: str = p['motor_joint']
        self.load_joint: str = p['load_joint']
        self.wait_for_subscribers: int = p['wait_for_subscribers']
        self.wait_timeout: float = p['wait_timeout']
        self.loop: bool = p['loop']
        self.publish_clock: bool = p['publish_clock']
        self.restamp: bool = p['restamp']
        self.rate_factor: float = p['rate_factor']
        self.params = p
        if self.motor_joint == self.load_joint or not self.motor_joint or not self.load_joint:
            raise ConfigError(f'motor_joint and load_joint must be two different non-empty '
                              f'names, got {self.motor_joint!r} and {self.load_joint!r}')
        self.sim_config: SimulationConfig | None = None
        self.replay: list[ReplayMessage] = []
        if self.mode == 'simulate':
            self._setup_simulation(p)
        else:
            self._setup_replay(p)
        output = p['remap'] or JOINT_STATES
        self.joint_pub = self.create_publisher(JointState, output, OUTPUT_QOS)
        self.truth_pubs = {
            'truth_friction': self.create_publisher(Vector3Stamped, TRUTH_FRICTION, OUTPUT_QOS),
            'truth_efficiency': self.create_publisher(Vector3Stamped, TRUTH_EFFICIENCY,
                                                      OUTPUT_QOS),
        }
        self.clock_pub = self.create_publisher(
            Clock, CLOCK, QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)) \
            if self.publish_clock else None
        self.diag_pub = self.create_publisher(DiagnosticArray, DIAGNOSTICS, OUTPUT_QOS)
        self.add_on_set_parameters_callback(self._refuse_changes)
        self.counter = DropCounter()
        self.published = 0
        self.loops = 0
        self.jitter = JitterStats()
        self.state = 'starting'
        self.finished = threading.Event()
        self.error: str | None = None
        self.wait_timed_out = False
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run_worker, name='publisher-pacing',
                                        daemon=True)
        self.create_timer(1.0, self._publish_diagnostics)

    # -- parameters -------------------------------------------------------------------------
    def _declare_all(self) -> dict[str, Any]:
        specs = list(NODE_PARAMETERS)
        for name, (default, description, low, high) in PARAMETERS.items():
            specs.append((name, default, 'simulate: ' + description, low, high))
        values: dict[str, Any] = {}
        for name, default, description, low, high in specs:
            try:
                values[name] = declare(self, name, default, description, low=low, high=high,
                                       read_only=True)
            except ParameterException as exc:
                raise ConfigError(f'parameter {name}: {_flat(exc)}') from None
        if values['mode'] not in MODES:
            raise ConfigError(f'parameter mode must be simulate or replay, got '
                              f'{values["mode"]!r}')
        return values

    def _refuse_changes(self, params: Sequence[Any]) -> SetParametersResult:
        names = ', '.join(p.name for p in params)
        return SetParametersResult(successful=False,
                                   reason=f'{names}: read at start only; restart the node')

    # -- set-up -----------------------------------------------------------------------------
    def _setup_simulation(self, p: dict[str, Any]) -> None:
        try:
            self.sim_config = config_from_parameters({n: p[n] for n in PARAMETERS})
        except ValueError as exc:
            raise ConfigError(f'parameter {_flat(exc)}') from None
        if p['duration'] > 0.0:
            friction = float(self.sim_config.wear.value(p['duration']))
            _, eta_d, _ = self.sim_config.plant.efficiencies(friction)
            if not float(eta_d) > 0.0:
                raise ConfigError(f'parameter duration: friction {friction:.4g} at '
                                  f'{p["duration"]:g} s gives eta_D <= 0 (gearbox jams)')

    def _setup_replay(self, p: dict[str, Any]) -> None:
        if not p['bag_path']:
            raise ConfigError('parameter bag_path is empty: replay needs a bag')
        path = Path(p['bag_path']).expanduser()
        try:
            with BagReader(path) as bag:
                topic = self._pick_topic(bag, p['topic'])
                wanted = {topic: 'joint_states'}
                if p['replay_truth']:
                    for truth, kind in ((TRUTH_FRICTION, 'truth_friction'),
                                        (TRUTH_EFFICIENCY, 'truth_efficiency')):
                        name = bag.resolve_topic(truth)
                        if bag.topics.get(name) == VECTOR3_STAMPED_TYPE:
                            wanted[name] = kind
                start_ns = bag.start_ns + int(round(p['start_offset'] * 1e9))
                if p['start_offset'] > 0 and start_ns > bag.end_ns:
                    raise ConfigError(
                        f'parameter start_offset {p["start_offset"]:g} s is beyond the end '
                        f'of bag {path} ({(bag.end_ns - bag.start_ns) * 1e-9:.3f} s long)')
                messages = [ReplayMessage(wanted[t], t_ns, raw) for t, t_ns, raw
                            in bag.raw_messages(list(wanted), start_ns=start_ns)]
        except BagError as exc:
            raise ConfigError(_flat(exc)) from None
        joints = [m for m in messages if m.kind == 'joint_states']
        if not joints:
            raise ConfigError(f'topic {topic} of bag {path} has no message after start_offset '
                              f'{p["start_offset"]:g} s')
        self.replay = self._check_joints(messages, joints, topic, path)
        self.topic = topic

    def _pick_topic(self, bag: BagReader, topic: str) -> str:
        if topic:
            return bag.require_topic(topic, JOINT_STATE_TYPE)
        candidates = bag.topics_of_type(JOINT_STATE_TYPE)
        if not candidates:
            raise BagError(f'bag {bag.path} has no {JOINT_STATE_TYPE} topic (topics: '
                           f'{", ".join(f"{t} [{k}]" for t, k in sorted(bag.topics.items()))})')
        if len(candidates) == 1:
            return candidates[0]
        for preferred in ('/' + JOINT_STATES, JOINT_STATES):
            if preferred in candidates:
                return preferred
        raise BagError(f'bag {bag.path} has several {JOINT_STATE_TYPE} topics '
                       f'({", ".join(candidates)}): set parameter topic')

    def _check_joints(self, messages: list[ReplayMessage], joints: list[ReplayMessage],
                      topic: str, path: Path) -> list[ReplayMessage]:
        """Drop JointState messages without both joints; ConfigError if none has them."""
        batch = decode_joint_states([m.raw for m in joints], self.motor_joint, self.load_joint)
        if len(batch) == len(joints):
            return messages
        if len(batch) == 0:
            first = deserialize_message(joints[0].raw, JointState)
            raise ConfigError(
                f'joints {self.motor_joint!r} and {self.load_joint!r} (parameters motor_joint, '
                f'load_joint) are not in the messages of {topic} in bag {path}: '
                f'names are {list(first.name)} ({", ".join(sorted(batch.rejected))})')
        kept = []
        for message in messages:
            if message.kind == 'joint_states' and not len(decode_joint_states(
                    [message.raw], self.motor_joint, self.load_joint)):
                continue
            kept.append(message)
        self.pre_dropped = dict(batch.rejected)
        return kept

    # -- running ----------------------------------------------------------------------------
    def start(self) -> None:
        for reason, count in self.pre_dropped.items():
            self.counter.dropped[reason] += count
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)

    def _run_worker(self) -> None:
        try:
            self._wait_for_subscribers()
            if self._stop.is_set():
                return
            self.state = 'running'
            if self.mode == 'simulate':
                self._simulate()
            else:
                self._replay()
            self._flush()
            self.state = 'done'
        except Exception as exc:  # noqa: BLE001 reported by the main thread, exit non-zero
            self.error = f'{type(exc).__name__}: {_flat(exc)}'
            self.state = 'failed'
        finally:
            self.finished.set()

    def _wait_for_subscribers(self) -> None:
        needed = self.wait_for_subscribers
        if needed <= 0:
            return
        self.state = 'waiting for subscribers'
        deadline = time.monotonic() + self.wait_timeout if self.wait_timeout > 0 else math.inf
        while self.joint_pub.get_subscription_count() < needed and not self._stop.is_set():
            if time.monotonic() >= deadline:
                self.get_logger().warning(
                    f'only {self.joint_pub.get_subscription_count()} of {needed} subscriber(s) '
                    f'after {self.wait_timeout:g} s (wait_timeout); starting anyway')
                self.wait_timed_out = True
                return
            time.sleep(0.01)

    def _sleep_until(self, when: float) -> bool:
        """Sleep until monotonic time ``when``; False if asked to stop."""
        while True:
            remaining = when - time.monotonic()
            if remaining <= 0.0:
                return not self._stop.is_set()
            if remaining > 0.05:    # long waits: stay responsive to stop()
                if self._stop.wait(remaining - 0.05):
                    return False
            else:                   # last stretch: clock_nanosleep is the most precise
                time.sleep(remaining)

    def _send(self, publisher: Any, payload: Any, scheduled: float) -> None:
        """Publish and record the lateness of the call (monotonic now - scheduled) [s]."""
        self.jitter.add(time.monotonic() - scheduled)
        publisher.publish(payload)

    def _simulate(self) -> None:
        assert self.sim_config is not None
        simulator = Simulator(self.sim_config)
        rate = float(self.params['rate'])
        duration = float(self.params['duration'])
        total = int(math.floor(duration * rate + 1e-9)) if duration > 0 else None
        names = [self.motor_joint, self.load_joint]
        wall0 = time.monotonic()
        stamp0 = self.get_clock().now().nanoseconds
        chunk = max(1, int(round(SIM_CHUNK_S * rate)))
        index = 0
        while total is None or index < total:
            count = chunk if total is None else min(chunk, total - index)
            k = np.arange(index, index + count)
            result = simulator.sample(k / rate)
            for i in range(count):
                scheduled = wall0 + (index + i) / rate
                t_ns = stamp0 + int(round((index + i) * 1e9 / rate))
                msg = JointState()
                msg.header.stamp = stamp(t_ns)
                msg.name = names
                msg.position = [float(result.position_motor[i]), float(result.position_load[i])]
                msg.velocity = [float(result.velocity_motor[i]), float(result.velocity_load[i])]
                msg.effort = [float(result.effort_motor[i]), float(result.effort_load[i])]
                friction = _vector(t_ns, result.u[i], result.friction[i], 0.0)
                efficiency = _vector(t_ns, result.eta_opposing[i], result.eta_aiding[i], 0.0)
                if not self._sleep_until(scheduled):
                    return
                self._send(self.joint_pub, msg, scheduled)
                self.truth_pubs['truth_friction'].publish(friction)
                self.truth_pubs['truth_efficiency'].publish(efficiency)
                self.counter.received += 1
                self.published += 1
            index += count

    def _replay(self) -> None:
        first_ns = self.replay[0].t_ns
        last_ns = self.replay[-1].t_ns
        gaps = np.diff([m.t_ns for m in self.replay if m.kind == 'joint_states'])
        period_ns = int(np.median(gaps)) if len(gaps) else 0
        loop_ns = last_ns - first_ns + period_ns          # bag time of one pass
        wall0 = time.monotonic()
        stamp0 = self.get_clock().now().nanoseconds
        while True:
            offset_ns = self.loops * loop_ns
            for message in self.replay:
                bag_elapsed = (message.t_ns - first_ns + offset_ns) / self.rate_factor
                scheduled = wall0 + bag_elapsed * 1e-9
                if not self._sleep_until(scheduled):
                    return
                self._publish_replayed(message, stamp0 + int(round(bag_elapsed)), scheduled)
            self.loops += 1
            if not self.loop:
                return

    def _publish_replayed(self, message: ReplayMessage, new_stamp_ns: int,
                          scheduled: float) -> None:
        self.counter.received += 1
        publisher = self.joint_pub if message.kind == 'joint_states' \
            else self.truth_pubs[message.kind]
        if self.restamp:
            msg = deserialize_message(message.raw, publisher.msg_type)
            msg.header.stamp = stamp(new_stamp_ns)
            payload: Any = msg
            clock_ns = new_stamp_ns
        else:
            payload = message.raw
            clock_ns = message.t_ns
        if message.kind == 'joint_states':
            if self.clock_pub is not None:
                self.clock_pub.publish(Clock(clock=stamp(clock_ns)))
            self._send(publisher, payload, scheduled)
            self.published += 1
        else:
            publisher.publish(payload)

    def _flush(self) -> None:
        """Wait until reliable subscribers acknowledged everything (bounded)."""
        for publisher in (self.joint_pub, *self.truth_pubs.values()):
            publisher.wait_for_all_acked(Duration(seconds=5.0))

    # -- diagnostics --------------------------------------------------------------------------
    def _publish_diagnostics(self) -> None:
        p50, p99, worst = self.jitter.percentiles()
        healthy = self.counter.dropped_total == 0 and self.error is None \
            and not self.wait_timed_out
        level = OK if healthy else WARN
        extra = [('mode', self.mode), ('state', self.state),
                 ('messages_published', self.published), ('loops', self.loops),
                 ('jitter_p50_ms', p50 * 1e3), ('jitter_p99_ms', p99 * 1e3),
                 ('jitter_max_ms', worst * 1e3),
                 ('subscribers', self.joint_pub.get_subscription_count())]
        if self.mode == 'replay':
            extra += [('bag', str(self.params['bag_path'])), ('topic', self.topic),
                      ('rate_factor', self.rate_factor)]
        else:
            extra += [('rate_hz', self.params['rate'])]
        status = self.counter.status(f'gear_phm publisher: {self.get_name()}',
                                     self.mode, level, self.error or self.state, extra)
        msg = DiagnosticArray()
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.status = [status_msg(status)]
        self.diag_pub.publish(msg)


def _vector(t_ns: int, x: float, y: float, z: float) -> Vector3Stamped:
    msg = Vector3Stamped()
    msg.header.stamp = stamp(t_ns)
    msg.vector.x, msg.vector.y, msg.vector.z = float(x), float(y), float(z)
    return msg


def _spin(node: PublisherNode) -> None:
    node.start()
    try:
        while rclpy.ok() and not node.finished.is_set():
            rclpy.spin_once(node, timeout_sec=0.1)
    finally:
        node.stop()
    if node.finished.is_set():
        node._publish_diagnostics()
        p50, p99, worst = node.jitter.percentiles()
        node.get_logger().info(
            f'{node.state}: published {node.published} messages, jitter p50 '
            f'{p50 * 1e3:.3f} ms, p99 {p99 * 1e3:.3f} ms, max {worst * 1e3:.3f} ms')
    if node.error is not None:
        raise ConfigError(f'publisher stopped: {node.error}')


def main(args: Sequence[str] | None = None) -> int:
    """Entry point (``ros2 run gear_phm publisher``); returns the exit status."""
    return run_node(PublisherNode, args=args, spin=_spin)


if __name__ == '__main__':
    raise SystemExit(main())
