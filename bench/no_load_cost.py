"""The no-load model's cost in ``gear-phm analyze``: with and without it, runs interleaved.

One bag of the bench example of docs/estimation.md ("No-load losses": R 30, a cold start,
drag 2.5 % of the input torque warm and three times that cold, a load of 0.3-1.0 of nominal,
a load sensor 0.4 N m high) is analysed as a whole process, alternately without
(A, the default) and with ``--param no_load_model=true`` (B). Reports the median wall and CPU
time (user + system) of each and the ratio B / A of both.

    .venv/bin/python bench/no_load_cost.py --duration 600 --rate 200 --repeat 5
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = Path(__file__).resolve().parents[1]
SIMULATE = ['--ratio', '30', '--wear', 'constant', '--friction-initial', '0.0595',
            '--no-load-coulomb', '0.034', '--no-load-cold-factor', '3',
            '--oil-warm-time-constant', '900', '--load-scale-min', '0.3',
            '--load-scale-max', '1.0', '--bias-effort-load', '0.4']
ANALYZE = ['--ratio', '30', '--eta-opposing-min', '0.9148', '--no-plot', '--no-progress',
           '--overwrite']


def _gear_phm(*args: str) -> tuple[float, float]:
    """(wall [s], CPU [s]) of one ``gear-phm`` process of this tree."""
    started = time.perf_counter()
    process = subprocess.Popen([sys.executable, '-m', 'gear_phm.cli.main', *args], cwd=ROOT,
                               env={**os.environ, 'PYTHONPATH': str(ROOT)},
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(process.pid, 0)
    wall = time.perf_counter() - started
    error = process.stderr.read().decode() if process.stderr else ''
    if process.stderr:
        process.stderr.close()
    if status != 0:
        raise SystemExit(f'gear-phm {args[0]} failed: {error[-2000:]}')
    return wall, usage.ru_utime + usage.ru_stime


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--duration', type=float, default=600.0, help='bag length [s]')
    parser.add_argument('--rate', type=float, default=200.0, help='sample rate [Hz]')
    parser.add_argument('--repeat', type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        bag = Path(tmp) / 'bag'
        _gear_phm('simulate', '--out', str(bag), '--duration', repr(args.duration), '--rate',
                  repr(args.rate), *SIMULATE)
        runs: dict[str, list[tuple[float, float]]] = {'A': [], 'B': []}
        for _ in range(args.repeat):
            for name, extra in (('A', []), ('B', ['--param', 'no_load_model=true'])):
                runs[name].append(_gear_phm('analyze', str(bag), *ANALYZE, *extra,
                                            '--out', str(Path(tmp) / name)))
    samples = round(args.duration * args.rate)
    print(f'{samples:,} samples at {args.rate:g} Hz, medians of {args.repeat} runs each')
    print('| analysis | wall [s] | CPU [s] |')
    print('|---|---|---|')
    medians = {}
    for name, label in (('A', 'paper model (default)'), ('B', 'no_load_model')):
        wall, cpu = (statistics.median(run[j] for run in runs[name]) for j in range(2))
        medians[name] = (wall, cpu)
        print(f'| {label} | {wall:.2f} | {cpu:.2f} |')
    (wall_a, cpu_a), (wall_b, cpu_b) = medians['A'], medians['B']
    print(f'| ratio B / A | {wall_b / wall_a:.2f} | {cpu_b / cpu_a:.2f} |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
