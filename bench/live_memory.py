"""Memory of the live nodes over a long replay: RSS against the bag time they have processed.

Starts the three nodes as processes over DDS: ``publisher`` replaying a simulated 1 kHz bag
(``mode: replay`` at ``--rate-factor``, by default 1000, the highest it accepts, so it
publishes as fast as it can; bag stamps, so the estimator sees 1 kHz; no truth topics),
``estimator`` (``--executor``, by default its default ``events``) and ``diagnostics`` with
their defaults. Every ``--interval`` s it reads each
node's RSS from /proc and how far the estimator has got in bag time (the stamp of its latest
``gear_phm/operating_time``), for ``--minutes`` of wall time or until the bag is replayed.
The slope of RSS against processed bag time is a least-squares fit after the ``--warmup``
share of the run, in MiB per hour of 1 kHz input, with the growth it implies over a
simulated day (24 h of 1 kHz, 86.4M samples).

Usage: .venv/bin/python bench/live_memory.py [--bag DIR] [--minutes 10] [--interval 10]
[--no-append]  (without ``--bag`` it simulates a 1-hour 1 kHz bag into a temporary folder)
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import append_section, BENCHMARKS_MD, rss_mib  # noqa: E402

BIN = Path(sys.executable).parent
NODES = ('publisher', 'estimator', 'diagnostics')
DAY_H = 24.0


def node_commands(bag: str, rate_factor: float, executor: str) -> dict[str, list[str]]:
    """Return the three nodes' command lines."""
    replay = ['--ros-args', '-p', 'mode:=replay', '-p', f'bag_path:={bag}', '-p',
              f'rate_factor:={rate_factor!r}', '-p', 'replay_truth:=false', '-p',
              'wait_for_subscribers:=1']
    return {'publisher': [str(BIN / 'publisher'), *replay],
            'estimator': [str(BIN / 'estimator'), '--ros-args', '-p', f'executor:={executor}'],
            'diagnostics': [str(BIN / 'diagnostics')]}


class Progress:
    """How far the estimator has got: the latest stamp [ns] of its operating-time output."""

    def __init__(self) -> None:
        import rclpy
        from geometry_msgs.msg import Vector3Stamped

        from gear_phm.interfaces import OPERATING_TIME
        rclpy.init()
        self.node = rclpy.create_node('live_memory_bench')
        self.first_ns: int | None = None
        self.last_ns: int | None = None
        self.node.create_subscription(Vector3Stamped, OPERATING_TIME, self._on, 100)

    def _on(self, msg) -> None:
        t_ns = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
        if self.first_ns is None:
            self.first_ns = t_ns
        self.last_ns = t_ns if self.last_ns is None else max(self.last_ns, t_ns)

    def bag_hours(self) -> float:
        if self.first_ns is None or self.last_ns is None:
            return 0.0
        return (self.last_ns - self.first_ns) / 3.6e12

    def spin_for(self, seconds: float) -> None:
        import rclpy
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            rclpy.spin_once(self.node, timeout_sec=min(0.1, max(end - time.monotonic(), 0)))

    def close(self) -> None:
        import rclpy
        self.node.destroy_node()
        rclpy.shutdown()


def run(bag: str, rate_factor: float, executor: str, minutes: float,
        interval: float) -> list[tuple[float, float, dict[str, float]]]:
    """(wall [s], processed bag time [h], RSS [MiB] per node) every ``interval`` s."""
    env = dict(os.environ)
    env.setdefault('ROS_DOMAIN_ID', str(150 + os.getpid() % 50))
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ.update(env)
    progress = Progress()
    procs = {name: subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL,
                                    stderr=subprocess.DEVNULL)
             for name, command in node_commands(bag, rate_factor, executor).items()}
    samples = []
    try:
        start = time.monotonic()
        while time.monotonic() - start < minutes * 60.0:
            progress.spin_for(interval)
            for name, proc in procs.items():
                if proc.poll() is not None and (name != 'publisher' or proc.returncode):
                    raise RuntimeError(f'{name} exited with {proc.returncode}')
            if procs['publisher'].poll() is not None:
                break                               # the whole bag is replayed
            rss = {name: rss_mib(proc.pid) for name, proc in procs.items()}
            samples.append((time.monotonic() - start, progress.bag_hours(), rss))
            print(f'{samples[-1][0]:6.0f} s  bag {samples[-1][1]:.3f} h  ' + '  '.join(
                f'{name} {value:.1f}' for name, value in rss.items()), flush=True)
    finally:
        for proc in procs.values():
            proc.terminate()
        for proc in procs.values():
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                proc.kill()
        progress.close()
    return samples


def table(samples: list[tuple[float, float, dict[str, float]]],
          warmup: float) -> list[list[str]]:
    """Per node: RSS after warm-up and at the end, and the fitted slope."""
    kept = [s for s in samples if s[1] > 0 and s[1] >= warmup * samples[-1][1]]
    hours = np.array([s[1] for s in kept])
    rows = [['node', f'RSS at {kept[0][1]:.2f} h [MiB]', f'RSS at {kept[-1][1]:.2f} h [MiB]',
             'peak [MiB]', 'slope [MiB per h of 1 kHz input]', 'implied over 24 h [MiB]']]
    for name in NODES:
        rss = np.array([s[2][name] for s in kept])
        slope = float(np.polyfit(hours, rss, 1)[0]) if np.ptp(hours) > 0 else float('nan')
        rows.append([name, f'{rss[0]:.1f}', f'{rss[-1]:.1f}',
                     f'{max(s[2][name] for s in samples):.1f}', f'{slope:+.2f}',
                     f'{slope * DAY_H:+.0f}'])
    wall = samples[-1][0]
    rows.append(['(bag time reached)', f'{kept[-1][1] * 3.6e6 / 1e6:.2f}M samples in {wall:.0f} s',
                 f'{kept[-1][1] * 3.6e6 / wall:,.0f} samples/s', '', '', ''])
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--bag', default=None, help='a 1 kHz bag to replay')
    parser.add_argument('--rate-factor', type=float, default=1000.0,
                        help='replay speed-up (1000, the highest, publishes as fast as the '
                        'publisher can; lower keeps the input within what the estimator '
                        'processes)')
    parser.add_argument('--executor', choices=('events', 'single'), default='events',
                        help="the estimator's executor parameter")
    parser.add_argument('--minutes', type=float, default=10.0, help='wall time to run')
    parser.add_argument('--interval', type=float, default=10.0, help='RSS sampling [s]')
    parser.add_argument('--warmup', type=float, default=0.2,
                        help='share of the processed bag time left out of the fit')
    parser.add_argument('--no-append', action='store_true')
    args = parser.parse_args()
    folder = None
    bag = args.bag
    if bag is None:
        folder = tempfile.mkdtemp(prefix='gear-phm-live-memory-')
        bag = str(Path(folder) / 'bag')
        subprocess.run([str(BIN / 'gear-phm'), 'simulate', '--duration', '3600', '--rate',
                        '1000', '--out', bag], check=True, capture_output=True)
    try:
        samples = run(bag, args.rate_factor, args.executor, args.minutes, args.interval)
    finally:
        if folder is not None:
            shutil.rmtree(folder, ignore_errors=True)
    append_section(f'Memory: live nodes over a long replay at rate_factor {args.rate_factor:g} '
                   f'(1 kHz bag, estimator executor {args.executor})',
                   table(samples, args.warmup), out=None if args.no_append else BENCHMARKS_MD)
    return 0


if __name__ == '__main__':
    sys.exit(main())
