"""End to end over DDS.

The publisher replays bags/wearing fast, the estimator runs, diagnostics
records. The recording opens with rosbags and mcap; /diagnostics goes OK -> WARN -> ERROR as
the bag wears; killing the publisher gives STALE within stale_timeout.

Wearing bag: true u 0.05 -> 0.30 exponentially over 300 s, R = 3. With eta_opposing_min 0.7333
(u_eol 0.25, reached at ~269 s) and eta_warn 0.8 (u 0.176, ~211 s) the levels change late in
the bag; replayed 20x faster (15 s).

STALE is timed from the last estimator message this test receives, not from the publisher's
kill: on a loaded 2-core machine the estimator may still be working off its input queue after
the kill (CI once saw 2.08 s kill-to-STALE with a 1 s timeout), and the diagnostics node's
contract is about the silence of its own inputs.
"""
from __future__ import annotations

import math
from pathlib import Path
import signal
import time

from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from geometry_msgs.msg import Vector3Stamped  # noqa: E402
from mcap.reader import make_reader  # noqa: E402
import pytest
import rclpy
from rclpy.node import Node  # noqa: E402

from gear_phm.bagio import BagReader  # noqa: E402
from gear_phm.interfaces import DIAGNOSTICS, ESTIMATOR_TOPICS  # noqa: E402
from gear_phm.nodes.common import OUTPUT_QOS  # noqa: E402
from helpers.processes import spawn, stop  # noqa: E402

pytestmark = [pytest.mark.integration, pytest.mark.timeout(180)]
BAG = Path(__file__).resolve().parents[2] / 'bags' / 'wearing'
STALE_TIMEOUT = 1.0
DIAGNOSTICS_RATE = 10.0


@pytest.mark.long(15)
def test_three_processes_levels_recording_and_stale(tmp_path: Path,
                                                    sigkill_safe_env: dict[str, str]) -> None:
    record = tmp_path / 'diag'
    diagnostics = spawn('diagnostics', f'record_path:={record}', 'record_inputs:=true',
                        'ratio:=3.0', 'eta_opposing_min:=0.7333', 'eta_warn:=0.8',
                        'warn_horizon:=0.0', f'rate:={DIAGNOSTICS_RATE}',
                        f'stale_timeout:={STALE_TIMEOUT}', 'transmission_name:=wearing')
    estimator = spawn('estimator', 'ratio:=3.0', 'process_noise:=1e-10')
    procs = [diagnostics, estimator]
    rclpy.init()
    node = Node('end_to_end_test')
    arrays: list[DiagnosticArray] = []
    arrived: list[float] = []    # monotonic arrival of each of them, s

    def on_array(msg: DiagnosticArray) -> None:
        if msg.status and msg.status[0].name == 'gear_phm: wearing':
            arrays.append(msg)
            arrived.append(time.monotonic())
    node.create_subscription(DiagnosticArray, DIAGNOSTICS, on_array, OUTPUT_QOS)
    last_input = [math.nan]      # monotonic arrival of the latest estimator message, s
    # the topic an update is published on last (ESTIMATOR_TOPICS is in publishing order): its
    # newest message is the latest of all seven, one callback per update instead of seven
    node.create_subscription(Vector3Stamped, ESTIMATOR_TOPICS[-1],
                             lambda _m: last_input.__setitem__(0, time.monotonic()),
                             OUTPUT_QOS)
    try:
        end = time.monotonic() + 30.0
        while not arrays and time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.05)
        assert arrays, 'diagnostics node never published'
        publisher = spawn('publisher', 'mode:=replay', f'bag_path:={BAG}',
                          'rate_factor:=20.0', 'wait_for_subscribers:=1',
                          env=sigkill_safe_env)                 # killed with -9 below
        procs.append(publisher)
        levels: list[bytes] = []
        end = time.monotonic() + 90.0
        while publisher.poll() is None and time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.05)
            level = arrays[-1].status[0].level
            if not levels or levels[-1] != level:
                levels.append(level)
            if level == b'\x02':
                break
        live = [lv for lv in levels if lv != b'\x03']
        assert live[:3] == [b'\x00', b'\x01', b'\x02'], levels
        if publisher.poll() is None:          # kill the publisher mid-replay
            publisher.send_signal(signal.SIGKILL)
            publisher.wait(timeout=10)
        # the STALE that follows the last input (a loaded machine can also show a passing
        # STALE while the replay still runs: once, the newest array was such a one when the
        # publisher was killed, 0.5 ms after an input)
        end = time.monotonic() + STALE_TIMEOUT + 10.0
        while not (arrays[-1].status[0].level == b'\x03' and arrived[-1] > last_input[0]) \
                and time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.01)
        assert arrays[-1].status[0].level == b'\x03'
        first = len(arrays) - 1                # the first of the STALE arrays since the input
        while first > 0 and arrays[first - 1].status[0].level == b'\x03' \
                and arrived[first - 1] > last_input[0]:
            first -= 1
        silence = arrived[first] - last_input[0]
        # STALE not before the timeout (0.3 s slack for the two processes' clocks of the last
        # input); after it, within a deadline, not a tight window: with 4 workers on 2 cores
        # under load the status came 0.34 s after the timeout plus one period once
        assert STALE_TIMEOUT - 0.3 <= silence <= STALE_TIMEOUT + 1.0 / DIAGNOSTICS_RATE + 5.0
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        codes = [stop(p) for p in reversed(procs)]
    assert codes[-1] == 0 or codes[-1] == -signal.SIGINT, diagnostics.stderr.read()
    with BagReader(record) as bag:
        topics = bag.topics
        assert bag.message_count('/gear_phm/health/rul') > 10
        assert '/gear_phm/friction' in topics and '/diagnostics' in topics
    with open(next(record.glob('*.mcap')), 'rb') as stream:
        count = sum(1 for _ in make_reader(stream).iter_messages(topics=['/diagnostics']))
    assert count > 10
