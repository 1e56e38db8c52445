"""End to end, as a user runs it: ``gear-phm analyze`` as a whole process against rosbags.

For each bag (simulated at --rates and --samples, linear wear with the ground truth topics):
alternately, ``--repeat`` times each, in one run so that machine load hits both,
- ``gear-phm analyze BAG --ratio 3.0 --out OUT`` as a whole process: start-up, imports,
  reading, estimator, diagnostics, writing the output bag and ``summary.json``, and the plot
  (``--no-plot`` leaves it out);
- rosbags' ``AnyReader`` read + deserialize of every JointState message of the same bag, in
  a process of its own; its time is the reading loop only (the baseline without its
  interpreter start-up and imports, which favours rosbags).
Both are reported as samples/s of wall time and as CPU time (user + sys of the process);
the ratios are rosbags' time over analyze's (above 1: analyze is faster), of wall time and
of the two processes' CPU time (the CPU ratio holds better on a loaded machine). Medians.

Usage: .venv/bin/python bench/analyze_e2e.py [--samples 300000 3000000] [--rates 100 1000]
       [--repeat 3] [--no-plot] [--no-append]
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path
import resource
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import append_section, BENCHMARKS_MD  # noqa: E402

BIN = Path(sys.executable).parent

ROSBAGS = """
import json, sys, time
from rosbags.highlevel import AnyReader
from rosbags.typesys import get_typestore, Stores
store = get_typestore(Stores.ROS2_JAZZY)
start = time.perf_counter()
count = 0
with AnyReader([__import__('pathlib').Path(sys.argv[1])], default_typestore=store) as reader:
    connections = [c for c in reader.connections if c.topic == '/joint_states']
    for connection, _, raw in reader.messages(connections=connections):
        reader.deserialize(raw, connection.msgtype)
        count += 1
print(json.dumps({'seconds': time.perf_counter() - start, 'messages': count}))
"""


def child(command: list[str]) -> tuple[float, float, str]:
    """Run ``command``; return (wall [s], CPU user + sys [s] of the child, stdout)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, check=True, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, done.stdout


def simulate(bag: Path, samples: int, rate: float) -> None:
    subprocess.run([str(BIN / 'gear-phm'), 'simulate', '--out', str(bag), '--duration',
                    str(samples / rate), '--rate', str(rate), '--wear', 'linear',
                    '--friction-initial', '0.05', '--friction-final', '0.2', '--seed', '1'],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def compile_package() -> None:
    """Write the package's bytecode, as a user's second run finds it.

    This machine sets PYTHONDONTWRITEBYTECODE: a module changed since the setup would be
    compiled again by every run.
    """
    subprocess.run([sys.executable, '-m', 'compileall', '-q',
                    str(Path(__file__).resolve().parents[1] / 'gear_phm')],
                   check=True, stdout=subprocess.DEVNULL)


def measure(bag: Path, out: Path, repeat: int, plot: bool) -> dict[str, float]:
    analyze = [str(BIN / 'gear-phm'), 'analyze', str(bag), '--ratio', '3.0', '--out',
               str(out), '--overwrite', '--no-progress'] + ([] if plot else ['--no-plot'])
    runs: dict[str, list[float]] = {key: [] for key in (
        'analyze_wall', 'analyze_cpu', 'loop', 'rosbags_loop', 'rosbags_cpu')}
    messages = 0
    for _ in range(repeat):
        wall, cpu, _ = child(analyze)
        summary = json.loads((out / 'summary.json').read_text())
        runs['analyze_wall'].append(wall)
        runs['analyze_cpu'].append(cpu)
        runs['loop'].append(summary['seconds'])
        _, cpu, text = child([sys.executable, '-c', ROSBAGS, str(bag)])
        result = json.loads(text)
        runs['rosbags_loop'].append(result['seconds'])
        runs['rosbags_cpu'].append(cpu)
        messages = result['messages']
        assert summary['messages'] == messages, 'analyze and rosbags saw different counts'
    median = {key: statistics.median(values) for key, values in runs.items()}
    median['messages'] = messages
    return median


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--samples', type=int, nargs='+', default=[300_000, 3_000_000])
    parser.add_argument('--rates', type=float, nargs='+', default=[100.0, 1000.0])
    parser.add_argument('--repeat', type=int, default=3, help='runs of each (median)')
    parser.add_argument('--no-plot', action='store_true', help='analyze without its plot')
    parser.add_argument('--no-append', action='store_true')
    args = parser.parse_args()
    rows = [['bag', 'rosbags read + deserialize: samples/s (loop), CPU [s] (process)',
             '`gear-phm analyze` end to end: samples/s (wall), wall [s], CPU [s]',
             'analyze processing loop [s] (summary.json)', 'ratio analyze / rosbags (wall)',
             'ratio analyze / rosbags (CPU of both processes)']]
    compile_package()
    with tempfile.TemporaryDirectory() as tmp:
        for rate in args.rates:
            for samples in args.samples:
                bag = Path(tmp) / f'bag_{rate:g}_{samples}'
                simulate(bag, samples, rate)
                m = measure(bag, Path(tmp) / 'out', args.repeat, not args.no_plot)
                n = m['messages']
                rows.append([f'{n:,} samples, {rate:g} Hz',
                             f'{n / m["rosbags_loop"]:,.0f}, {m["rosbags_cpu"]:.2f}',
                             f'{n / m["analyze_wall"]:,.0f}, {m["analyze_wall"]:.2f}, '
                             f'{m["analyze_cpu"]:.2f}',
                             f'{m["loop"]:.2f}',
                             f'{m["rosbags_loop"] / m["analyze_wall"]:.2f}',
                             f'{m["rosbags_cpu"] / m["analyze_cpu"]:.2f}'])
                print(' | '.join(rows[-1]), flush=True)
                for path in (bag, Path(tmp) / 'out'):
                    subprocess.run(['rm', '-rf', str(path)], check=True)
    notes = (f'Medians of {args.repeat} alternating runs. Bags: `gear-phm simulate --wear '
             f'linear --friction-initial 0.05 --friction-final 0.2 --seed 1` (JointState '
             f'and the two ground-truth topics at every sample). analyze '
             f'{"without" if args.no_plot else "with"} its plot. The rosbags figure is its '
             "reading loop alone (no start-up); analyze's is the whole process.")
    append_section('Offline analysis end to end against rosbags', rows, notes,
                   out=None if args.no_append else BENCHMARKS_MD)
    return 0


if __name__ == '__main__':
    sys.exit(main())
