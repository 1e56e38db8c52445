"""Fleet scaling: ``gear-phm fleet`` on 1 and on 2 Dask workers, same fleet, same run.

Simulates a fleet (default 20 units x 30 recordings of 120 s at 100 Hz, a week of idle time
between recordings) once, then runs ``gear-phm fleet --workers 1`` and ``--workers 2``
alternately (``--repeat`` times each) and reports: wall time, speed-up, whether the tables are
byte-identical, peak RSS per worker task, throughput per core (samples/s and recordings/s),
and a sizing model for a larger fleet on a Dask cluster.

Usage: .venv/bin/python bench/fleet_scale.py [--units 20] [--recordings 30] [--duration 120]
       [--repeat 2] [--no-append]
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import append_section, BENCHMARKS_MD  # noqa: E402

GEAR_PHM = Path(sys.executable).parent / 'gear-phm'


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--units', type=int, default=20)
    parser.add_argument('--recordings', type=int, default=30)
    parser.add_argument('--duration', type=float, default=120.0,
                        help='per recording [s] (a flight or a bench run of a few minutes)')
    parser.add_argument('--rate', type=float, default=100.0)
    parser.add_argument('--repeat', type=int, default=2)
    parser.add_argument('--no-append', action='store_true')
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / 'fleet'
        subprocess.run([str(GEAR_PHM), 'simulate', '--fleet', str(args.units), '--recordings',
                        str(args.recordings), '--duration', str(args.duration), '--rate',
                        str(args.rate), '--wear', 'linear', '--friction-initial', '0.05',
                        '--wear-rate', '2e-4', '--seed', '8', '--out', str(root)],
                       check=True, capture_output=True)
        samples = int(args.units * args.recordings * args.duration * args.rate)
        walls: dict[int, list[float]] = {1: [], 2: []}
        tables: dict[int, bytes] = {}
        peak = 0.0
        for i in range(args.repeat):
            for workers in (1, 2):
                out = Path(tmp) / f'out-{workers}-{i}'
                start = time.perf_counter()
                subprocess.run([str(GEAR_PHM), 'fleet', str(root), '--ratio', '3.0', '--out',
                                str(out), '--workers', str(workers), '--no-progress',
                                '--no-unit-outputs'], check=True, capture_output=True)
                walls[workers].append(time.perf_counter() - start)
                tables.setdefault(workers, (out / 'fleet.parquet').read_bytes())
                run = json.loads((out / 'fleet_run.json').read_text())
                peak = max(peak, run['max_peak_rss_mib'])
        one, two = statistics.median(walls[1]), statistics.median(walls[2])
        identical = tables[1] == tables[2]
    per_core = samples / one
    recordings = args.units * args.recordings
    # sizing: 10,000 units x 1,000 recordings of the same length, on W workers of one core
    big = 10_000 * 1_000 * args.duration * args.rate
    hours_one_core = big / per_core / 3600.0
    table = [['workers', 'wall [s]', 'speed-up', 'samples/s', 'recordings/s',
              'tables identical'],
             ['1', f'{one:.1f}', '1.00', f'{samples / one:,.0f}', f'{recordings / one:.1f}',
              '-'],
             ['2', f'{two:.1f}', f'{one / two:.2f}', f'{samples / two:,.0f}',
              f'{recordings / two:.1f}', 'yes' if identical else 'NO']]
    notes = (
        f'Fleet: {args.units} units x {args.recordings} recordings of {args.duration:g} s at '
        f'{args.rate:g} Hz ({samples:,} samples); medians of {args.repeat} alternating runs. '
        f'Peak RSS of one worker task: {peak:.0f} MiB. Throughput per core (1 worker, Dask '
        f'start-up included): {per_core:,.0f} samples/s.\n\n'
        f'Sizing, 10,000 units x 1,000 recordings like these ({big:,.0f} samples): '
        f'{hours_one_core:,.0f} core-hours; on 100 one-core workers about '
        f'{hours_one_core / 100:,.1f} h, on 500 about {hours_one_core / 500:,.1f} h; each '
        f'worker needs about {peak:.0f} MiB (one unit at a time, recordings streamed).')
    append_section('Fleet scaling (gear-phm fleet on Dask)', table, notes,
                   out=None if args.no_append else BENCHMARKS_MD)
    return 0 if identical else 1


if __name__ == '__main__':
    raise SystemExit(main())
