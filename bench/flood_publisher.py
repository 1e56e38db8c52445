"""Publish simulated JointState messages at a fixed rate for the live benchmarks.

Waits until ``--subscribers`` subscriptions match, publishes ``--rate`` Hz for ``--duration`` s
(paced against time.perf_counter: below 2.5 kHz it sleeps through most of a period and
spins only its last 0.3 ms; stamps = wall clock now), prints ``sent=<n>`` and exits.
The samples come from gear_phm.simulation at the same rate, so the estimator does real work.
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState


def simulated_columns(rate: float, count: int) -> np.ndarray:
    """(count, 6) array: motor pos/vel/effort, load pos/vel/effort, from the simulator."""
    from gear_phm.simulation import SimulationConfig, simulate
    config = SimulationConfig()
    t = np.arange(count) / rate
    result = simulate(config, t)
    return np.column_stack([result.position_motor, result.velocity_motor, result.effort_motor,
                            result.position_load, result.velocity_load, result.effort_load])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--rate', type=float, required=True, help='messages per second')
    parser.add_argument('--duration', type=float, required=True, help='seconds of publishing')
    parser.add_argument('--subscribers', type=int, default=1)
    parser.add_argument('--reliable', action='store_true', help='RELIABLE publisher QoS')
    args = parser.parse_args()
    count = int(args.rate * args.duration)
    pool = simulated_columns(args.rate, min(count, 200_000))
    rclpy.init()
    node = rclpy.create_node('flood_publisher')
    qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE if args.reliable
                     else ReliabilityPolicy.BEST_EFFORT)
    publisher = node.create_publisher(JointState, 'joint_states', qos)
    deadline = time.monotonic() + 20.0
    while publisher.get_subscription_count() < args.subscribers:
        if time.monotonic() > deadline:
            print('error: no subscriber matched within 20 s', file=sys.stderr)
            return 1
        rclpy.spin_once(node, timeout_sec=0.05)
    time.sleep(1.0)  # let every endpoint finish matching (late matches lose messages)
    msg = JointState(name=['motor', 'load'])
    period = 1.0 / args.rate
    start = time.perf_counter()
    for i in range(count):
        target = start + i * period
        ahead = target - time.perf_counter()
        if ahead > 4e-4:             # sleep most of a long period, spin only the end of it
            time.sleep(ahead - 3e-4)
        while time.perf_counter() < target:
            pass
        row = pool[i % len(pool)]
        now = time.time_ns()
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(now, 1_000_000_000)
        msg.position = [row[0], row[3]]
        msg.velocity = [row[1], row[4]]
        msg.effort = [row[2], row[5]]
        publisher.publish(msg)
    elapsed = time.perf_counter() - start
    print(f'sent={count} elapsed={elapsed:.3f}', flush=True)
    time.sleep(0.5)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
