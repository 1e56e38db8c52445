"""Memory: RSS growth of the estimator and diagnostics code over one hour of 1 kHz input.

Two measurements, each against its own start:
- ``--mode logic`` (default part 1): the code of both nodes (EstimatorPipeline, then
  HealthAssessor on its estimates, exactly what the nodes and ``gear-phm analyze`` run) fed
  3,600,000 simulated samples (one hour at 1 kHz) as fast as it goes, in this process; RSS at
  the start, at the 10-minute mark and at the 1-hour mark.
- ``--mode nodes`` (part 2): the estimator and diagnostics nodes as processes over DDS, fed by
  the flood publisher at ``--rate`` for ``--duration`` s; RSS of each node from /proc at the
  start and at the end.

Usage: .venv/bin/python bench/memory.py [--mode logic|nodes|both] [--no-append]
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


def rss_mib(pid: int | str = 'self') -> float:
    """Resident set size [MiB] from /proc/<pid>/status."""
    for line in Path(f'/proc/{pid}/status').read_text().splitlines():
        if line.startswith('VmRSS:'):
            return int(line.split()[1]) / 1024.0
    return float('nan')


def logic(samples: int, rate: float) -> list[list[str]]:
    from gear_phm.estimation import EstimatorConfig, EstimatorPipeline
    from gear_phm.prognostics import HealthAssessor, HealthConfig
    from gear_phm.simulation import SimulationConfig, simulate
    config = SimulationConfig()
    ratio = config.plant.ratio
    estimator = EstimatorPipeline(EstimatorConfig(ratio=ratio))
    health = HealthAssessor(HealthConfig(ratio=ratio))
    block = min(60_000, max(samples // 60, 1))  # one minute of 1 kHz samples per batch
    ten_minutes = samples // 6                  # the 10-minute mark of the hour
    marks = {0: rss_mib()}
    start = time.perf_counter()
    for first in range(0, samples, block):
        t = (np.arange(first, min(first + block, samples)) / rate)
        result = simulate(config, t)
        outputs = estimator.on_batch((t * 1e9).astype(np.int64) + 10**9, result.velocity_motor,
                                     result.effort_motor, result.velocity_load,
                                     result.effort_load)
        for estimate in outputs:
            health.on_estimate(estimate)
        done = first + len(t)
        if done >= ten_minutes and 'ten' not in marks:
            marks['ten'] = rss_mib()
        if done == samples:
            marks['end'] = rss_mib()
    elapsed = time.perf_counter() - start
    ten, hour = marks['ten'], marks['end']
    return [['samples (1 kHz)', 'RSS [MiB]', 'growth vs 10-min mark'],
            ['0 (start)', f'{marks[0]:.1f}', '-'],
            [f'{ten_minutes:,} (10 min)', f'{ten:.1f}', '0.0 %'],
            [f'{samples:,} (1 h)', f'{hour:.1f}', f'{(hour - ten) / ten * 100:+.1f} %'],
            ['run time', f'{elapsed:.1f} s', f'{samples / elapsed:,.0f} samples/s']]


def nodes(rate: float, duration: float) -> list[list[str]]:
    env = dict(os.environ)
    env.setdefault('ROS_DOMAIN_ID', str(150 + os.getpid() % 50))
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    procs = {name: subprocess.Popen([str(BIN / name)], env=env, stdout=subprocess.DEVNULL,
                                    stderr=subprocess.DEVNULL)
             for name in ('estimator', 'diagnostics')}
    try:
        time.sleep(5.0)
        start = {name: rss_mib(p.pid) for name, p in procs.items()}
        flood = subprocess.run([sys.executable, str(ROOT / 'bench' / 'flood_publisher.py'),
                                '--rate', str(rate), '--duration', str(duration)], env=env,
                               capture_output=True, text=True, check=True)
        end = {name: rss_mib(p.pid) for name, p in procs.items()}
    finally:
        for p in procs.values():
            p.terminate()
            p.wait(timeout=10)
    sent = flood.stdout.split('sent=')[1].split()[0]
    rows = [['node', 'RSS at start [MiB]', f'RSS after {sent} samples [MiB]', 'growth']]
    for name in procs:
        rows.append([name, f'{start[name]:.1f}', f'{end[name]:.1f}',
                     f'{(end[name] - start[name]) / start[name] * 100:+.1f} %'])
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--mode', choices=('logic', 'nodes', 'both'), default='both')
    parser.add_argument('--samples', type=int, default=3_600_000)
    parser.add_argument('--rate', type=float, default=2000.0, help='nodes mode input [Hz]')
    parser.add_argument('--duration', type=float, default=300.0, help='nodes mode [s]')
    parser.add_argument('--no-append', action='store_true')
    args = parser.parse_args()
    out = None if args.no_append else BENCHMARKS_MD
    if args.mode in ('logic', 'both'):
        append_section("Memory: both nodes' code, one hour of 1 kHz input (in process)",
                       logic(args.samples, 1000.0), out=out)
    if args.mode in ('nodes', 'both'):
        append_section(f'Memory: node processes over DDS, {args.rate:.0f} Hz for '
                       f'{args.duration:.0f} s', nodes(args.rate, args.duration), out=out)
    return 0


if __name__ == '__main__':
    sys.exit(main())
