"""Stopping nodes: what counts as a clean stop, and a publisher stopped by a signal exits 0."""
from __future__ import annotations

import os
from pathlib import Path
import signal
import sys
import threading
import time

import pytest

from helpers.processes import signalled_when

PUBLISHER = Path(sys.executable).parent / 'publisher'


@pytest.mark.integration
@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM])
def test_running_publisher_stopped_by_signal_exits_0(sig: signal.Signals) -> None:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    topic = f'shutdown_test_{sig.name.lower()}'
    received: list[int] = []
    rclpy.init()
    node = rclpy.create_node('test_publisher_shutdown')
    node.create_subscription(JointState, topic, lambda _m: received.append(1),
                             QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE))
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        process = signalled_when(
            [str(PUBLISHER), '--ros-args', '-p', f'remap:={topic}', '-p', 'rate:=200.0'],
            lambda _child: len(received) >= 50, 'published 50 messages', sig,
            ready_within=30.0, exit_within=20.0)
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
        spinner.join(timeout=5.0)
    assert process.returncode == 0, process.stderr
    assert 'Traceback' not in process.stderr and 'error' not in process.stderr.lower(), \
        process.stderr


def test_stop_signals_request_a_stop_then_a_second_signal_stops_now() -> None:
    """SIGINT/SIGTERM only request a stop; a second one raises KeyboardInterrupt.

    The main thread then stops in order; the previous handlers come back afterwards.
    """
    import rclpy

    from gear_phm.nodes.common import init_node_process, keep_spinning, stop_signals

    before = signal.getsignal(signal.SIGTERM)
    init_node_process([])
    try:
        for sig in (signal.SIGINT, signal.SIGTERM):
            with stop_signals():
                assert keep_spinning()
                os.kill(os.getpid(), sig)
                deadline = time.monotonic() + 5.0
                while keep_spinning() and time.monotonic() < deadline:
                    time.sleep(0.001)      # the handler runs between bytecodes of this thread
                assert not keep_spinning()
                assert rclpy.ok(), 'a stop request must not shut the context down'
                with pytest.raises(KeyboardInterrupt):
                    os.kill(os.getpid(), sig)
                    time.sleep(1.0)
    finally:
        rclpy.try_shutdown()
    assert signal.getsignal(signal.SIGTERM) is before
    assert not keep_spinning()                  # the context is down
