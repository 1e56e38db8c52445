"""Publisher node as a real subprocess: replay exactness and pacing, simulate mode, bad input."""
from __future__ import annotations

from collections.abc import Iterator
import json
import os
from pathlib import Path
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from gear_phm.bagio import BagReader
from helpers.processes import udp_only_env
from helpers.shared import build_once

REPO = Path(__file__).resolve().parents[2]
PUBLISHER = Path(sys.executable).parent / 'publisher'
HEALTHY = REPO / 'bags' / 'healthy'


def publisher_command(**params: object) -> list[str]:
    command = [str(PUBLISHER), '--ros-args']
    for name, value in params.items():
        if isinstance(value, bool):
            value = 'true' if value else 'false'
        command += ['-p', f'{name}:={value}']
    return command


def run_publisher(timeout: float = 60.0, **params: object) -> subprocess.CompletedProcess:
    return subprocess.run(publisher_command(**params), capture_output=True, text=True,
                          timeout=timeout, env=os.environ.copy())


# --- bad input: exit 2, one line on stderr naming the thing, never a traceback ---------------

def _broken_bags(root: Path) -> dict[str, Path]:
    """Write a truncated and a corrupt copy of bags/healthy under ``root``; name -> directory."""
    source = HEALTHY / 'healthy_0.mcap'
    data = source.read_bytes()
    bags = {}
    for name, payload in (('truncated', data[: len(data) // 2]),
                          ('corrupt', data[:2000] + bytes(len(data) - 4000) + data[-2000:])):
        directory = root / name
        directory.mkdir()
        (directory / f'{name}_0.mcap').write_bytes(payload)
        metadata = (HEALTHY / 'metadata.yaml').read_text().replace('healthy_0', f'{name}_0')
        (directory / 'metadata.yaml').write_text(metadata)
        bags[name] = directory
    return bags


BAD_INPUTS = {
    'missing bag': ({'mode': 'replay', 'bag_path': '/nonexistent/bag'}, '/nonexistent/bag'),
    'truncated bag': ({'mode': 'replay', 'bag_path': '{truncated}'}, 'truncated'),
    'corrupt bag': ({'mode': 'replay', 'bag_path': '{corrupt}'}, 'corrupt'),
    'bag without the topic': ({'mode': 'replay', 'bag_path': str(HEALTHY),
                               'topic': '/encoders'},
                              "no topic '/encoders'"),
    'topic of the wrong type': ({'mode': 'replay', 'bag_path': str(HEALTHY),
                                 'topic': '/gear_phm/truth/friction'},
                                'expected sensor_msgs/msg/JointState'),
    'joint names not in the messages': ({'mode': 'replay', 'bag_path': str(HEALTHY),
                                         'motor_joint': 'rotor'}, "'rotor'"),
    'ratio <= 0': ({'ratio': 0.0}, 'parameter ratio'),
    'negative rate': ({'rate': -100.0}, 'parameter rate'),
    'negative rate factor': ({'mode': 'replay', 'bag_path': str(HEALTHY), 'rate_factor': -2.0},
                             'parameter rate_factor'),
    'unknown mode': ({'mode': 'record'}, 'parameter mode'),
    'integer for a double': ({'ratio': 3}, 'parameter ratio'),
}


@pytest.fixture(scope='module')
def bad_input_runs(tmp_path_factory: pytest.TempPathFactory
                   ) -> dict[str, subprocess.CompletedProcess]:
    """Run every bad-input case at once (they exit at start-up): case -> finished process.

    Once per test run (helpers.shared.build_once): the eleven start-ups cost about 6 s of CPU,
    and a module fixture runs again on a worker whose tests of this module pytest-xdist's
    worksteal interleaved with another module's.
    """
    root = build_once(tmp_path_factory, 'publisher_bad_inputs', _run_bad_inputs)
    runs = json.loads((root / 'runs.json').read_text())
    return {case: subprocess.CompletedProcess(*run) for case, run in runs.items()}


def _run_bad_inputs(root: Path) -> None:
    """Write runs.json: case -> (args, returncode, stdout, stderr) of its publisher."""
    broken_bags = _broken_bags(root)
    processes = {}
    for case, (params, _) in BAD_INPUTS.items():
        params = {k: (v.format(**broken_bags) if isinstance(v, str) else v)
                  for k, v in params.items()}
        processes[case] = subprocess.Popen(publisher_command(**params), stdout=subprocess.PIPE,
                                           stderr=subprocess.PIPE, text=True,
                                           env=udp_only_env())     # exit at start-up
    runs = {}
    for case, process in processes.items():
        try:
            stdout, stderr = process.communicate(timeout=60)
        finally:
            if process.poll() is None:
                process.kill()
                stdout, stderr = process.communicate()
        runs[case] = (process.args, process.returncode, stdout, stderr)
    (root / 'runs.json').write_text(json.dumps(runs))


@pytest.mark.integration
@pytest.mark.parametrize('case', sorted(BAD_INPUTS))
def test_bad_input_one_line_error_and_exit_2(
        case: str, bad_input_runs: dict[str, subprocess.CompletedProcess]) -> None:
    done = bad_input_runs[case]
    expected = BAD_INPUTS[case][1]
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert done.returncode == 2, (case, done.returncode, done.stderr)
    assert 'Traceback' not in done.stderr
    assert len(lines) == 1, lines
    assert expected in lines[0], lines[0]
    assert lines[0].startswith('error: ')


# --- replay against a subscriber in this process ---------------------------------------------

@pytest.fixture(scope='module')
def ros() -> Iterator[object]:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    rclpy.init()
    node = rclpy.create_node('test_publisher_listener')
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    thread = threading.Thread(target=executor.spin, daemon=True)
    thread.start()
    yield node
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()
    thread.join(timeout=5.0)


class Recorder:
    """Records (stamp_ns, receive monotonic time, message) of one topic."""

    def __init__(self, node, msg_type, topic: str) -> None:
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        self.items: list[tuple[int, float, object]] = []
        self._lock = threading.Lock()
        qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.node = node
        self.subscription = node.create_subscription(msg_type, topic, self._on_msg, qos)

    def _on_msg(self, msg) -> None:
        if hasattr(msg, 'clock'):
            stamp_ns = msg.clock.sec * 1_000_000_000 + msg.clock.nanosec
        else:
            stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        with self._lock:
            self.items.append((stamp_ns, time.monotonic(), msg))

    def close(self) -> None:
        self.node.destroy_subscription(self.subscription)


def bag_stamps(path: Path, start_offset: float) -> list[int]:
    from gear_phm.interfaces import stamp_to_ns
    with BagReader(path) as bag:
        start_ns = bag.start_ns + int(round(start_offset * 1e9))
        return [stamp_to_ns(m.header.stamp)
                for _, _, m in bag.messages(['/joint_states'], start_ns=start_ns)]


def wait_until(condition, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f'timed out after {timeout} s waiting for {what}')
        time.sleep(0.02)


def run_with_listeners(ros_node, listeners: list[tuple[type, str]], timeout: float = 90.0,
                       **params: object) -> tuple[subprocess.CompletedProcess,
                                                  list[Recorder]]:
    """Start the publisher; return (process, recorders) with the joint_states recorder first.

    Subscribe to ``listeners`` (topic, type) first and to joint_states last, after the others
    matched, so that the publisher (which waits for a joint_states subscriber) starts only
    when every listener is connected.
    """
    from sensor_msgs.msg import JointState
    recorders = [Recorder(ros_node, msg_type, topic) for msg_type, topic in listeners]
    process = subprocess.Popen(publisher_command(**params), stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, env=os.environ.copy())
    joints = None
    try:
        for recorder in recorders:
            wait_until(lambda r=recorder: r.subscription.get_publisher_count() >= 1, 30.0,
                       f'a publisher on {recorder.subscription.topic_name}')
        joints = Recorder(ros_node, JointState, params.get('remap') or 'joint_states')
        stdout, stderr = process.communicate(timeout=timeout)
        time.sleep(0.2)  # everything was acknowledged; let the last callbacks run
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
        for recorder in recorders + ([joints] if joints else []):
            recorder.close()
    done = subprocess.CompletedProcess(process.args, process.returncode, stdout, stderr)
    return done, [joints] + recorders


def replay(ros_node, rate_factor: float, start_offset: float, **extra: object):
    done, recorders = run_with_listeners(ros_node, [], mode='replay', bag_path=str(HEALTHY),
                                         rate_factor=rate_factor, start_offset=start_offset,
                                         **extra)
    return done, recorders[0].items


@pytest.mark.integration
def test_replay_delivers_every_message_in_order_and_paces_by_rate_factor(ros) -> None:
    start_offset = 115.0                       # the last 5 s of the bag: 500 messages
    expected = bag_stamps(HEALTHY, start_offset)
    assert len(expected) == 500
    spans, slopes = {}, {}
    for rate_factor in (1.0, 2.0):
        done, items = replay(ros, rate_factor, start_offset)
        assert done.returncode == 0, done.stderr
        assert 'Traceback' not in done.stderr
        stamps = [stamp for stamp, _, _ in items]
        assert stamps == expected               # every message, in order, bag stamps
        first = items[0][2]
        assert list(first.name) == ['motor', 'load']
        assert len(first.position) == len(first.velocity) == len(first.effort) == 2
        spans[rate_factor] = items[-1][1] - items[0][1]
        # receive time per bag time over 0.5 s strides; the median ignores a rare stall
        received = np.array([t for _, t, _ in items])
        bag_time = (np.array(stamps) - stamps[0]) * 1e-9
        slopes[rate_factor] = float(np.median((received[50:] - received[:-50])
                                              / (bag_time[50:] - bag_time[:-50])))
    bag_span = (expected[-1] - expected[0]) * 1e-9
    assert slopes[1.0] == pytest.approx(1.0, rel=0.05)
    assert slopes[2.0] == pytest.approx(0.5, rel=0.05)
    assert spans[1.0] >= bag_span * 0.97               # never faster than the bag
    assert spans[2.0] >= bag_span / 2.0 * 0.97
    assert spans[2.0] / spans[1.0] <= 0.7              # about half the time


@pytest.mark.integration
def test_replay_restamp_and_clock(ros) -> None:
    from geometry_msgs.msg import Vector3Stamped
    from rosgraph_msgs.msg import Clock
    before = time.time_ns()
    done, (joints, clock, truth) = run_with_listeners(
        ros, [(Clock, '/clock'), (Vector3Stamped, 'gear_phm/truth/efficiency')],
        mode='replay', bag_path=str(HEALTHY), rate_factor=4.0, start_offset=116.0,
        restamp=True, publish_clock=True)
    assert done.returncode == 0, done.stderr
    stamps = np.array([stamp for stamp, _, _ in joints.items])
    assert len(stamps) == 400
    assert stamps[0] >= before                      # node clock, not the bag's t = 116 s
    np.testing.assert_allclose(np.diff(stamps), 0.01e9 / 4.0, atol=2)   # 10 ms / 4
    assert [stamp for stamp, _, _ in clock.items] == list(stamps)   # /clock = published stamps
    assert [stamp for stamp, _, _ in truth.items] == list(stamps)   # truth replayed alongside
    with BagReader(HEALTHY) as bag:                 # with the bag's values
        start_ns = bag.start_ns + 116_000_000_000
        eta = [m.vector.x for _, _, m in bag.messages(['/gear_phm/truth/efficiency'],
                                                      start_ns=start_ns)]
    assert [m.vector.x for _, _, m in truth.items] == eta


@pytest.mark.integration
def test_simulate_mode_publishes_consistent_measurements_and_truth(ros) -> None:
    from geometry_msgs.msg import Vector3Stamped
    done, (joints, friction, efficiency) = run_with_listeners(
        ros, [(Vector3Stamped, 'gear_phm/truth/friction'),
              (Vector3Stamped, 'gear_phm/truth/efficiency')],
        duration=3.0, rate=200.0, seed=4, ratio=3.0, friction_initial=0.2,
        motor_joint='m', load_joint='l')
    assert done.returncode == 0, done.stderr
    assert len(joints.items) == len(friction.items) == len(efficiency.items) == 600
    stamps = np.array([s for s, _, _ in joints.items])
    np.testing.assert_array_equal(stamps, [s for s, _, _ in efficiency.items])
    np.testing.assert_allclose(np.diff(stamps), 5e6, atol=1)
    msgs = [m for _, _, m in joints.items]
    assert list(msgs[0].name) == ['m', 'l']
    velocity = np.array([m.velocity for m in msgs])
    effort = np.array([m.effort for m in msgs])
    eta_d = efficiency.items[0][2].vector.x
    assert eta_d == pytest.approx((3.0 - 0.2) / (3.0 * 1.2))
    assert friction.items[0][2].vector.x == pytest.approx(0.2)
    # first extension stroke at constant speed: 0.25 s .. 2.25 s -> energy ratio = eta_D
    steady = slice(int(0.3 * 200), int(2.2 * 200))
    p_motor = effort[steady, 0] * velocity[steady, 0]
    p_load = -effort[steady, 1] * velocity[steady, 1]
    assert -p_load.sum() / p_motor.sum() == pytest.approx(eta_d, abs=0.01)
    assert 'published 600 messages' in done.stderr
    assert [line.split(': ', 1)[1] for line in done.stderr.splitlines() if 'ready:' in line] \
        == ['ready: simulate to /joint_states, after 1 subscriber(s)']   # one line, at start


@pytest.mark.integration
def test_publisher_reports_diagnostics(ros) -> None:
    from diagnostic_msgs.msg import DiagnosticArray
    done, (_, diagnostics) = run_with_listeners(
        ros, [(DiagnosticArray, '/diagnostics')], duration=2.5, rate=100.0)
    assert done.returncode == 0, done.stderr
    statuses = [s for _, _, m in diagnostics.items for s in m.status
                if s.name == 'gear_phm publisher: publisher']
    assert statuses, 'no publisher status on /diagnostics'
    last = {kv.key: kv.value for kv in statuses[-1].values}
    assert last['messages_published'] == '250'
    assert last['state'] == 'done'
    assert float(last['jitter_p99_ms']) >= float(last['jitter_p50_ms']) >= -0.001


@pytest.mark.integration
def test_replay_without_subscriber_times_out_and_starts(tmp_path: Path) -> None:
    start = time.monotonic()
    done = run_publisher(timeout=60.0, mode='replay', bag_path=str(HEALTHY),
                         start_offset=119.5, wait_for_subscribers=1, wait_timeout=1.0,
                         remap='nobody_listens_here')
    elapsed = time.monotonic() - start
    assert done.returncode == 0, done.stderr
    assert 'starting anyway' in done.stderr
    assert elapsed >= 1.5


def test_config_file_lists_every_parameter_with_its_default_and_type() -> None:
    import yaml

    from gear_phm.nodes.publisher import NODE_PARAMETERS
    from gear_phm.simulation import PARAMETERS
    params = yaml.safe_load((REPO / 'config' / 'publisher.yaml').read_text())
    params = params['publisher']['ros__parameters']        # keyed by node name
    expected = {spec.name: spec.default for spec in NODE_PARAMETERS + PARAMETERS}
    assert set(params) == set(expected) | {'transmissions', 'extra_joints'}   # string arrays
    for name, default in expected.items():
        assert type(params[name]) is type(default), name     # 30.0, not 30
        assert params[name] == default, name


@pytest.mark.integration
def test_config_file_is_accepted_by_the_node() -> None:
    done = subprocess.run(
        [str(PUBLISHER), '--ros-args', '--params-file', str(REPO / 'config' / 'publisher.yaml'),
         '-p', 'duration:=0.3', '-p', 'wait_for_subscribers:=0'],
        capture_output=True, text=True, timeout=60, env=os.environ.copy())
    assert done.returncode == 0, done.stderr
    assert 'published 30 messages' in done.stderr


def write_other_formats(root: Path, count: int) -> dict[str, Path]:
    """Write the same 100 Hz JointState stream as a ROS1 .bag and a sqlite3 rosbag2."""
    from rosbags.rosbag1 import Writer as Ros1Writer
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Ros2Writer
    from rosbags.typesys import Stores, get_typestore

    kind = 'sensor_msgs/msg/JointState'
    paths = {'ros1': root / 'old.bag', 'sqlite3': root / 'sqlite'}
    for fmt, store in (('ros1', get_typestore(Stores.ROS1_NOETIC)),
                       ('sqlite3', get_typestore(Stores.ROS2_JAZZY))):
        header = store.types['std_msgs/msg/Header']
        time_type = store.types['builtin_interfaces/msg/Time']
        if fmt == 'ros1':
            writer = Ros1Writer(paths[fmt])
        else:
            writer = Ros2Writer(paths[fmt], version=9, storage_plugin=StoragePlugin.SQLITE3)
        with writer:
            connection = writer.add_connection('/joint_states', kind, typestore=store)
            for i in range(count):
                fields = {'stamp': time_type(sec=50 + i // 100, nanosec=(i % 100) * 10**7),
                          'frame_id': ''}
                if fmt == 'ros1':
                    fields['seq'] = i
                msg = store.types[kind](header=header(**fields), name=['load', 'motor'],
                                        position=np.zeros(2), velocity=np.array([0.5, 1.5]),
                                        effort=np.array([float(i), 2.0]))
                data = store.serialize_ros1(msg, kind) if fmt == 'ros1' \
                    else store.serialize_cdr(msg, kind)
                writer.write(connection, 50 * 10**9 + i * 10**7, data)
    return paths


@pytest.mark.integration
@pytest.mark.parametrize('fmt', ['ros1', 'sqlite3'])
def test_replay_of_ros1_and_sqlite3_bags(ros, tmp_path: Path, fmt: str) -> None:
    path = write_other_formats(tmp_path, 150)[fmt]
    done, (joints,) = run_with_listeners(ros, [], mode='replay', bag_path=str(path),
                                         rate_factor=3.0)
    assert done.returncode == 0, done.stderr
    stamps = [s for s, _, _ in joints.items]
    assert stamps == [50 * 10**9 + i * 10**7 for i in range(150)]
    assert [m.effort[0] for _, _, m in joints.items] == [float(i) for i in range(150)]
    assert list(joints.items[0][2].name) == ['load', 'motor']


@pytest.mark.integration
def test_replay_loop_repeats_until_interrupted(ros) -> None:
    import signal

    from sensor_msgs.msg import JointState
    recorder = Recorder(ros, JointState, 'joint_states')
    process = subprocess.Popen(
        publisher_command(mode='replay', bag_path=str(HEALTHY), start_offset=119.5,
                          rate_factor=2.0, loop=True),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=os.environ.copy())
    try:
        wait_until(lambda: len(recorder.items) >= 130, 30.0, 'two passes of the loop')
        process.send_signal(signal.SIGINT)
        _, stderr = process.communicate(timeout=20)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
        recorder.close()
    assert process.returncode == 0, stderr
    assert 'Traceback' not in stderr
    stamps = [s for s, _, _ in recorder.items]
    one_pass = [119_500_000_000 + i * 10_000_000 for i in range(50)]
    assert stamps[:100] == one_pass + one_pass            # original stamps, pass after pass


@pytest.mark.integration
def test_unbounded_simulation_that_jams_stops_with_one_line() -> None:
    done = run_publisher(timeout=60.0, wait_for_subscribers=0, wear='linear', wear_rate=2.0,
                         rate=50.0)
    assert done.returncode == 2, done.stderr
    assert 'Traceback' not in done.stderr
    errors = [line for line in done.stderr.splitlines() if line.startswith('error: ')]
    assert len(errors) == 1 and 'the gearbox jams' in errors[0], done.stderr
