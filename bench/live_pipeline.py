"""Live throughput and latency of the estimator (alone and with diagnostics) over real DDS.

Throughput: for each target (bare rclpy subscriber = baseline, estimator, estimator +
diagnostics) and each rate in ``--rates`` (ascending), a flood publisher process sends
``rate x duration`` JointState messages; the target's ``messages_received`` (from its
/diagnostics status) must equal the number sent. The highest zero-drop rate is reported, and
its ratio to the baseline's. Latency: at ``--latency-rates``, the time from a sample's stamp
(wall clock at publication) to the arrival, in this observer process, of the estimate stamped
with it (gear_phm/friction): p50, p99, max.

Usage: .venv/bin/python bench/live_pipeline.py [--duration 30] [--rates 500,1000,...]
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import append_section, BENCHMARKS_MD  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
BIN = Path(sys.executable).parent
TARGETS = {
    'bare subscriber (baseline)': [[sys.executable, str(ROOT / 'bench' / 'bare_subscriber.py')]],
    'estimator': [[str(BIN / 'estimator')]],
    'estimator + diagnostics': [[str(BIN / 'estimator')], [str(BIN / 'diagnostics')]],
}
RECEIVER_PREFIX = {'bare subscriber (baseline)': 'bench: bare_subscriber',
                   'estimator': 'gear_phm estimator', 'estimator + diagnostics':
                   'gear_phm estimator'}


class Observer:
    """rclpy node in this process: reads /diagnostics counts and estimate latencies."""

    def __init__(self) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import Vector3Stamped
        self.rclpy = rclpy
        rclpy.init()
        self.node = rclpy.create_node('bench_observer')
        self.counts: dict[str, int] = {}
        self.latencies: list[float] = []
        self.stream_end_ns: int | None = None   # wall time the flood publisher finished
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diag, 50)
        self.node.create_subscription(Vector3Stamped, 'gear_phm/friction', self._on_estimate,
                                      100)

    def _on_diag(self, msg) -> None:
        for status in msg.status:
            values = {kv.key: kv.value for kv in status.values}
            if 'messages_received' in values:
                self.counts[status.name] = int(values['messages_received'])

    def _on_estimate(self, msg) -> None:
        stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        now = time.time_ns()
        if self.stream_end_ns is None or now <= self.stream_end_ns:
            self.latencies.append((now - stamp_ns) * 1e-9)

    def received(self, prefix: str) -> int | None:
        hits = [v for k, v in self.counts.items() if k.startswith(prefix)]
        return max(hits) if hits else None

    def spin_until(self, condition, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.rclpy.spin_once(self.node, timeout_sec=0.05)
            if condition():
                return True
        return False

    def spin_for(self, seconds: float) -> None:
        self.spin_until(lambda: False, seconds)

    def close(self) -> None:
        self.node.destroy_node()
        self.rclpy.try_shutdown()


def run_trial(observer: Observer, target: str, rate: float,
              duration: float) -> tuple[int, int, list[float]]:
    """Start the target, flood it, return (sent, received, latencies [s])."""
    procs = [subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
             for cmd in TARGETS[target]]
    observer.counts.clear()
    observer.latencies.clear()
    observer.stream_end_ns = None
    prefix = RECEIVER_PREFIX[target]
    try:
        if not observer.spin_until(lambda: observer.received(prefix) is not None, 30.0):
            raise RuntimeError(f'{target}: no /diagnostics status within 30 s')
        flood = subprocess.Popen(
            [sys.executable, str(ROOT / 'bench' / 'flood_publisher.py'), '--rate', str(rate),
             '--duration', str(duration), '--subscribers', str(1)],
            stdout=subprocess.PIPE, text=True)
        # estimates after the stream ended (the sensor-timeout notice, stamped with the last
        # sample) are not the processing latency of a sample: stop collecting at 'sent='
        import threading
        lines: list[str] = []

        def read_stdout() -> None:
            for line in flood.stdout:
                if line.startswith('sent='):
                    observer.stream_end_ns = time.time_ns() + 50_000_000
                lines.append(line)
        reader = threading.Thread(target=read_stdout, daemon=True)
        reader.start()
        while flood.poll() is None:
            observer.spin_for(0.2)
        reader.join(timeout=5)
        latencies = list(observer.latencies)
        out = ''.join(lines)
        sent = int(out.split('sent=')[1].split()[0])
        last = -1
        # drain: wait until the count stops moving (2 s) or reaches `sent`
        deadline = time.monotonic() + 15.0
        while time.monotonic() < deadline:
            observer.spin_for(1.0)
            now = observer.received(prefix) or 0
            if now >= sent or now == last:
                break
            last = now
        return sent, observer.received(prefix) or 0, latencies
    finally:
        for proc in procs:
            proc.terminate()
        for proc in procs:
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--duration', type=float, default=30.0, help='seconds per trial')
    parser.add_argument('--rates', default='500,1000,1500,2000,3000,4000,6000,8000')
    parser.add_argument('--latency-rates', default='1000,5000')
    parser.add_argument('--targets', default=','.join(TARGETS))
    parser.add_argument('--no-append', action='store_true')
    args = parser.parse_args()
    os.environ.setdefault('ROS_DOMAIN_ID', str(150 + os.getpid() % 50))
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    rates = [float(r) for r in args.rates.split(',')]
    observer = Observer()
    best: dict[str, float] = {}
    rows = [['target', 'rate [Hz]', 'sent', 'received', 'drops']]
    try:
        for target in args.targets.split(','):
            best[target] = 0.0
            for rate in rates:
                sent, received, _ = run_trial(observer, target, rate, args.duration)
                rows.append([target, f'{rate:.0f}', str(sent), str(received),
                             str(sent - received)])
                print(rows[-1], flush=True)
                if received != sent:
                    break
                best[target] = rate
        latency_rows = [['rate [Hz]', 'estimates', 'p50 [ms]', 'p99 [ms]', 'max [ms]']]
        for rate in (float(r) for r in args.latency_rates.split(',')):
            _, _, lat = run_trial(observer, 'estimator', rate, args.duration)
            lat_ms = np.asarray(lat) * 1e3
            if lat_ms.size:
                latency_rows.append([f'{rate:.0f}', str(lat_ms.size),
                                     f'{np.percentile(lat_ms, 50):.2f}',
                                     f'{np.percentile(lat_ms, 99):.2f}', f'{lat_ms.max():.2f}'])
            else:
                latency_rows.append([f'{rate:.0f}', '0', '-', '-', '-'])
    finally:
        observer.close()
    out = None if args.no_append else BENCHMARKS_MD
    baseline = best.get('bare subscriber (baseline)', 0.0)
    summary = [['target', 'highest zero-drop rate [Hz]', 'ratio to bare subscriber']]
    for target, rate in best.items():
        ratio = f'{rate / baseline:.2f}' if baseline else '-'
        summary.append([target, f'{rate:.0f}', ratio])
    trials = ['| ' + ' | '.join(r) + ' |' for r in rows]
    trials.insert(1, '|' + '---|' * len(rows[0]))
    append_section(f'Live throughput, {args.duration:.0f} s per trial, zero drops', summary,
                   'Trials:\n\n' + '\n'.join(trials), out=out)
    append_section('Live latency: sample stamp -> estimate received by an observer process',
                   latency_rows, out=out)
    return 0


if __name__ == '__main__':
    sys.exit(main())
