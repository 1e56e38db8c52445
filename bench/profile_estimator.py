"""Profile the estimator node's callback path under a live stream (pyinstrument).

Runs the estimator node in this process on the chosen executor while
``bench/flood_publisher.py`` sends ``--rate`` Hz for ``--duration`` s, and prints
pyinstrument's call tree of the spinning thread (wall time, so the time rclpy spends waiting
for work shows up as ``spin_once`` -> wait) and the process CPU per message.

Usage: .venv/bin/python bench/profile_estimator.py [--rate 1000] [--executor single]
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path
import subprocess
import sys
import time

ROOT = Path(__file__).resolve().parent.parent


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--rate', type=float, default=1000.0)
    parser.add_argument('--duration', type=float, default=10.0)
    parser.add_argument('--executor', choices=('single', 'events'), default='single')
    parser.add_argument('--interval', type=float, default=0.0005, help='sampling [s]')
    args = parser.parse_args()
    os.environ.setdefault('ROS_DOMAIN_ID', str(150 + os.getpid() % 50))
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    import rclpy
    from pyinstrument import Profiler

    from gear_phm.nodes.estimator import EstimatorNode
    from gear_phm.nodes.executors import make_executor
    rclpy.init(args=['profile_estimator', '--ros-args', '-p', f'executor:={args.executor}'])
    node = EstimatorNode()
    executor = make_executor(args.executor)
    executor.add_node(node)
    flood = subprocess.Popen([sys.executable, str(ROOT / 'bench' / 'flood_publisher.py'),
                              '--rate', str(args.rate), '--duration', str(args.duration)],
                             stdout=subprocess.PIPE, text=True)
    while node.messages_received == 0 and flood.poll() is None:
        executor.spin_once(timeout_sec=0.1)
        node._flush()
    profiler = Profiler(interval=args.interval)
    cpu0, received0 = time.process_time(), node.messages_received + len(node.stamps)
    profiler.start()
    while flood.poll() is None:
        executor.spin_once(timeout_sec=0.1)
    profiler.stop()
    cpu = time.process_time() - cpu0
    received = node.messages_received + len(node.stamps) - received0
    print(profiler.output_text(unicode=False, color=False, show_all=False))
    print(f'{received} messages, process CPU {cpu:.2f} s = {cpu / max(received, 1) * 1e6:.0f} '
          f'us per message ({args.executor} executor, {args.rate:.0f} Hz)')
    print(flood.stdout.read().strip())
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
