"""Memory: peak RSS of offline analysis against bag length, and the nodes' code over an hour.

- ``--mode analyze`` (default): simulated 1 kHz bags (with ground truth) of ``--samples``
  samples each (default 300k, 3M, 10M, 40M), each analysed in its own process: ``gear-phm
  analyze`` with the plot (truth read), ``gear-phm analyze --no-plot``, and the Python API
  ``analyze_bag(bag, ratio)`` with its defaults; peak RSS of each process (``os.wait4``),
  and its growth against the smallest bag. The bags are deleted after use.
- ``--mode logic``: the code of both nodes (EstimatorPipeline, then HealthAssessor on its
  estimates) fed 3,600,000 simulated samples (one hour at 1 kHz) in this process; RSS at
  the start, at the 10-minute mark and at the 1-hour mark. ``--hours 24``: a simulated day,
  RSS at each hour and the slope after the first [MiB/h].
- ``--mode nodes``: the estimator and diagnostics nodes as processes over DDS, fed by the
  flood publisher at ``--rate`` for ``--duration`` s; RSS of each node from /proc at the
  start and at the end.

Usage: .venv/bin/python bench/memory.py [--mode analyze|logic|nodes|all] [--samples N ...]
[--hours H] [--tmp DIR] [--no-append]
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

ROOT = Path(__file__).resolve().parent.parent
BIN = Path(sys.executable).parent


def peak_mib(command: list[str]) -> tuple[float, float]:
    """Run ``command``; return its peak RSS [MiB] (its own, from wait4) and wall time [s]."""
    start = time.perf_counter()
    child = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    assert child.stderr is not None
    errors = child.stderr.read()
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode:
        raise RuntimeError(f'{command} failed: {errors.decode()[-2000:]}')
    return usage.ru_maxrss / 1024.0, time.perf_counter() - start


#: Ways of analysing a bag, as (label, command builder of bag and output directory).
ANALYSES = (
    ('gear-phm analyze (plot, truth)',
     lambda bag, out: [str(BIN / 'gear-phm'), 'analyze', bag, '--ratio', '3', '--out', out,
                       '--no-progress']),
    ('gear-phm analyze --no-plot',
     lambda bag, out: [str(BIN / 'gear-phm'), 'analyze', bag, '--ratio', '3', '--out', out,
                       '--no-progress', '--no-plot']),
    ('Python API analyze_bag(bag, 3.0), defaults',
     lambda bag, out: [sys.executable, '-c', 'import sys; from gear_phm.offline import '
                       'analyze_bag; analyze_bag(sys.argv[1], 3.0)', bag]),
)


def analyze(sizes: list[int], tmp: str | None) -> list[list[str]]:
    """Peak RSS [MiB] of each way of analysing a 1 kHz bag, per number of samples."""
    peaks: dict[str, list[tuple[int, float, float]]] = {label: [] for label, _ in ANALYSES}
    for samples in sizes:
        folder = Path(tempfile.mkdtemp(prefix='gear-phm-memory-', dir=tmp))
        try:
            bag = str(folder / 'bag')
            subprocess.run([str(BIN / 'gear-phm'), 'simulate', '--duration',
                            f'{samples / 1000.0:g}', '--rate', '1000', '--out', bag],
                           check=True, capture_output=True)
            for label, command in ANALYSES:
                peak, wall = peak_mib(command(bag, str(folder / 'out')))
                shutil.rmtree(folder / 'out', ignore_errors=True)
                peaks[label].append((samples, peak, wall))
                print(f'{label}: {samples:,} samples, peak {peak:.0f} MiB, {wall:.1f} s',
                      flush=True)
        finally:
            shutil.rmtree(folder, ignore_errors=True)
    rows = [['analysis', 'samples (1 kHz, with truth)', 'peak RSS [MiB]',
             'growth vs smallest', 'wall [s]']]
    for label, results in peaks.items():
        smallest = results[0][1]
        for samples, peak, wall in results:
            rows.append([label, f'{samples:,}', f'{peak:.0f}',
                         f'{(peak - smallest) / smallest * 100:+.1f} %', f'{wall:.1f}'])
    return rows


def logic(samples: int, rate: float, hours: int = 1) -> list[list[str]]:
    """Feed ``hours`` times ``samples`` (an hour of input) to both nodes' code; RSS rows.

    Marks: the start, the 10-minute mark of the first hour, and the end of each hour; with
    more than one hour, the least-squares slope of the hourly marks after the first hour
    [MiB per hour of input] and what it implies over a day.
    """
    from gear_phm.estimation import EstimatorConfig, EstimatorPipeline
    from gear_phm.prognostics import HealthAssessor, HealthConfig
    from gear_phm.simulation import SimulationConfig, simulate
    config = SimulationConfig()
    ratio = config.plant.ratio
    estimator = EstimatorPipeline(EstimatorConfig(ratio=ratio))
    health = HealthAssessor(HealthConfig(ratio=ratio))
    block = min(60_000, max(samples // 60, 1))  # one minute of 1 kHz samples per batch
    ten_minutes = samples // 6                  # the 10-minute mark of the first hour
    total = samples * hours
    marks = {0: rss_mib()}
    hourly: list[float] = []
    start = time.perf_counter()
    for first in range(0, total, block):
        last = min(first + block, total, (first // samples + 1) * samples)
        t = (np.arange(first, last) / rate)
        result = simulate(config, t)
        outputs = estimator.on_batch((t * 1e9).astype(np.int64) + 10**9, result.velocity_motor,
                                     result.effort_motor, result.velocity_load,
                                     result.effort_load)
        for estimate in outputs:
            health.on_estimate(estimate)
        if last >= ten_minutes and 'ten' not in marks:
            marks['ten'] = rss_mib()
        if last % samples == 0:
            hourly.append(rss_mib())
    elapsed = time.perf_counter() - start
    ten, hour = marks['ten'], hourly[0]
    rows = [['samples (1 kHz)', 'RSS [MiB]', 'growth vs 10-min mark'],
            ['0 (start)', f'{marks[0]:.1f}', '-'],
            [f'{ten_minutes:,} (10 min)', f'{ten:.1f}', '0.0 %'],
            [f'{samples:,} (1 h)', f'{hour:.1f}', f'{(hour - ten) / ten * 100:+.1f} %']]
    for h, rss in enumerate(hourly[1:], start=2):
        rows.append([f'{samples * h:,} ({h} h)', f'{rss:.1f}',
                     f'{(rss - ten) / ten * 100:+.1f} %'])
    if len(hourly) > 2:
        slope = float(np.polyfit(np.arange(1, len(hourly) + 1), hourly, 1)[0])
        rows.append(['slope after the first hour', f'{slope:+.3f} MiB/h',
                     f'{24 * slope:+.1f} MiB/day'])
    rows.append(['run time', f'{elapsed:.1f} s', f'{total / elapsed:,.0f} samples/s'])
    return rows


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
    parser.add_argument('--mode', choices=('analyze', 'logic', 'nodes', 'all'),
                        default='analyze')
    parser.add_argument('--samples', type=int, nargs='+',
                        default=[300_000, 3_000_000, 10_000_000, 40_000_000],
                        help='analyze mode: bag sizes; logic mode: the first')
    parser.add_argument('--hours', type=int, default=1,
                        help='logic mode: hours of input (each --samples samples)')
    parser.add_argument('--tmp', default=None, help='analyze mode: where the bags go')
    parser.add_argument('--rate', type=float, default=2000.0, help='nodes mode input [Hz]')
    parser.add_argument('--duration', type=float, default=300.0, help='nodes mode [s]')
    parser.add_argument('--no-append', action='store_true')
    args = parser.parse_args()
    out = None if args.no_append else BENCHMARKS_MD
    if args.mode in ('analyze', 'all'):
        append_section('Memory: peak RSS of offline analysis against bag length',
                       analyze(args.samples, args.tmp), out=out)
    if args.mode in ('logic', 'all'):
        hours = args.hours if args.mode == 'logic' else 1
        append_section(f"Memory: both nodes' code, {hours} h of 1 kHz input (in process)",
                       logic(args.samples[0] if args.mode == 'logic' else 3_600_000, 1000.0,
                             hours), out=out)
    if args.mode in ('nodes', 'all'):
        append_section(f'Memory: node processes over DDS, {args.rate:.0f} Hz for '
                       f'{args.duration:.0f} s', nodes(args.rate, args.duration), out=out)
    return 0


if __name__ == '__main__':
    sys.exit(main())
