"""``gear-phm monitor``: the three nodes in one process (see gear_phm.nodes.monitor)."""
from __future__ import annotations

import argparse

from gear_phm.nodes.executors import EXECUTORS

HELP = 'run publisher, estimator and diagnostics in one process'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--params-file', action='append', default=[], metavar='YAML',
                        help='ROS parameter file (repeatable), e.g. config/publisher.yaml')
    parser.add_argument('--no-publisher', action='store_true',
                        help='leave the publisher out (live bench data on joint_states)')
    parser.add_argument('--executor', choices=EXECUTORS, default='single',
                        help='rclpy executor (events = rclpy.experimental.EventsExecutor)')
    parser.add_argument('--linger', type=float, default=2.0, metavar='S',
                        help='seconds to keep spinning after the publisher finishes')
    parser.epilog = ('ROS arguments follow --ros-args, e.g. --ros-args -p '
                     'publisher:mode:=replay -p publisher:bag_path:=bags/wearing '
                     '(node:parameter targets one node)')


def run(args: argparse.Namespace) -> int:
    from gear_phm.cli.main import CliError
    from gear_phm.nodes.common import ConfigError
    from gear_phm.nodes.monitor import run_monitor

    if args.linger < 0:
        raise CliError(f'--linger must be >= 0, got {args.linger}')
    ros_args = [a for path in args.params_file for a in ('--params-file', path)]
    extra = list(args.ros_args)
    ros_args += extra[1:] if extra[:1] == ['--ros-args'] else extra
    try:
        return run_monitor(ros_args, with_publisher=not args.no_publisher,
                           executor=args.executor, linger=args.linger)
    except ConfigError as exc:
        raise CliError(str(exc)) from exc
