"""``gear-phm analyze`` speed of two source trees, measured in one run, interleaved.

Checks a refactor or an optimisation against the code before it, on the same bags, on the
same machine, at the same time (runs alternate A, B, A, B, ... so machine load hits both).
Each tree is imported through PYTHONPATH with this environment's interpreter, so both run
with the same dependencies; each runs with its tree as working directory (``python -m`` puts
the working directory first on sys.path, so running both from one checkout would import that
checkout twice). Reports the median processing rate (``samples_per_second`` of
summary.json) and wall time, and the ratio B / A.

    git worktree add --detach /tmp/base HEAD~5
    .venv/bin/python bench/compare_checkouts.py /tmp/base . --repeat 5

The bags are simulated once (1 kHz and 100 Hz, wear fast enough that the RUL predictor runs).
"""
from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
import statistics
import subprocess
import sys
import tempfile
import time

BIN = Path(sys.executable).parent


def simulate(tree: Path, out: Path, rate: float, duration: float) -> None:
    subprocess.run([sys.executable, '-m', 'gear_phm.cli.main', 'simulate', '--out', str(out),
                    '--rate', str(rate), '--duration', str(duration), '--seed', '5',
                    '--wear', 'linear', '--friction-initial', '0.05', '--wear-rate', '2e-4'],
                   check=True, capture_output=True, cwd=tree,
                   env={**os.environ, 'PYTHONPATH': str(tree)})


def analyze(tree: Path, bag: Path, out: Path) -> tuple[float, float]:
    """(samples/s of the processing loop, wall time [s])."""
    started = time.perf_counter()
    subprocess.run([sys.executable, '-m', 'gear_phm.cli.main', 'analyze', str(bag), '--ratio',
                    '3.0', '--out', str(out), '--no-plot', '--no-progress'], check=True,
                   capture_output=True, cwd=tree, env={**os.environ, 'PYTHONPATH': str(tree)})
    wall = time.perf_counter() - started
    summary = json.loads((out / 'summary.json').read_text())
    return float(summary['samples_per_second']), wall


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('a', type=Path, help='source tree A (the baseline)')
    parser.add_argument('b', type=Path, help='source tree B')
    parser.add_argument('--repeat', type=int, default=5)
    parser.add_argument('--duration', type=float, default=300.0, help='bag length [s]')
    args = parser.parse_args()
    trees = [args.a.resolve(), args.b.resolve()]
    print('| bag | A samples/s | B samples/s | B/A | A wall [s] | B wall [s] |')
    print('|---|---|---|---|---|---|')
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for rate in (1000.0, 100.0):
            bag = root / f'bag{rate:.0f}'
            simulate(trees[1], bag, rate, args.duration)
            results: list[list[tuple[float, float]]] = [[], []]
            for i in range(args.repeat):
                for k, tree in enumerate(trees):
                    out = root / f'out{k}-{i}-{rate:.0f}'
                    results[k].append(analyze(tree, bag, out))
            speed = [statistics.median(r[0] for r in res) for res in results]
            wall = [statistics.median(r[1] for r in res) for res in results]
            print(f'| {rate:.0f} Hz, {args.duration:.0f} s | {speed[0]:,.0f} | {speed[1]:,.0f} '
                  f'| {speed[1] / speed[0]:.3f} | {wall[0]:.2f} | {wall[1]:.2f} |')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
