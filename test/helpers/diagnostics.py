"""Test side of the diagnostics node (needs rclpy).

Start it as a process, wait on a condition while spinning, and feed it the estimator topics of
a known linear wear.
"""
from __future__ import annotations

import math
import os
from pathlib import Path
import subprocess
import sys
import time

import rclpy
from geometry_msgs.msg import Vector3Stamped  # noqa: I100
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy

from gear_phm.interfaces import (COUNTS, DIRECTION_OFFSET, EFFICIENCY, ESTIMATOR_TOPICS,
                                 FRICTION, FRICTION_COVARIANCE, INNOVATION, OPERATING_TIME)
from gear_phm.nodes.common import stamp

EXE = Path(sys.executable).parent / 'diagnostics'


def start(*params: str, env: dict[str, str] | None = None) -> subprocess.Popen:
    args = [str(EXE), '--ros-args', '-p', 'stale_timeout:=0.5', '-p', 'rate:=20.0',
            '-p', 'warn_horizon:=600.0', '-p', 'transmission_name:=left_aileron',
            '-p', 'hardware_id:=gb-7']
    for param in params:
        args += ['-p', param]
    return subprocess.Popen(args, env=env or os.environ.copy(), stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)


def wait_for(node: Node, condition, deadline_s: float, what: str) -> None:
    end = time.monotonic() + deadline_s
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.02)
        if condition():
            return
    raise AssertionError(f'timed out waiting for {what}')


#: The feeder's queue: deep enough that a diagnostics node slowed by a loaded machine still
#: receives every update (with the nodes' depth 10, a test that publishes 400 updates in a
#: burst lost some under load, and the levels it asserts came from a shorter history).
FEEDER_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


class Feeder:
    """Publishes the estimator topics of linear wear u = 0.05 + 1.5e-4 t.

    The operating time is ``utilisation`` t.
    """

    def __init__(self, node: Node, utilisation: float = 0.5) -> None:
        self.pubs = [node.create_publisher(Vector3Stamped, t, FEEDER_QOS)
                     for t in ESTIMATOR_TOPICS]
        self.utilisation = utilisation
        self.step = 0

    def matched(self) -> bool:
        return all(p.get_subscription_count() > 0 for p in self.pubs)

    def publish(self, dt: float = 10.0) -> int:
        t = self.step * dt
        self.step += 1
        u = 0.05 + 1.5e-4 * t
        eta_d, eta_i = (3.0 - u) / (3.0 * (1.0 + u)), 3.0 * (1.0 - u) / (3.0 + u)
        by_topic = {FRICTION: (u, 1.5e-4, 1e-3), FRICTION_COVARIANCE: (1e-6, 0.0, 1e-12),
                    EFFICIENCY: (eta_d, eta_i, eta_d),
                    INNOVATION: (0.001, 1e-6, 1.0 if self.step % 2 else 0.5),
                    COUNTS: (float(self.step), 0.0, 1.0),
                    DIRECTION_OFFSET: (0.0, math.nan, math.nan),
                    OPERATING_TIME: (t * self.utilisation, 0.0, 0.0)}
        vectors = [by_topic[topic] for topic in ESTIMATOR_TOPICS]
        stamp_ns = int(t * 1e9)
        for pub, (x, y, z) in zip(self.pubs, vectors):
            msg = Vector3Stamped()
            msg.header.stamp = stamp(stamp_ns)
            msg.vector.x, msg.vector.y, msg.vector.z = x, y, z
            pub.publish(msg)
        return stamp_ns
