"""Shared test set-up: isolate DDS traffic of this test run and give helpers to tests."""
from __future__ import annotations

import os
import sys

import pytest

from helpers.processes import udp_only_env

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

# The suite starts hundreds of Python processes (the CLI, the nodes, the bench scripts). With
# PYTHONDONTWRITEBYTECODE set (this project's machines set it) each of them compiled
# gear_phm's sources again, and each pytest worker the test modules: test_publisher and
# test_analyze_cli took 44.6 s of CPU so, 36.6 s with the bytecode cache. This run writes the
# cache once (__pycache__/, git-ignored) and its processes reuse it.
os.environ.pop('PYTHONDONTWRITEBYTECODE', None)
sys.dont_write_bytecode = False


@pytest.fixture
def sigkill_safe_env() -> dict[str, str]:
    """Environment for a ROS process that a test kills with SIGKILL on purpose (UDP only).

    :func:`helpers.processes.udp_only_env` says why.
    """
    return udp_only_env()


def worksteal_shares(count: int, workers: int) -> list[int]:
    """Return how many of ``count`` tests each of ``workers`` gets at the start of a run.

    pytest-xdist's ``--dist worksteal`` deals the collection out in contiguous shares, in
    order: each worker in turn gets the remaining tests divided by the workers still to serve.
    """
    shares = []
    for served in range(workers):
        shares.append((count - sum(shares)) // (workers - served))
    return shares


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """On pytest-xdist workers, put each ``long`` test at the head of a worker's share.

    The shares are those of ``--dist worksteal`` (setup.cfg; a worker cannot see the mode,
    its own is ``no``). A share is run from its head; idle workers take the second half of
    the longest queue. A long test at the end of the collection
    (integration/test_state_file.py, integration/test_transmissions_live.py) would start late
    and finish the run alone on one core. The long tests are dealt out longest first (their
    marker's seconds), each to the share with the fewest long seconds so far, and start at
    once; the other tests keep their order.
    Each worker computes the same order, as pytest-xdist requires.
    """
    workers = int(getattr(config, 'workerinput', {}).get('workercount', 0))
    long = sorted((item for item in items if item.get_closest_marker('long')),
                  key=lambda item: -float(item.get_closest_marker('long').args[0]))
    if not workers or not long:
        return
    heads: list[list[pytest.Item]] = [[] for _ in range(workers)]
    seconds = [0.0] * workers
    for item in long:
        share = min(range(workers), key=lambda k: (seconds[k], k))
        heads[share].append(item)
        seconds[share] += float(item.get_closest_marker('long').args[0])
    rest = iter([item for item in items if not item.get_closest_marker('long')])
    ordered: list[pytest.Item] = []
    for head, share in zip(heads, worksteal_shares(len(items), workers)):
        ordered += head
        ordered += [item for _, item in zip(range(share - len(head)), rest)]
    ordered += rest
    items[:] = ordered


#: Where each pytest-xdist worker of a run writes faulthandler's report of a fatal error (a
#: worker crashed twice in integration/test_diagnostics_node.py with only "node down: Not
#: properly terminated"); the controller prints any at the end of the run.
CRASH_LOG = 'GEAR_PHM_TEST_CRASH_LOG'


@pytest.hookimpl(trylast=True)             # after pytest's own faulthandler set-up
def pytest_configure(config: pytest.Config) -> None:
    """On a worker: faulthandler writes to its crash log (a fatal signal's Python stacks)."""
    import faulthandler
    import tempfile
    worker = os.environ.get('PYTEST_XDIST_WORKER')
    if worker is None:
        os.environ.setdefault(CRASH_LOG, tempfile.mkdtemp(prefix='gear-phm-crashes-'))
        return
    folder = os.environ.get(CRASH_LOG)
    if folder and os.path.isdir(folder):
        config._gear_phm_crash_log = open(os.path.join(folder, f'{worker}.log'), 'a')
        faulthandler.enable(file=config._gear_phm_crash_log, all_threads=True)


def pytest_unconfigure(config: pytest.Config) -> None:
    """On the controller: print the workers' crash reports, if any, and remove them."""
    import shutil
    if os.environ.get('PYTEST_XDIST_WORKER') is not None:
        return
    folder = os.environ.get(CRASH_LOG)
    if not folder or not os.path.isdir(folder):
        return
    for name in sorted(os.listdir(folder)):
        with open(os.path.join(folder, name)) as handle:
            report = handle.read().strip()
        if report:
            sys.stderr.write(f'\n--- faulthandler report of worker {name[:-4]} ---\n'
                             f'{report}\n')
    shutil.rmtree(folder, ignore_errors=True)
