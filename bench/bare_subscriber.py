"""Baseline for live benchmarks: a bare rclpy JointState subscriber that does nothing.

Same QoS as the estimator (qos_profile_sensor_data policies, depth 100), the same executor
choice (``--executor single|events``) and the same reporting (a /diagnostics status with
``messages_received``), so the harness measures both the same way. ``--raw`` takes the
messages serialized, as the estimator node does (no Python message object per message).
"""
from __future__ import annotations

import argparse
import sys

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from sensor_msgs.msg import JointState

from gear_phm.interfaces import DiagnosticsOut
from gear_phm.nodes.common import DropCounter, OUTPUT_QOS, run_node, SENSOR_QOS, to_rclpy
from gear_phm.nodes.executors import spin_executor
from gear_phm.status import OK


class BareSubscriber(Node):
    def __init__(self, raw: bool = False, name: str = 'bare_subscriber') -> None:
        super().__init__(name)
        self.counter = DropCounter()
        self.status_name = f'bench: {name}'
        self.create_subscription(JointState, 'joint_states', self._on_message, SENSOR_QOS,
                                 raw=raw)
        self._diagnostics = self.create_publisher(DiagnosticArray, '/diagnostics', OUTPUT_QOS)
        self.create_timer(1.0, self._report)

    def _on_message(self, msg: JointState) -> None:
        self.counter.received += 1

    def _report(self) -> None:
        status = self.counter.status(self.status_name, 'bench', OK, 'counting')
        now = self.get_clock().now().nanoseconds
        self._diagnostics.publish(to_rclpy(DiagnosticsOut(now, (status,))))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--executor', choices=('single', 'events'), default='single')
    parser.add_argument('--raw', action='store_true', help='serialized messages')
    parser.add_argument('--name', default='bare_subscriber', help='node name')
    args, rest = parser.parse_known_args()

    def spin(node: Node) -> None:
        spin_executor(node, args.executor)

    return run_node(lambda: BareSubscriber(args.raw, args.name), [sys.argv[0], *rest],
                    spin=spin)


if __name__ == '__main__':
    sys.exit(main())
