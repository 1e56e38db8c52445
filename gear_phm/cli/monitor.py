"""``gear-phm monitor``: publisher, estimator and diagnostics in one process, one executor.

For small targets: one Python interpreter and one DDS participant instead of three. Each node
reads its own section of the parameter files (keyed by node name: ``publisher``,
``estimator``, ``diagnostics``). With a finite replay or simulation, the command returns once
the publisher has finished and ``--linger`` seconds have passed for the others to catch up.
"""
from __future__ import annotations

import argparse
import time

HELP = 'run publisher, estimator and diagnostics in one process'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--params-file', action='append', default=[], metavar='YAML',
                        help='ROS parameter file (repeatable), e.g. config/publisher.yaml')
    parser.add_argument('--no-publisher', action='store_true',
                        help='leave the publisher out (live bench data on joint_states)')
    parser.add_argument('--executor', choices=('single', 'multi', 'events'), default='single',
                        help='rclpy executor (events = rclpy.experimental.EventsExecutor)')
    parser.add_argument('--linger', type=float, default=2.0, metavar='S',
                        help='seconds to keep spinning after the publisher finishes')
    parser.epilog = ('ROS arguments follow --ros-args, e.g. --ros-args -p '
                     'publisher:mode:=replay -p publisher:bag_path:=bags/wearing '
                     '(node:parameter targets one node)')


def _executor(kind: str):
    from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor
    if kind == 'multi':
        return MultiThreadedExecutor(num_threads=3)
    if kind == 'events':
        from rclpy.experimental import EventsExecutor
        return EventsExecutor()
    return SingleThreadedExecutor()


def run(args: argparse.Namespace) -> int:
    import rclpy
    from rclpy._rclpy_pybind11 import RCLError
    from rclpy.executors import ExternalShutdownException

    from gear_phm.cli.main import CliError
    from gear_phm.nodes.common import ConfigError
    from gear_phm.nodes.diagnostics import DiagnosticsNode
    from gear_phm.nodes.estimator import EstimatorNode
    from gear_phm.nodes.publisher import PublisherNode

    if args.linger < 0:
        raise CliError(f'--linger must be >= 0, got {args.linger}')
    extra = list(args.ros_args)
    if extra and extra[0] == '--ros-args':
        extra = extra[1:]
    ros_args = ['--ros-args']
    for path in args.params_file:
        ros_args += ['--params-file', path]
    rclpy.init(args=['gear-phm-monitor', *ros_args, *extra])
    nodes: list = []
    publisher = None
    try:
        try:
            if not args.no_publisher:
                publisher = PublisherNode()
                nodes.append(publisher)
            nodes.append(EstimatorNode())
            nodes.append(DiagnosticsNode())
        except ConfigError as exc:
            raise CliError(str(exc)) from exc
        executor = _executor(args.executor)
        for node in nodes:
            executor.add_node(node)
        if publisher is not None:
            publisher.start()
        finished_at = None
        while rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
            if publisher is not None and publisher.finished.is_set():
                finished_at = finished_at or time.monotonic()
                if time.monotonic() - finished_at >= args.linger:
                    break
        if publisher is not None and publisher.error is not None:
            raise CliError(f'publisher stopped: {publisher.error}')
        return 0
    except (KeyboardInterrupt, ExternalShutdownException):
        return 0
    except RCLError:
        if not rclpy.ok():    # a signal shut the context down mid-callback: clean stop
            return 0
        raise
    finally:
        if publisher is not None:
            publisher.stop()
        for node in reversed(nodes):
            node.destroy_node()
        rclpy.try_shutdown()
