"""``gear-phm simulate`` end to end for one or two source trees, runs interleaved.

Each run is a whole process (start-up, simulation, CDR packing, zstd, metadata), its tree as
working directory and first on PYTHONPATH, this environment's interpreter. Reports the median
wall time, samples per wall second, the process's CPU time (user + system, which machine load
inflates less than wall time) and peak RSS, and with two trees the ratio A / B of wall and
CPU time (B's speed-up over A). Every run uses the same seed; the SHA-256 of each run's bag
files (.mcap and metadata.yaml) says whether a tree wrote identical bags in all its runs.

    git worktree add --detach /tmp/base <old commit>
    .venv/bin/python bench/simulate_speed.py /tmp/base . --samples 1000000 --repeat 3
"""
from __future__ import annotations

import argparse
import hashlib
import os
from pathlib import Path
import shutil
import statistics
import subprocess
import sys
import tempfile
import time


def run_once(tree: Path, out: Path, samples: int, rate: float) -> tuple[float, float, float]:
    """(wall [s], CPU [s], peak RSS [MB]) of one ``gear-phm simulate`` process."""
    started = time.perf_counter()
    process = subprocess.Popen(
        [sys.executable, '-m', 'gear_phm.cli.main', 'simulate', '--out', str(out),
         '--duration', repr(samples / rate), '--rate', repr(rate), '--seed', '5',
         '--wear', 'linear', '--friction-initial', '0.05', '--friction-final', '0.25'],
        cwd=tree, env={**os.environ, 'PYTHONPATH': str(tree)},
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(process.pid, 0)
    wall = time.perf_counter() - started
    if status != 0:
        raise SystemExit(f'{tree}: simulate failed: {process.stderr.read().decode()[-2000:]}')
    process.stderr.close()
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0


def digest(bag: Path) -> str:
    """SHA-256 over the files of ``bag`` (sorted by name)."""
    sha = hashlib.sha256()
    for path in sorted(bag.iterdir()):
        sha.update(path.name.encode())
        with open(path, 'rb') as stream:
            while block := stream.read(1 << 24):
                sha.update(block)
    return sha.hexdigest()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('trees', type=Path, nargs='+', help='source tree A [and B]')
    parser.add_argument('--samples', type=int, default=1_000_000)
    parser.add_argument('--rate', type=float, default=1000.0, help='sample rate [Hz]')
    parser.add_argument('--repeat', type=int, default=3)
    parser.add_argument('--no-append', action='store_true', help='(prints only; accepted for '
                        'the bench tests)')
    args = parser.parse_args()
    trees = [tree.resolve() for tree in args.trees[:2]]
    results: list[list[tuple[float, float, float]]] = [[] for _ in trees]
    digests: list[set[str]] = [set() for _ in trees]
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.repeat):
            for k, tree in enumerate(trees):
                out = Path(tmp) / f'run{k}'
                results[k].append(run_once(tree, out, args.samples, args.rate))
                digests[k].add(digest(out))
                shutil.rmtree(out)                 # 10M samples are about 1 GB
    print(f'{args.samples:,} samples at {args.rate:g} Hz, medians of {args.repeat} runs')
    print('| tree | wall [s] | samples/s (wall) | CPU [s] | peak RSS [MB] | identical bags |')
    print('|---|---|---|---|---|---|')
    medians = []
    for name, tree, res, sums in zip('AB', trees, results, digests):
        wall, cpu, rss = (statistics.median(r[j] for r in res) for j in range(3))
        medians.append((wall, cpu))
        same = ('-' if args.repeat < 2 else
                f'{"yes" if len(sums) == 1 else "NO"} ({args.repeat} runs)')
        print(f'| {name}: {tree} | {wall:.1f} | {args.samples / wall:,.0f} | {cpu:.1f} '
              f'| {rss:.0f} | {same} |')
    if len(trees) == 2:
        print(f'A and B wrote identical bags: {"yes" if digests[0] == digests[1] else "no"}')
    if len(medians) == 2:
        print(f'A / B: wall {medians[0][0] / medians[1][0]:.2f}, '
              f'CPU {medians[0][1] / medians[1][1]:.2f}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
