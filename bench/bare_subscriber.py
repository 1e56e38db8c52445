"""Baseline for live benchmarks: a bare rclpy JointState subscriber that does nothing.

Same QoS as the estimator (qos_profile_sensor_data) and the same reporting (a /diagnostics
status with ``messages_received``), so the harness measures both the same way.
"""
from __future__ import annotations

import sys

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from sensor_msgs.msg import JointState

from gear_phm.interfaces import DiagnosticsOut
from gear_phm.nodes.common import DropCounter, OUTPUT_QOS, run_node, SENSOR_QOS, to_rclpy
from gear_phm.status import OK


class BareSubscriber(Node):
    def __init__(self) -> None:
        super().__init__('bare_subscriber')
        self.counter = DropCounter()
        self.create_subscription(JointState, 'joint_states', self._on_message, SENSOR_QOS)
        self._diagnostics = self.create_publisher(DiagnosticArray, '/diagnostics', OUTPUT_QOS)
        self.create_timer(0.5, self._report)

    def _on_message(self, msg: JointState) -> None:
        self.counter.received += 1

    def _report(self) -> None:
        status = self.counter.status('bench: bare_subscriber', 'bench', OK, 'counting')
        now = self.get_clock().now().nanoseconds
        self._diagnostics.publish(to_rclpy(DiagnosticsOut(now, (status,))))


def main() -> int:
    return run_node(BareSubscriber)


if __name__ == '__main__':
    sys.exit(main())
