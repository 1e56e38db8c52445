"""Publisher, estimator and diagnostics in one process on one executor (``gear-phm monitor``).

For small targets: one Python interpreter and one DDS participant instead of three. Each node
reads its own section of the parameter files (keyed by node name: ``publisher``,
``estimator``, ``diagnostics``). With a finite replay or simulation, :func:`run_monitor`
returns once the publisher has finished and ``linger`` seconds have passed for the others.
"""
from __future__ import annotations

from collections.abc import Sequence
import time

import rclpy
from rclpy.node import Node

from gear_phm.nodes.common import (ConfigError, init_node_process, keep_spinning,
                                   SPIN_TIMEOUT_S, stop_signals, stopped_by_signal)
from gear_phm.nodes.diagnostics import DiagnosticsNode
from gear_phm.nodes.estimator import EstimatorNode
from gear_phm.nodes.executors import make_executor
from gear_phm.nodes.publisher import PublisherNode


def run_monitor(ros_args: Sequence[str], with_publisher: bool = True, executor: str = 'single',
                linger: float = 2.0) -> int:
    """Run the nodes until shutdown, or until the publisher finished ``linger`` [s] ago.

    ``ros_args`` are the arguments after ``--ros-args`` (parameter files, ``-p node:name:=v``).
    Start-up problems and a publisher that stopped on an error raise ConfigError (one line).
    """
    init_node_process(['gear-phm-monitor', '--ros-args', *ros_args])
    with stop_signals():        # SIGINT/SIGTERM end the loop; the nodes stop in order
        nodes: list[Node] = []
        publisher = None
        try:
            if with_publisher:
                publisher = PublisherNode()
                nodes.append(publisher)
            nodes += [EstimatorNode(), DiagnosticsNode()]
            spinner = make_executor(executor)
            for node in nodes:
                spinner.add_node(node)
            if publisher is not None:
                publisher.start()
            finished_at = None
            while keep_spinning():
                spinner.spin_once(timeout_sec=SPIN_TIMEOUT_S)
                if publisher is not None and publisher.finished.is_set():
                    finished_at = finished_at or time.monotonic()
                    if time.monotonic() - finished_at >= linger:
                        break
            if publisher is not None and publisher.error is not None:
                raise ConfigError(f'publisher stopped: {publisher.error}')
            return 0
        except ConfigError:
            raise
        except BaseException as exc:
            if stopped_by_signal(exc):
                return 0
            raise
        finally:
            if publisher is not None:
                publisher.stop()
            for node in reversed(nodes):
                node.destroy_node()
            rclpy.try_shutdown()
