"""Test side of the live pipeline over DDS (needs rclpy).

A JointState driver node that also collects /diagnostics statuses and the output topics, and
paced publishing.
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
import sys
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticArray  # noqa: I100
from geometry_msgs.msg import Vector3Stamped
from rclpy.executors import Executor
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

from gear_phm.interfaces import (ESTIMATOR_TOPICS, HEALTH_EFFICIENCY, HEALTH_RUL, SAMPLE_LOSS,
                                 stamp_to_ns)
from helpers.processes import spawn, stop

#: Outputs and /diagnostics: reliable, deep enough for a burst.
RELIABLE = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
#: The output topics a driver logs unless told fewer.
OUTPUTS = (*ESTIMATOR_TOPICS, SAMPLE_LOSS, HEALTH_RUL, HEALTH_EFFICIENCY)


def _events_executor() -> Executor:
    """Return rclpy's EventsExecutor, made with the process's own stderr as ``sys.stderr``.

    Making one calls ``faulthandler.enable()``, which needs a file descriptor: pytest's
    ``--capture=sys`` puts an in-memory file there instead.
    """
    stderr, sys.stderr = sys.stderr, sys.__stderr__
    try:
        return EventsExecutor()
    finally:
        sys.stderr = stderr


class Driver:
    """Test-side node: JointState publisher, estimator/diagnostics status and output log.

    It logs the output topics ``outputs`` (default all of them). Each message received costs
    the test process a callback: a test that reads only some of them names those. The node
    spins in an executor of its own, kept for the driver's life (``rclpy.spin_once`` adds the
    node to the global executor and removes it at every call, and each change wakes the wait):
    rclpy's EventsExecutor, as the estimator node's, whose C++ dispatch costs a callback less
    CPU than the SingleThreadedExecutor's wait set rebuilt in Python at every call (test
    CPU of test_direction_offset_live 3.9 -> 1.2 s).
    """

    def __init__(self, name: str, outputs: tuple[str, ...] = OUTPUTS) -> None:
        rclpy.init()
        self.node = Node(name)
        self.executor = _events_executor()
        self.executor.add_node(self.node)
        self.statuses: dict[str, list[dict[str, str]]] = {}
        # diagnostics node: (monotonic arrival, level, message)
        self.levels: list[tuple[float, bytes, str]] = []
        self.stamps: dict[str, list[int]] = {}
        self.messages: dict[str, list[Vector3Stamped]] = {}
        self.arrived: dict[str, float] = {}          # topic -> monotonic time of the newest
        #: More callbacks of each /diagnostics array, after the driver's own (one subscription:
        #: a second one would take and convert every array again).
        self.on_diagnostics: list[Callable[[DiagnosticArray], None]] = []
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diag, RELIABLE)
        for topic in outputs:
            self.stamps[topic] = []
            self.messages[topic] = []
            self.node.create_subscription(
                Vector3Stamped, topic,
                lambda m, topic=topic: (self.stamps[topic].append(stamp_to_ns(m.header.stamp)),
                                        self.messages[topic].append(m),
                                        self.arrived.__setitem__(topic, time.monotonic())),
                RELIABLE)
        self.pub = self.node.create_publisher(JointState, 'joint_states',
                                              qos_profile_sensor_data)

    def _on_diag(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            values = {kv.key: kv.value for kv in status.values}
            values['_level'] = status.level
            values['_message'] = status.message
            values['_stamp_ns'] = str(stamp_to_ns(msg.header.stamp))   # the node's clock
            self.statuses.setdefault(status.name.split(':')[0], []).append(values)
            if status.name.startswith('gear_phm: '):
                self.levels.append((time.monotonic(), status.level, status.message))
        for callback in self.on_diagnostics:
            callback(msg)

    def latest(self, prefix: str) -> dict[str, str]:
        return self.statuses.get(prefix, [{}])[-1]

    def spin_once(self, timeout: float) -> None:
        """Run one ready callback, waiting up to ``timeout`` [s] for one."""
        self.executor.spin_once(timeout_sec=timeout)

    def spin(self, seconds: float = 0.0) -> None:
        end = time.monotonic() + seconds
        while True:
            self.spin_once(0.01)
            if time.monotonic() >= end:
                return

    def wait(self, condition, deadline: float, what: str) -> None:
        end = time.monotonic() + deadline
        while time.monotonic() < end:
            if condition():
                return
            self.spin(0.02)
        raise AssertionError(f'timed out waiting for {what}')

    def settle(self, prefix: str) -> dict[str, str]:
        """Return the node's status once its received count was the same in three statuses.

        All three were published after this call (node clock, same machine): statuses still
        queued from the input phase, which a busy node can send with an unchanging count, do
        not count.
        """
        since = time.time_ns()

        def still() -> bool:
            recent = [s for s in self.statuses.get(prefix, [])
                      if int(s.get('_stamp_ns', 0)) >= since][-3:]
            counts = [s.get('messages_received') for s in recent]
            return len(counts) == 3 and len(set(counts)) == 1
        self.wait(still, 60.0, f'{prefix} to settle')
        return self.latest(prefix)

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown()


def joint_state(stamp_ns: int, w_m: float, tau_m: float, w_l: float,
                tau_l: float) -> JointState:
    msg = JointState(name=['motor', 'load'])
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(stamp_ns), 10 ** 9)
    msg.velocity = [float(w_m), float(w_l)]
    msg.effort = [float(tau_m), float(tau_l)]
    return msg


def _sleep_until(target: float) -> None:
    """Sleep until ``time.perf_counter()`` reaches ``target`` [s] (at once if it has)."""
    left = target - time.perf_counter()
    if left > 0:
        time.sleep(left)


def publish_paced(driver: Driver, messages: list[JointState], rate: float,
                  spin_every: int = 500) -> None:
    """Publish at ``rate`` [Hz] of wall time: message i at ``i / rate`` s after the first.

    Each waits in a sleep, not spinning: parallel tests share the cores (a busy-wait for the
    last 0.2 ms cost 0.14 ms of CPU per message). A sleep that overshoots delays one message,
    not the schedule. The driver spins once every ``spin_every`` messages.
    """
    start = time.perf_counter()
    for i, msg in enumerate(messages):
        _sleep_until(start + i / rate)
        driver.pub.publish(msg)
        if i % spin_every == spin_every - 1:
            driver.spin_once(0.0)


def messages_received(driver: Driver, prefix: str = 'gear_phm estimator') -> int:
    """Return the messages the estimator reports received in its newest /diagnostics status."""
    return int(driver.latest(prefix).get('messages_received', 0))


def newest_stamp(driver: Driver, topics: tuple[str, ...] = (HEALTH_RUL, HEALTH_EFFICIENCY)
                 ) -> int:
    """Return the newest stamp [ns] the driver received on ``topics`` (-1: none yet).

    Topics the driver does not log are left out.
    """
    return max((driver.stamps[topic][-1] for topic in topics if driver.stamps.get(topic)),
               default=-1)


def publish_acked(driver: Driver, messages: list[JointState], rate: float, ahead: int = 80,
                  assess_lag: int = 40, stall: float = 60.0) -> None:
    """Publish at up to ``rate`` [Hz], never faster than the nodes take the stream in.

    The estimator's input queue holds 100 messages (best effort) and the diagnostics node's
    estimate queues 10 (reliable, keep last; one estimate per few samples): a loaded machine
    that runs a node behind the publisher would drop the excess. The estimator acknowledges
    in its /diagnostics status (``messages_received``), the diagnostics node by the stamp of
    its newest health output (each is stamped with the newest sample behind it). A message
    goes out only while the estimator is fewer than ``ahead`` messages behind and the
    diagnostics node fewer than ``assess_lag`` behind the estimator (once its first output
    of this call arrived), so none is lost, whatever the load; only the pace drops. Raises
    AssertionError when neither acknowledges anything new for ``stall`` seconds.
    """
    position = {stamp_to_ns(msg.header.stamp): i + 1 for i, msg in enumerate(messages)}
    base = messages_received(driver)

    def acks() -> tuple[int, int]:
        return messages_received(driver) - base, position.get(newest_stamp(driver), 0)

    def free(i: int, estimated: int, assessed: int) -> bool:
        if i - estimated >= ahead:
            return False
        return assessed <= 0 or estimated - assessed < assess_lag

    start = time.perf_counter()
    for i, msg in enumerate(messages):
        last_progress, seen = time.monotonic(), acks()
        while not free(i, *seen):
            driver.spin_once(0.01)
            now = acks()
            if now != seen:
                last_progress, seen = time.monotonic(), now
            elif time.monotonic() - last_progress > stall:
                text = f'the nodes acknowledged {seen} of {i} messages for {stall} s'
                raise AssertionError(text)
        _sleep_until(start + i / rate)
        driver.pub.publish(msg)
        if i % 10 == 9:
            driver.spin_once(0.0)


def replay_to_nodes(name: str, topics: tuple[str, ...], bag: Path, duration: float,
                    diagnostics: tuple[str, ...], estimator: tuple[str, ...],
                    rate_factor: float = 2.0) -> tuple[Driver, int, str]:
    """Replay ``bag`` (``duration`` s of bag time) to a diagnostics and an estimator node.

    The nodes are started with the ``node:=value`` arguments given, the publisher replays at
    ``rate_factor`` once the diagnostics node reports; the :class:`Driver` ``name`` records
    ``topics`` and every status until the estimator's status settles. Returns the (closed)
    driver, the publisher's exit code and its standard error.
    """
    procs = [spawn('diagnostics', *diagnostics), spawn('estimator', *estimator)]
    driver = Driver(name, topics)
    try:
        driver.wait(lambda: driver.latest('gear_phm'), 30.0, 'the diagnostics node')
        publisher = spawn('publisher', 'mode:=replay', f'bag_path:={bag}',
                          f'rate_factor:={rate_factor}', 'wait_for_subscribers:=1')
        procs.append(publisher)
        driver.wait(lambda: publisher.poll() is not None, duration / rate_factor + 90.0,
                    'the replay to end')
        driver.settle('gear_phm estimator')
        driver.spin(1.0)
    finally:
        driver.close()
        codes = [stop(p) for p in reversed(procs)]
    error = publisher.stderr.read() if publisher.stderr else ''
    return driver, codes[0], error
