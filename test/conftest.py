"""Shared test set-up: isolate DDS traffic of this test run and give helpers to tests."""
from __future__ import annotations

import os

import pytest

#: The DDS domain of a test run's first worker; the controller of a run picks it once and
#: its pytest-xdist workers inherit it.
DOMAIN_BASE = 'GEAR_PHM_TEST_DOMAIN_BASE'
#: Largest ROS_DOMAIN_ID that Fast DDS maps to valid UDP ports (7400 + 250 d + ...).
DOMAIN_MAX = 232


def _domain_id() -> int:
    """Return this pytest process's DDS domain: the run's base plus the xdist worker number.

    The base is ROS_DOMAIN_ID if set, else derived from the pid of the run's controller, so
    that two runs differ; worker gwN uses base + N, so two workers of a run never share one.
    """
    base = os.environ.get(DOMAIN_BASE)
    if base is None:
        base = os.environ.get('ROS_DOMAIN_ID') or str(100 + os.getpid() % 100)
        os.environ[DOMAIN_BASE] = base
    worker = os.environ.get('PYTEST_XDIST_WORKER', 'gw0')
    domain = int(base) + int(worker.removeprefix('gw'))
    if domain > DOMAIN_MAX:
        msg = (f'ROS_DOMAIN_ID {base} plus worker {worker} is domain {domain}, above '
               f'{DOMAIN_MAX}: set a lower ROS_DOMAIN_ID')
        raise pytest.UsageError(msg)
    return domain


# One DDS domain per pytest process, on loopback only, so that parallel runs, the workers of
# one run, or a developer's own ROS graph never see each other. Set before anything imports
# rclpy; the node processes that tests start inherit it.
os.environ['ROS_DOMAIN_ID'] = str(_domain_id())
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
