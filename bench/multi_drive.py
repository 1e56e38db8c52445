"""Benchmark (not a test): an N-drive bag analysed in one pass against N single-drive runs.

``gear-phm simulate --transmissions`` writes a bench of N drives (different ratios and wear)
in one JointState stream; then, each as its own process as a user would run them:

- one ``gear-phm analyze BAG --transmissions FILE --jobs 1`` (the bag read once, each
  message decoded once for all drives, every drive in that one process);
- the same as users run it, with the default ``--jobs 0``: the drives' work in one worker
  process per core (:mod:`gear_phm.offline.parallel`), the bag still read once;
- N ``gear-phm analyze BAG --ratio R --motor-joint M --load-joint L``, one per drive, one after
  another.

Alternated ``--repeat`` times (medians), so that machine load hits all three. Wall and CPU
time (of the child processes and theirs) of each, the ratios, and the largest relative
difference between each drive's u, du/dt and sigma_u (``gear_phm/<drive>/friction``) in a one
pass and in its single run (issue 25: u within 1e-9). The per-drive work (the estimator's
windows and filter, the health assessment at each output) does not shrink with one pass; what
one process saves is the start of N processes and reading and decoding the bag N times, so
that ratio grows with the sample rate; the workers then share the per-drive work out over the
cores (the CPU ratio shows what they add). Appends the table to docs/benchmarks.md
(``--no-append``: print only).

Usage: .venv/bin/python bench/multi_drive.py [--drives 8] [--duration 120] [--rate 1000]
       [--repeat 3]
"""
from __future__ import annotations

import argparse
from pathlib import Path
import resource
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import append_section  # noqa: E402

from gear_phm import interfaces  # noqa: E402
from gear_phm.bagio import BagReader  # noqa: E402
from gear_phm.bagio.writer import vector3_stamped_from_cdr  # noqa: E402
from gear_phm.offline.summary import read_summary, RunSummary  # noqa: E402

GEAR_PHM = Path(sys.executable).parent / 'gear-phm'
RATIOS = (3.0, 5.0, 2.0, 4.0, 30.0, 12.0)


def bench_file(drives: int) -> dict[str, object]:
    """Return a transmissions document of ``drives`` drives, each its ratio and wear."""
    return {'transmissions': {
        f'drive_{i}': {'motor_joint': f'motor_{i}', 'load_joint': f'load_{i}',
                       'ratio': RATIOS[i % len(RATIOS)],
                       'simulation': {'wear': 'linear', 'friction_initial': 0.04 + 0.005 * i,
                                      'wear_rate': 1e-4 * (i % 3)}}
        for i in range(drives)}}


def timed(commands: list[list[str]]) -> tuple[float, float]:
    """Run the commands one after another; return (wall [s], CPU of the children [s])."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    for command in commands:
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            raise SystemExit(f'{" ".join(command)}\n{done.stderr[-2000:]}')
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def friction(out: Path, topic: str) -> np.ndarray:
    """Return the (stamp, u, rate, sigma) rows of an output bag's friction topic."""
    with BagReader(out) as bag:
        return np.array([vector3_stamped_from_cdr(raw)
                         for _, _, raw in bag.raw_messages([topic])], dtype=float)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--drives', type=int, default=8)
    parser.add_argument('--duration', type=float, default=120.0, help='bag length [s]')
    parser.add_argument('--rate', type=float, default=1000.0, help='sample rate [Hz]')
    parser.add_argument('--repeat', type=int, default=3, help='runs of each (median)')
    parser.add_argument('--no-append', action='store_true',
                        help='print only, do not append to docs/benchmarks.md')
    args = parser.parse_args()
    document = bench_file(args.drives)
    drives = document['transmissions']
    assert isinstance(drives, dict)
    with tempfile.TemporaryDirectory(prefix='gear-phm-multi-') as tmp:
        work = Path(tmp)
        spec = work / 'bench.yaml'
        spec.write_text(yaml.safe_dump(document, sort_keys=False))
        bag = work / 'bag'
        timed([[str(GEAR_PHM), 'simulate', '--transmissions', str(spec), '--duration',
                str(args.duration), '--rate', str(args.rate), '--out', str(bag)]])
        common = ['--no-plot', '--no-progress', '--overwrite']
        passes = {jobs: [[str(GEAR_PHM), 'analyze', str(bag), '--transmissions', str(spec),
                          '--out', str(work / f'all_{jobs}'), '--jobs', jobs, *common]]
                  for jobs in ('1', '0')}
        singles = [[str(GEAR_PHM), 'analyze', str(bag), '--ratio', str(drive['ratio']),
                    '--motor-joint', drive['motor_joint'], '--load-joint',
                    drive['load_joint'], '--out', str(work / name), *common]
                   for name, drive in drives.items()]
        times: dict[str, list[tuple[float, float]]] = {'1': [], '0': [], 'singles': []}
        for _ in range(args.repeat):
            for key, commands in (*passes.items(), ('singles', singles)):
                times[key].append(timed(commands))
        wall = {key: statistics.median(w for w, _ in runs) for key, runs in times.items()}
        cpu = {key: statistics.median(c for _, c in runs) for key, runs in times.items()}
        run = read_summary(work / 'all_0')
        assert isinstance(run, RunSummary), 'a run of many drives'
        workers = run.workers
        worst = [0.0, 0.0, 0.0]                 # u, du/dt, sigma_u
        for name in drives:
            theirs = friction(work / name, '/' + interfaces.FRICTION)
            for jobs in passes:
                ours = friction(work / f'all_{jobs}',
                                '/' + interfaces.drive_topic(name, interfaces.FRICTION))
                if ours.shape != theirs.shape:
                    raise SystemExit(f'{name}: {ours.shape} outputs in one pass, '
                                     f'{theirs.shape} alone')
                relative = (np.abs(ours - theirs)[:, 1:]
                            / np.maximum(np.abs(theirs[:, 1:]), 1e-300))
                worst = [max(w, float(r)) for w, r in zip(worst, relative.max(axis=0))]
    samples = int(round(args.duration * args.rate))
    n = len(drives)
    table = [['analysis', 'wall [s]', 'CPU [s]', 'N runs / one pass (wall)',
              'N runs / one pass (CPU)'],
             [f'{n} single-drive runs (`--ratio`, one process each)', f'{wall["singles"]:.2f}',
              f'{cpu["singles"]:.2f}', '1.00', '1.00']]
    for jobs, label in (('1', 'one pass (`--transmissions --jobs 1`, one process)'),
                        ('0', f'one pass (`--transmissions`, default `--jobs 0`: {workers} '
                              f'worker processes)')):
        table.append([label, f'{wall[jobs]:.2f}', f'{cpu[jobs]:.2f}',
                      f'{wall["singles"] / wall[jobs]:.2f}', f'{cpu["singles"] / cpu[jobs]:.2f}'])
    notes = (f'{n} drives in one JointState stream ({2 * n} joints), {samples:,} messages '
             f'({args.duration:g} s at {args.rate:g} Hz); medians of {args.repeat} alternating '
             f'runs of each. Largest relative difference between a drive in a one pass and its '
             f'single run: u {worst[0]:.1e}, du/dt {worst[1]:.1e} (near 0 for a drive that does '
             f'not wear), sigma_u {worst[2]:.1e}.')
    append_section(f'Many drives in one pass (`gear-phm analyze --transmissions`), {n} drives, '
                   f'{args.rate:g} Hz', table, notes, None if args.no_append else
                   Path(__file__).resolve().parent.parent / 'docs' / 'benchmarks.md')


if __name__ == '__main__':
    main()
