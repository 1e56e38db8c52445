"""The estimator node as a real subprocess over DDS.

It estimates from good messages, survives garbage, refuses bad parameters with a reason.
"""
from __future__ import annotations

import math
import os
from pathlib import Path
import subprocess
import sys
import time

import pytest

from helpers.plant import lever_plant

VENV_BIN = Path(sys.executable).parent
pytestmark = pytest.mark.integration


def _wait(condition, deadline_s: float, spin) -> bool:
    end = time.monotonic() + deadline_s
    while time.monotonic() < end:
        if condition():
            return True
        spin()
    return condition()


def test_bad_parameter_is_refused_with_reason() -> None:
    result = subprocess.run([str(VENV_BIN / 'estimator'), '--ros-args', '-p', 'window:=0.5',
                             '-p', 'min_window:=0.8'], capture_output=True, text=True,
                            timeout=30, env=os.environ.copy())
    assert result.returncode == 2
    assert 'min_window must be < window' in result.stderr


def test_renamed_parameter_is_refused_and_an_unknown_one_named() -> None:
    """Overrides rclpy would drop: a renamed one is refused, a misspelt one is named."""
    renamed = subprocess.run([str(VENV_BIN / 'diagnostics'), '--ros-args', '-p',
                              'self_locking_eol:=false'], capture_output=True, text=True,
                             timeout=30, env=os.environ.copy())
    assert renamed.returncode == 2
    assert 'parameter self_locking_eol was replaced by must_back_drive' in renamed.stderr
    misspelt = subprocess.run([str(VENV_BIN / 'estimator'), '--ros-args', '-p', 'window:=0.5',
                               '-p', 'min_window:=0.8', '-p', 'windw:=2.0'],
                              capture_output=True, text=True, timeout=30, env=os.environ.copy())
    assert misspelt.returncode == 2          # refused for min_window, after naming windw
    assert 'ignored parameters (not parameters of estimator): windw' in misspelt.stderr


@pytest.mark.long(12)
def test_node_survives_garbage_and_keeps_estimating() -> None:
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import Vector3Stamped
    from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
    from sensor_msgs.msg import JointState

    proc = subprocess.Popen(
        [str(VENV_BIN / 'estimator'), '--ros-args', '-p', 'ratio:=3.0',
         '-p', 'motor_torque_noise:=0.05', '-p', 'load_torque_noise:=0.05',
         '-p', 'motor_inertia:=0.01', '-p', 'backwards_policy:=skip',
         '-p', 'sensor_timeout:=5.0', '-p', 'diagnostics_period:=0.2'],
        env=os.environ.copy(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    rclpy.init()
    node = rclpy.create_node('estimator_test_driver')
    try:
        friction: list[Vector3Stamped] = []
        statuses: list = []
        reliable = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
        node.create_subscription(Vector3Stamped, 'gear_phm/friction', friction.append,
                                 reliable)
        node.create_subscription(
            DiagnosticArray, '/diagnostics',
            lambda m: statuses.extend(s for s in m.status if 'estimator' in s.name), reliable)
        pub = node.create_publisher(JointState, 'joint_states', qos_profile_sensor_data)

        def spin() -> None:
            rclpy.spin_once(node, timeout_sec=0.01)

        assert _wait(lambda: pub.get_subscription_count() > 0 and statuses, 30.0, spin), \
            'estimator did not come up'
        run = lever_plant(3, 60.0, 0.1, rate=100.0)
        base = time.time_ns()

        def joint_state(stamp_ns: int, names, velocity, effort) -> JointState:
            msg = JointState()
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 10 ** 9)
            msg.name, msg.velocity, msg.effort = names, velocity, effort
            return msg

        for i in range(run.t.size):
            stamp = base + int(run.t[i] * 1e9)
            pub.publish(joint_state(stamp, ['motor', 'load'],
                                    [float(run.motor_velocity[i]), float(run.load_velocity[i])],
                                    [float(run.motor_effort[i]), float(run.load_effort[i])]))
            if i % 50 == 25:
                pub.publish(joint_state(stamp + 1, ['left', 'right'], [1.0, 1.0], [1.0, 1.0]))
                pub.publish(joint_state(stamp + 2, [], [], []))
                pub.publish(joint_state(stamp + 3, ['motor', 'load'], [math.nan, 1.0],
                                        [1.0, math.inf]))
                pub.publish(joint_state(stamp - 10 ** 9, ['motor', 'load'], [1.0, 1.0],
                                        [5.0, -5.0]))
            if i % 4 == 0:
                spin()
                time.sleep(0.002)
        end_stamp = base + int(run.t[-1] * 1e9)

        def done() -> bool:
            return bool(friction) and friction[-1].header.stamp.sec * 10 ** 9 + \
                friction[-1].header.stamp.nanosec >= end_stamp - 2 * 10 ** 9

        assert _wait(done, 30.0, spin), 'no estimate near the end of the stream'
        n = len(statuses)
        assert _wait(lambda: len(statuses) > n + 1, 10.0, spin)
        assert proc.poll() is None, proc.stdout.read() if proc.stdout else ''
        u_hat, sigma = friction[-1].vector.x, friction[-1].vector.z
        assert abs(u_hat - 0.1) <= 0.002 and 0.0 < sigma < 0.002
        values = {kv.key: kv.value for kv in statuses[-1].values}
        for key in ('dropped_missing_joint', 'dropped_nonfinite', 'dropped_backwards'):
            assert int(values[key]) >= 5, (key, values)
        assert int(values['filter_updates']) > 10
        assert int(values['messages_received']) > run.t.size // 2
        stamps = [m.header.stamp.sec * 10 ** 9 + m.header.stamp.nanosec for m in friction]
        assert stamps == sorted(stamps)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        proc.terminate()
        proc.wait(timeout=10)


@pytest.mark.long(20)
def test_status_says_which_joints_the_messages_name_and_that_stamps_do_not_advance() -> None:
    """The estimator's status says why it has no measurement, on /diagnostics.

    A bench client that names other joints, then one that leaves header.stamp at 0, then one
    whose load torque reads the other way, then a gearbox of another ratio.
    """
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters
    from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
    from sensor_msgs.msg import JointState

    def start(motor_joint: str) -> subprocess.Popen:
        return subprocess.Popen(
            [str(VENV_BIN / 'estimator'), '--ros-args', '-r', '__node:=joints_probe', '-p',
             'ratio:=3.0', '-p', f'motor_joint:={motor_joint}', '-p',
             'diagnostics_period:=0.2'],
            env=os.environ.copy(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    proc = start('rotor')
    rclpy.init()
    node = rclpy.create_node('joints_probe_driver')
    try:
        messages: list[str] = []
        node.create_subscription(
            DiagnosticArray, '/diagnostics',
            lambda m: messages.extend(s.message for s in m.status if 'joints_probe' in s.name),
            QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE))
        pub = node.create_publisher(JointState, 'joint_states', qos_profile_sensor_data)

        def spin() -> None:
            rclpy.spin_once(node, timeout_sec=0.01)

        assert _wait(lambda: pub.get_subscription_count() > 0 and messages, 30.0, spin), \
            'estimator did not come up'

        def publish(count: int, stamped: bool, reversed_load: bool = False,
                    load_speed: float = 3.3) -> None:
            base = time.time_ns()
            for i in range(count):
                msg = JointState(name=['motor', 'load'], velocity=[10.0, load_speed],
                                 effort=[1.0, -2.8])
                if reversed_load:       # 50 samples opposing (eta 0.9), 50 aiding, ...
                    aiding = (i // 50) % 2 == 1
                    msg.velocity = [10.0, 10.0 / 3.0]
                    msg.effort = [-0.9, -3.0] if aiding else [1.0, 2.7]
                    msg.effort[1] = -msg.effort[1]      # the load torque read the other way
                if stamped:
                    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(
                        base + i * 10_000_000, 10 ** 9)
                pub.publish(msg)
                spin()

        publish(50, stamped=True)
        hint = "the first messages name the joints ['motor', 'load']"
        assert _wait(lambda: any(hint in m for m in messages), 20.0, spin), messages[-3:]
        # the joint names are structural (read-only at run time): the right one needs a
        # restart; then no stamps
        client = node.create_client(SetParameters, '/joints_probe/set_parameters')
        assert client.wait_for_service(timeout_sec=20.0)
        value = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value='motor')
        future = client.call_async(SetParameters.Request(
            parameters=[Parameter(name='motor_joint', value=value)]))
        assert _wait(future.done, 20.0, spin)
        result = future.result().results[0]
        assert not result.successful
        assert result.reason == 'Trying to set a read-only parameter: motor_joint.'
        proc.terminate()
        proc.wait(timeout=10)
        messages.clear()
        proc = start('motor')
        assert _wait(lambda: pub.get_subscription_count() > 0 and messages, 30.0, spin), \
            'estimator did not come up again'
        messages.clear()
        publish(200, stamped=False)
        stalled = 'no efficiency measurement yet: the header stamps do not advance'
        assert _wait(lambda: any(m.startswith(stalled) for m in messages), 20.0, spin), \
            messages[-3:]
        assert not any(hint in m for m in messages[-1:])      # its samples were seen
        # a load torque sensor that reads the other way: the status names the sign to flip
        messages.clear()
        publish(600, stamped=True, reversed_load=True)
        reversed_sign = "the load torque's sign looks reversed"
        assert _wait(lambda: any(reversed_sign in m and 'set load_effort_sign to -1' in m
                                 for m in messages), 20.0, spin), messages[-3:]
        # a gearbox of ratio 5 under ratio:=3.0: the speeds contradict the parameter
        messages.clear()
        publish(1500, stamped=True, load_speed=2.0)
        assert _wait(lambda: any('the speeds give ratio' in m and 'the ratio parameter is 3'
                                 in m for m in messages), 20.0, spin), messages[-3:]
        assert proc.poll() is None
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        proc.terminate()
        proc.wait(timeout=10)
