"""Shared test set-up: isolate DDS traffic of this test run and give helpers to tests."""
from __future__ import annotations

import os

import pytest

# One DDS domain per pytest process, on loopback only, so that parallel runs (or a developer's
# own ROS graph) never see each other. Set before anything imports rclpy.
os.environ.setdefault('ROS_DOMAIN_ID', str(100 + os.getpid() % 100))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp')


@pytest.fixture
def sigkill_safe_env() -> dict[str, str]:
    """Environment for a ROS process that a test kills with SIGKILL on purpose.

    Fast DDS's shared-memory transport keeps robust mutexes and port queues in /dev/shm; a
    participant killed in the middle of using them can leave them in a state that makes a
    later participant hang (eProsima/Fast-DDS#1144). Once, in a fresh clone, a publisher
    started after the kill tests printed its start-up error and then never exited. The
    killed process therefore uses UDPv4 only; the processes it talks to keep the default
    transports and reach it over UDP.
    """
    return {**os.environ, 'FASTDDS_BUILTIN_TRANSPORTS': 'UDPv4'}
