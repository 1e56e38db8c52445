"""Shared test set-up: isolate DDS traffic of this test run and give helpers to tests."""
from __future__ import annotations

import os

# One DDS domain per pytest process, on loopback only, so that parallel runs (or a developer's
# own ROS graph) never see each other. Set before anything imports rclpy.
os.environ.setdefault('ROS_DOMAIN_ID', str(100 + os.getpid() % 100))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp')
