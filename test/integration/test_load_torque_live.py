"""The load torque from a force/torque sensor (``load_torque_topic``) gives the JointState's u.

Two estimator processes on one plant stream: one reads the load effort from JointState (root
namespace), the other, in namespace ``/w``, reads JointStates whose load effort is NaN and
takes the load torque from ``geometry_msgs/WrenchStamped`` on ``/w/load_wrench``: along x,
with the sign flipped (``load_torque_sign:=-1``), stamped 0.2 ms after the joint samples
(matched as the nearest within ``load_torque_tolerance`` 1 ms). Their u agree within 1e-6
relative at every output. On the way: the namespaced estimator's status name is qualified.
"""
from __future__ import annotations

from collections.abc import Iterator
import signal
import subprocess

import pytest

rclpy = pytest.importorskip('rclpy')
from geometry_msgs.msg import WrenchStamped  # noqa: E402, I100
from rclpy.qos import qos_profile_sensor_data  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402

from gear_phm.interfaces import FRICTION, stamp_to_ns  # noqa: E402
from helpers.live import Driver, joint_state  # noqa: E402
from helpers.plant import lever_plant  # noqa: E402
from helpers.processes import BIN, stop  # noqa: E402

pytestmark = [pytest.mark.integration, pytest.mark.timeout(180)]
#: u = 0.1, 100 Hz: 20 s of stamps, published as fast as the estimators take them.
RUN = lever_plant(7, 20.0, 0.1, rate=100.0)
COMMON = ('ratio:=3.0', 'motor_torque_noise:=0.05', 'load_torque_noise:=0.05',
          'motor_inertia:=0.01', 'diagnostics_period:=0.1')
NAMES = ('gear_phm estimator: estimator', 'gear_phm estimator: w/estimator')
SHIFT_NS = 200_000          # the wrench's stamp after the joint sample's


def _start(*args: str) -> subprocess.Popen:
    command = [str(BIN / 'estimator'), '--ros-args', *args]
    for param in COMMON:
        command += ['-p', param]
    return subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)


@pytest.fixture(scope='module')
def rig() -> Iterator[tuple[Driver, dict[str, dict[str, str]]]]:
    procs = [_start(),
             _start('-r', '__ns:=/w', '-p', 'load_torque_topic:=load_wrench', '-p',
                    'load_torque_axis:=x', '-p', 'load_torque_sign:=-1')]
    driver = Driver('load_torque_driver', outputs=(FRICTION, f'/w/{FRICTION}'))
    statuses: dict[str, dict[str, str]] = {}
    driver.on_diagnostics.append(lambda msg: statuses.update(
        (s.name, {kv.key: kv.value for kv in s.values}) for s in msg.status))
    try:
        yield driver, statuses
    finally:
        driver.close()
        for proc in procs:
            assert stop(proc, signal.SIGINT) == 0, proc.stderr.read() if proc.stderr else ''


def test_wrench_load_torque_gives_the_joint_state_u(
        rig: tuple[Driver, dict[str, dict[str, str]]]) -> None:
    driver, statuses = rig
    node = driver.node
    joints_w = node.create_publisher(JointState, '/w/joint_states', qos_profile_sensor_data)
    wrench = node.create_publisher(WrenchStamped, '/w/load_wrench', qos_profile_sensor_data)
    driver.wait(lambda: all(name in statuses for name in NAMES)
                and min(p.get_subscription_count() for p in (driver.pub, joints_w, wrench)) > 0,
                60.0, 'both estimators')

    def received() -> int:
        return min(int(statuses[name].get('messages_received', 0)) for name in NAMES)

    base = 10**18
    for i in range(RUN.t.size):
        stamp = base + int(round(RUN.t[i] * 1e9))
        values = (RUN.motor_velocity[i], RUN.motor_effort[i], RUN.load_velocity[i],
                  RUN.load_effort[i])
        driver.pub.publish(joint_state(stamp, *values))
        joints_w.publish(joint_state(stamp, *values[:3], float('nan')))
        msg = WrenchStamped()
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp + SHIFT_NS, 10**9)
        msg.wrench.torque.x = -float(values[3])
        wrench.publish(msg)
        if i % 20 == 19:        # at most 60 samples ahead of the slower estimator (depth 100)
            driver.wait(lambda: received() >= i - 60, 60.0, 'the estimators keeping up')
    driver.wait(lambda: received() == RUN.t.size, 60.0, 'every sample taken in')
    assert statuses[NAMES[1]]['dropped_no_load_torque'] == '0'
    assert 'dropped_no_load_torque' not in statuses[NAMES[0]]
    driver.wait(lambda: len(driver.messages[FRICTION]) == len(driver.messages[f'/w/{FRICTION}'])
                and len(driver.messages[FRICTION]) > 0, 30.0, 'the same outputs')
    outputs = [{stamp_to_ns(m.header.stamp): m.vector.x for m in driver.messages[topic]}
               for topic in (FRICTION, f'/w/{FRICTION}')]
    assert outputs[0].keys() == outputs[1].keys() and len(outputs[0]) >= 10
    for stamp, u in outputs[0].items():
        assert outputs[1][stamp] == pytest.approx(u, rel=1e-6), stamp
    assert list(outputs[0].values())[-1] == pytest.approx(0.1, abs=0.02)
    print(f'{len(outputs[0])} outputs compared, u {list(outputs[0].values())[-1]:.6f}')
