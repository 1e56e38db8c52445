"""Live throughput, CPU, idle cost and latency of the estimator over real DDS.

Each as a ratio to a bare rclpy subscriber with the same QoS and executor, measured in the same
run.

- **Throughput**: for each target (bare subscriber = baseline, estimator, estimator +
  diagnostics; on request ``'bare subscriber (serialized)'``, a raw subscription) and each
  rate in ``--rates`` (ascending), a flood publisher process sends ``rate x duration``
  JointState messages; the target's ``messages_received`` (its /diagnostics status) must
  equal the number sent. The highest zero-loss rate is reported.
- **CPU per message, side by side**: at each of ``--cpu-rates`` the bare subscriber and the
  estimator take the same stream at once; CPU time of each process (all threads, from
  /proc/<pid>/task/*/schedstat) over the stream, divided by the messages it received.
- **Idle**: CPU of each target over ``--idle`` s without input, as a share of one core.
- **Latency**: at ``--latency-rates``, the time from a sample's stamp (wall clock at
  publication) to the arrival, in this observer process, of the estimate stamped with it
  (gear_phm/friction): p50, p99, max.

``--executor single|events`` chooses the rclpy executor of every target (the bare subscriber
uses the same). ``--repeat`` runs the CPU and idle measurements several times.

Usage: .venv/bin/python bench/live_pipeline.py [--duration 20] [--executor single]
"""
from __future__ import annotations

import argparse
import glob
import os
from pathlib import Path
import subprocess
import sys
import threading
import time

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import append_section, BENCHMARKS_MD  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
BIN = Path(sys.executable).parent
BARE = 'bare subscriber (baseline)'
BARE_RAW = 'bare subscriber (serialized)'
TARGETS = (BARE, 'estimator', 'estimator + diagnostics')
RECEIVER = {BARE: 'bench: bare_subscriber', BARE_RAW: 'bench: bare_subscriber',
            'estimator': 'gear_phm estimator', 'estimator + diagnostics': 'gear_phm estimator'}


def commands(target: str, executor: str) -> list[list[str]]:
    bare = [sys.executable, str(ROOT / 'bench' / 'bare_subscriber.py'), '--executor', executor]
    estimator = [str(BIN / 'estimator'), '--ros-args', '-p', f'executor:={executor}']
    if target == BARE:
        return [bare]
    if target == BARE_RAW:                  # rclpy's floor: no Python message object
        return [bare + ['--raw']]
    if target == 'estimator':
        return [estimator]
    return [estimator, [str(BIN / 'diagnostics')]]


def cpu_ns(pid: int) -> int:
    """CPU time of all threads of process ``pid`` so far [ns]."""
    total = 0
    for path in glob.glob(f'/proc/{pid}/task/*/schedstat'):
        try:
            with open(path, encoding='ascii') as stream:
                total += int(stream.read().split()[0])
        except (OSError, ValueError, IndexError):
            pass            # a thread that ended meanwhile
    return total


def load_average() -> str:
    return ', '.join(f'{v:.2f}' for v in os.getloadavg())


class Observer:
    """rclpy node in this process: reads /diagnostics counts and estimate latencies.

    It spins an EventsExecutor, the lightest wake-up rclpy offers, so its own delay adds little to
    the latency it measures.
    """

    def __init__(self) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import Vector3Stamped

        from gear_phm.interfaces import FRICTION
        self.rclpy = rclpy
        rclpy.init()
        self.node = rclpy.create_node('bench_observer')
        self.counts: dict[str, int] = {}
        self.latencies: list[float] = []
        self.stream_end_ns: int | None = None   # wall time the flood publisher finished
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diag, 50)
        self.node.create_subscription(Vector3Stamped, FRICTION, self._on_estimate, 100)
        from rclpy.experimental import EventsExecutor
        self.executor = EventsExecutor()
        self.executor.add_node(self.node)

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
            self.executor.spin_once(timeout_sec=0.05)
            if condition():
                return True
        return False

    def spin_for(self, seconds: float) -> None:
        self.spin_until(lambda: False, seconds)

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.rclpy.try_shutdown()


class Targets:
    """Node processes started together; stopped on exit."""

    def __init__(self, observer: Observer, cmds: list[list[str]], receivers: list[str]) -> None:
        self.observer = observer
        self.receivers = receivers
        observer.counts.clear()
        self.procs = [subprocess.Popen(cmd, stdout=subprocess.DEVNULL,
                                       stderr=subprocess.DEVNULL) for cmd in cmds]

    def __enter__(self) -> Targets:
        if not self.observer.spin_until(
                lambda: all(self.observer.received(r) is not None for r in self.receivers),
                60.0):
            self.__exit__()
            raise RuntimeError(f'{self.receivers}: no /diagnostics status within 60 s')
        return self

    def cpu(self) -> list[int]:
        return [cpu_ns(p.pid) for p in self.procs]

    def __exit__(self, *exc) -> None:
        for proc in self.procs:
            proc.terminate()
        for proc in self.procs:
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()


def flood(observer: Observer, rate: float, duration: float, subscribers: int,
          receivers: list[str]) -> int:
    """Publish the stream, wait for the counts to settle; return the number sent."""
    observer.latencies.clear()
    observer.stream_end_ns = None
    proc = subprocess.Popen(
        [sys.executable, str(ROOT / 'bench' / 'flood_publisher.py'), '--rate', str(rate),
         '--duration', str(duration), '--subscribers', str(subscribers)],
        stdout=subprocess.PIPE, text=True)
    lines: list[str] = []

    def read_stdout() -> None:
        for line in proc.stdout:
            if line.startswith('sent='):
                observer.stream_end_ns = time.time_ns() + 50_000_000
            lines.append(line)
    reader = threading.Thread(target=read_stdout, daemon=True)
    reader.start()
    while proc.poll() is None:
        observer.spin_for(0.2)
    reader.join(timeout=5)
    sent = int(''.join(lines).split('sent=')[1].split()[0])
    last: list[int | None] = [None] * len(receivers)
    deadline = time.monotonic() + 15.0
    while time.monotonic() < deadline:          # until every count reaches sent or stops
        observer.spin_for(1.2)
        now = [observer.received(r) or 0 for r in receivers]
        if all(n >= sent for n in now) or now == last:
            break
        last = now
    return sent


def throughput(observer: Observer, target: str, executor: str, rates: list[float],
               duration: float, rows: list[list[str]]) -> float:
    best = 0.0
    for rate in rates:
        with Targets(observer, commands(target, executor), [RECEIVER[target]]):
            sent = flood(observer, rate, duration, 1, [RECEIVER[target]])
            received = observer.received(RECEIVER[target]) or 0
        rows.append([target, f'{rate:.0f}', str(sent), str(received), str(sent - received)])
        print(rows[-1], flush=True)
        if received != sent:
            break
        best = rate
    return best


def side_by_side(observer: Observer, executor: str, rate: float,
                 duration: float) -> tuple[float, float, int, int, int]:
    """(bare us/msg, estimator us/msg, sent, bare received, estimator received)."""
    cmds = commands(BARE, executor) + commands('estimator', executor)
    receivers = [RECEIVER[BARE], RECEIVER['estimator']]
    with Targets(observer, cmds, receivers) as targets:
        observer.spin_for(2.0)
        before = targets.cpu()
        sent = flood(observer, rate, duration, 2, receivers)
        after = targets.cpu()
        got = [observer.received(r) or 0 for r in receivers]
    per = [(a - b) / max(n, 1) * 1e-3 for a, b, n in zip(after, before, got)]
    return per[0], per[1], sent, got[0], got[1]


def idle(observer: Observer, executor: str, seconds: float) -> tuple[float, float]:
    """Share of one core [%] used by the bare subscriber and the estimator with no input."""
    cmds = commands(BARE, executor) + commands('estimator', executor)
    with Targets(observer, cmds, [RECEIVER[BARE], RECEIVER['estimator']]) as targets:
        observer.spin_for(3.0)
        before = targets.cpu()
        start = time.monotonic()
        observer.spin_for(seconds)
        after = targets.cpu()
        elapsed = time.monotonic() - start
    bare, estimator = ((a - b) * 1e-9 / elapsed * 100.0 for a, b in zip(after, before))
    return bare, estimator


def latency(observer: Observer, executor: str, rate: float, duration: float) -> list[str]:
    from gear_phm.interfaces import FRICTION
    with Targets(observer, commands('estimator', executor), [RECEIVER['estimator']]):
        # its estimates reach this process only once its estimate writer matched our reader:
        # a /diagnostics status does not say so (a short stream was all sent before, 0 seen)
        if not observer.spin_until(lambda: observer.node.count_publishers(FRICTION) >= 1,
                                   30.0):
            raise RuntimeError(f'{FRICTION}: no writer matched within 30 s')
        flood(observer, rate, duration, 1, [RECEIVER['estimator']])
        lat_ms = np.asarray(observer.latencies) * 1e3
    if not lat_ms.size:
        return [f'{rate:.0f}', '0', '-', '-', '-']
    return [f'{rate:.0f}', str(lat_ms.size), f'{np.percentile(lat_ms, 50):.2f}',
            f'{np.percentile(lat_ms, 99):.2f}', f'{lat_ms.max():.2f}']


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--duration', type=float, default=20.0, help='seconds per stream')
    parser.add_argument('--executor', choices=('events', 'single'), default='events')
    parser.add_argument('--rates', default='1000,2000,3000,4000,5000,6000,8000',
                        help='throughput rates [Hz], ascending ("" skips throughput)')
    parser.add_argument('--targets', default=','.join(TARGETS))
    parser.add_argument('--cpu-rates', default='1000,100', help='side-by-side rates [Hz]')
    parser.add_argument('--idle', type=float, default=20.0, help='idle seconds (0 skips)')
    parser.add_argument('--latency-rates', default='1000')
    parser.add_argument('--repeat', type=int, default=1, help='CPU and idle repetitions')
    parser.add_argument('--no-append', action='store_true')
    args = parser.parse_args()
    os.environ.setdefault('ROS_DOMAIN_ID', str(150 + os.getpid() % 50))
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    out = None if args.no_append else BENCHMARKS_MD
    executor = args.executor
    load_before = load_average()
    observer = Observer()
    try:
        # warm-up, discarded: the first DDS stream after the machine's first node start lost
        # 2 % of a 1 kHz stream (203 of 10,000, 2026-11-24, quiet machine) that every later
        # trial delivered whole
        throughput(observer, BARE, executor, [1000.0], 2.0, [])
        best: dict[str, float] = {}
        trials = [['target', 'rate [Hz]', 'sent', 'received', 'lost']]
        rates = [float(r) for r in args.rates.split(',') if r]
        for target in (args.targets.split(',') if rates else []):
            best[target] = throughput(observer, target, executor, rates, args.duration,
                                      trials)
        cpu_rows = [['rate [Hz]', 'run', 'bare [us/msg]', 'estimator [us/msg]', 'ratio',
                     'received bare / estimator / sent']]
        idle_rows = [['run', 'bare [% of a core]', 'estimator [% of a core]']]
        for run in range(1, args.repeat + 1):
            for rate in (float(r) for r in args.cpu_rates.split(',') if r):
                bare, est, sent, got_bare, got_est = side_by_side(observer, executor, rate,
                                                                  args.duration)
                cpu_rows.append([f'{rate:.0f}', str(run), f'{bare:.0f}', f'{est:.0f}',
                                 f'{est / bare:.2f}', f'{got_bare} / {got_est} / {sent}'])
                print(cpu_rows[-1], flush=True)
            if args.idle > 0:
                bare, est = idle(observer, executor, args.idle)
                idle_rows.append([str(run), f'{bare:.2f}', f'{est:.2f}'])
                print(idle_rows[-1], flush=True)
        latency_rows = [['rate [Hz]', 'estimates', 'p50 [ms]', 'p99 [ms]', 'max [ms]']]
        for rate in (float(r) for r in args.latency_rates.split(',') if r):
            latency_rows.append(latency(observer, executor, rate, args.duration))
            print(latency_rows[-1], flush=True)
    finally:
        observer.close()
    note = (f'Executor: {executor}. Load average before the run: {load_before}; after: '
            f'{load_average()} (2 cores, shared with other jobs).')
    if best:
        baseline = best.get(BARE, 0.0)
        summary = [['target', 'highest zero-loss rate [Hz]', 'ratio to bare subscriber']]
        for target, rate in best.items():
            summary.append([target, f'{rate:.0f}',
                            f'{rate / baseline:.2f}' if baseline else '-'])
        table = ['| ' + ' | '.join(r) + ' |' for r in trials]
        table.insert(1, '|' + '---|' * len(trials[0]))
        append_section(f'Live throughput, {args.duration:.0f} s per trial, zero loss',
                       summary, note + '\n\nTrials:\n\n' + '\n'.join(table), out=out)
    if len(cpu_rows) > 1:
        append_section('Live CPU per message, bare subscriber and estimator side by side',
                       cpu_rows, note, out=out)
    if len(idle_rows) > 1:
        append_section(f'Live idle CPU, {args.idle:.0f} s without input', idle_rows, note,
                       out=out)
    if len(latency_rows) > 1:
        append_section('Live latency: sample stamp -> estimate received by an observer '
                       'process', latency_rows, note, out=out)
    return 0


if __name__ == '__main__':
    sys.exit(main())
