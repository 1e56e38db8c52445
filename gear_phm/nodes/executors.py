"""The rclpy executors the nodes spin on, and the ``executor`` node parameter (one home).

``events`` is rclpy.experimental.EventsExecutor: about 2.5x less CPU per message than
``single`` (SingleThreadedExecutor), which rebuilds its wait set at every callback
(docs/benchmarks.md). Its event queue is not bounded: a node fed faster than it can work
grows in memory, where ``single`` drops from the subscription's queue and counts the loss.
``multi`` (MultiThreadedExecutor, 3 threads) is for ``gear-phm monitor`` only.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from gear_phm.parameters import ParamSpec

if TYPE_CHECKING:       # rclpy is imported where an executor is made: the CLI reads the names
    from rclpy.executors import Executor
    from rclpy.node import Node

#: Executors of a node process; ``gear-phm monitor`` also takes 'multi'.
NODE_EXECUTORS = ('events', 'single')
EXECUTORS = ('single', 'multi', 'events')


def executor_parameter(default: str = 'events') -> ParamSpec:
    """Return the ``executor`` parameter of a node process."""
    return ParamSpec('executor', default, 'rclpy executor: events (rclpy.experimental.'
                     'EventsExecutor, about 2.5x less CPU per message here) or single '
                     '(SingleThreadedExecutor)', choices=NODE_EXECUTORS, read_only=True)


def make_executor(kind: str) -> Executor:
    """'single', 'multi' (3 threads) or 'events' (rclpy.experimental.EventsExecutor)."""
    from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor
    if kind == 'multi':
        return MultiThreadedExecutor(num_threads=3)
    if kind == 'events':
        from rclpy.experimental import EventsExecutor
        return EventsExecutor()
    return SingleThreadedExecutor()


def spin_executor(node: Node, kind: str) -> None:
    """Spin ``node`` on a new executor of ``kind`` until a stop request or context shutdown.

    Calls ``spin_once`` with a timeout rather than ``spin()``: in this rclpy (Jazzy)
    ``EventsExecutor.spin()`` polls and keeps a core about half busy with no work at all
    (measured: 0.45 s of CPU per second with one 1 s timer), ``spin_once(timeout_sec)``
    sleeps until an event. The timeout bounds how late a SIGINT/SIGTERM is seen
    (gear_phm.nodes.common.stop_signals).
    """
    from gear_phm.nodes.common import keep_spinning, SPIN_TIMEOUT_S
    executor = make_executor(kind)
    executor.add_node(node)
    try:
        while keep_spinning(node.context):
            executor.spin_once(timeout_sec=SPIN_TIMEOUT_S)
    finally:
        executor.shutdown()
