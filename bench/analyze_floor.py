"""The floor of ``gear-phm analyze`` end to end: the parts that run one after the other.

Issue 24 asks ``gear-phm analyze`` (a whole process, plot included) to be 3x faster than
rosbags' read + deserialize of the same bag. Some of its work cannot overlap, whatever the
cores: the interpreter and imports come first; the health assessment is one chain (each
estimate's state, levels and RUL follow from the previous; each RUL refit from the previous
fit's detection, admitted laws and forecast cache), as long as the output must stay the same;
the plot is drawn once the last estimate is known. For a simulated bag (``--samples`` at each
of ``--rates``), in one run:

- rosbags' ``AnyReader`` read + deserialize loop of the JointState topic (the baseline, as
  ``bench/analyze_e2e.py``);
- start-up: a process that imports what ``gear-phm analyze`` imports before it reads (wall);
- the assessment chain: ``analyze_bag(bag, 3.0, jobs=1, plot=False)`` with
  ``HealthAssessor.on_estimates`` timed, and of it the RUL refits (``RulPredictor._refit``);
- the draw: ``plot_analysis`` of the finished Analysis, matplotlib imported before (best of
  ``--repeat``).

The floor is start-up + assessment + draw [s]; the budget is rosbags' time / 3. Medians of
``--repeat`` runs.

Usage: .venv/bin/python bench/analyze_floor.py [--samples 300000] [--rates 100 1000]
       [--repeat 3] [--no-append]
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
from analyze_e2e import compile_package, ROSBAGS, simulate  # noqa: E402, I100, I201

from _report import append_section, BENCHMARKS_MD  # noqa: E402

IMPORTS = 'import gear_phm.cli.main, gear_phm.cli.analyze, gear_phm.offline.engine, gear_phm.bagio'

CHAIN = """
import json, sys, time
from pathlib import Path
from gear_phm.offline import analyze_bag
from gear_phm.prognostics.assessor import HealthAssessor
from gear_phm.prognostics.predictor import RulPredictor
spent = {'assess': 0.0, 'refits': 0.0}
def timed(cls, name, key):
    inner = getattr(cls, name)
    def wrapper(*args):
        start = time.perf_counter()
        try:
            return inner(*args)
        finally:
            spent[key] += time.perf_counter() - start
    setattr(cls, name, wrapper)
timed(HealthAssessor, 'on_estimates', 'assess')
timed(RulPredictor, '_refit', 'refits')
analysis = analyze_bag(sys.argv[1], 3.0, jobs=1, plot=False)
import matplotlib.backends.backend_agg, matplotlib.figure
from gear_phm.offline.plot import plot_analysis
draws = []
for _ in range(int(sys.argv[3])):
    start = time.perf_counter()
    plot_analysis(Path(sys.argv[2]), analysis, 3.0, [Path(sys.argv[1])])
    draws.append(time.perf_counter() - start)
spent['draw'] = min(draws)
spent['messages'] = analysis.summary.run.messages
print(json.dumps(spent))
"""


def measure(bag: Path, png: Path, repeat: int) -> dict[str, float]:
    runs: dict[str, list[float]] = {key: [] for key in (
        'rosbags', 'start-up', 'assess', 'refits', 'draw')}
    for _ in range(repeat):
        start = time.perf_counter()
        subprocess.run([sys.executable, '-c', IMPORTS], check=True)
        runs['start-up'].append(time.perf_counter() - start)
        chain = json.loads(subprocess.run(
            [sys.executable, '-c', CHAIN, str(bag), str(png), str(repeat)], check=True,
            capture_output=True, text=True).stdout)
        for key in ('assess', 'refits', 'draw'):
            runs[key].append(chain[key])
        baseline = json.loads(subprocess.run([sys.executable, '-c', ROSBAGS, str(bag)],
                                             check=True, capture_output=True,
                                             text=True).stdout)
        assert baseline['messages'] == chain['messages']
        runs['rosbags'].append(baseline['seconds'])
    return {key: statistics.median(values) for key, values in runs.items()}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--samples', type=int, nargs='+', default=[300_000])
    parser.add_argument('--rates', type=float, nargs='+', default=[100.0, 1000.0])
    parser.add_argument('--repeat', type=int, default=3, help='runs of each (median)')
    parser.add_argument('--no-append', action='store_true')
    args = parser.parse_args()
    rows = [['bag', 'rosbags read + deserialize [s]', 'budget of 3x [s]', 'start-up [s]',
             'assessment chain [s] (of it RUL refits)', 'plot draw [s]', 'floor [s]',
             'floor / budget']]
    compile_package()
    with tempfile.TemporaryDirectory() as tmp:
        for rate in args.rates:
            for samples in args.samples:
                bag = Path(tmp) / f'bag_{rate:g}_{samples}'
                simulate(bag, samples, rate)
                m = measure(bag, Path(tmp) / 'plot.png', args.repeat)
                budget = m['rosbags'] / 3.0
                floor = m['start-up'] + m['assess'] + m['draw']
                rows.append([f'{samples:,} samples, {rate:g} Hz', f'{m["rosbags"]:.2f}',
                             f'{budget:.2f}', f'{m["start-up"]:.2f}',
                             f'{m["assess"]:.2f} ({m["refits"]:.2f})', f'{m["draw"]:.2f}',
                             f'{floor:.2f}', f'{floor / budget:.2f}'])
                print(' | '.join(rows[-1]), flush=True)
                subprocess.run(['rm', '-rf', str(bag)], check=True)
    notes = (f'Medians of {args.repeat} runs. Bags as bench/analyze_e2e.py. The floor is the '
             'sequential part of one analysis: above 1, no use of the second core can bring '
             'the whole process to 3x rosbags without changing its outputs.')
    append_section('Offline analysis: the sequential floor against 3x rosbags', rows, notes,
                   out=None if args.no_append else BENCHMARKS_MD)
    return 0


if __name__ == '__main__':
    sys.exit(main())
