"""The executors the nodes spin on and their parameter (gear_phm.nodes.executors)."""
from __future__ import annotations

import pytest

from gear_phm.nodes.executors import (executor_parameter, EXECUTORS, make_executor,
                                      NODE_EXECUTORS)


def test_the_executor_parameter_offers_the_node_executors() -> None:
    spec = executor_parameter()
    assert (spec.name, spec.default, spec.choices, spec.read_only) == (
        'executor', 'events', NODE_EXECUTORS, True)
    assert executor_parameter('single').default == 'single'
    assert set(NODE_EXECUTORS) < set(EXECUTORS) and 'multi' not in NODE_EXECUTORS


def test_make_executor_makes_the_kind_named() -> None:
    rclpy = pytest.importorskip('rclpy')
    rclpy.init()                        # the executors take the default context
    try:
        for kind, name in (('single', 'SingleThreadedExecutor'),
                           ('multi', 'MultiThreadedExecutor'), ('events', 'EventsExecutor'),
                           ('other', 'SingleThreadedExecutor')):
            executor = make_executor(kind)
            assert type(executor).__name__ == name, kind
            executor.shutdown()
    finally:
        rclpy.try_shutdown()
