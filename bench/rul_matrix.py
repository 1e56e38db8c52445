"""RUL wear-law matrix: simulate -> analyze -> evaluate, no tuning (docs/prognostics.md).

For linear, exponential and power-law (exponent 3) wear from u = 0.05 to u_eol = 0.6
(eta_opposing_min 0.5, ratio 3) in LIFE seconds at 100 Hz, per seed: alpha-lambda at 0.5,
0.75 and 0.9, the prognostic horizon, from which fraction of the life the RUL stays finite, and
the share of predictions from lambda 0.25 whose p5-p95 band holds the true RUL, and the health
level transitions, all as `gear-phm evaluate` scores them (evaluation.json). Prints one
markdown row per run and writes OUT/table.md.

Usage: .venv/bin/python bench/rul_matrix.py [--lives 300 3000 30000] [--seeds 1 2 3]
       [--rate 1000] [--laws linear exponential power] [--reuse] OUT [-- extra analyze options]

Truth is written every 10th sample at 100 Hz and every 100th at 1 kHz (10 Hz either way).
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
import shutil
import subprocess
import sys

GEAR_PHM = [sys.executable, '-m', 'gear_phm.cli.main']
RATES = {'linear': lambda life: 0.55 / life, 'exponential': lambda life: math.log(12) / life,
         'power': lambda life: 0.55 / life ** 3}
HEALTH = ['--ratio', '3', '--eta-opposing-min', '0.5']


def run(out: Path, law: str, life: float, seed: int, extra: list[str],
        rate: float = 100.0, reuse: bool = False, analysis_name: str = 'a') -> str:
    """One scenario; returns its markdown row. ``reuse``: keep a bag simulated before.

    The analysis goes to OUT/``analysis_name``.
    """
    bag, analysis = out / 'bag', out / analysis_name
    if reuse and bag.exists():
        shutil.rmtree(analysis, ignore_errors=True)
    else:
        shutil.rmtree(out, ignore_errors=True)
        out.mkdir(parents=True)
    quiet = {'check': True, 'stdout': subprocess.DEVNULL, 'stderr': subprocess.DEVNULL}
    if not bag.exists():
        subprocess.run([*GEAR_PHM, 'simulate', '--rate', repr(rate), '--out', str(bag),
                        '--duration', str(1.1 * life), '--seed', str(seed), '--wear', law,
                        '--wear-rate', repr(RATES[law](life)), '--friction-initial', '0.05',
                        '--wear-exponent', '3', '--truth-every',
                        str(max(1, round(rate / 10.0)))], **quiet)
    subprocess.run([*GEAR_PHM, 'analyze', str(bag), *HEALTH, '--out', str(analysis),
                    '--no-plot', '--no-progress', *extra], **quiet)
    subprocess.run([*GEAR_PHM, 'evaluate', str(analysis), '--truth', str(bag), *HEALTH,
                    '--lambdas', '0.25', '0.5', '0.75', '0.9'], **quiet)
    metrics = json.loads((analysis / 'evaluation.json').read_text())
    t_eol = metrics['t_eol_s']
    checks = {check['lam']: check for check in metrics['alpha_lambda']}

    def cell(lam: float) -> str:
        check = checks[lam]
        predicted = check['predicted_rul']
        error = predicted / check['true_rul'] - 1.0 if isinstance(predicted, float) else math.inf
        return f"{'pass' if check['passed'] else 'FAIL'} {error:+.0%}"

    horizon = metrics['prognostic_horizon_s']
    finite_from = float(metrics['rul_finite_from'])
    band = float(metrics['band_coverage']['share'])
    return (f'| {law} | {life:.0f} | {rate:.0f} | {seed} | {cell(0.5)} | {cell(0.75)} | '
            f'{cell(0.9)} | {horizon:.0f} ({horizon / t_eol:.0%}) | {finite_from:.2f} | '
            f'{band:.0%} | {level_changes(metrics)} |')


def level_changes(metrics: dict) -> str:
    """Return the health-level transitions that `gear-phm evaluate` found.

    E.g. 'OK>WARN 0.12, WARN>ERROR 1.01' (fractions of the true life), with '(ERROR early)'
    if ERROR came before the true end of life.
    """
    steps = [f"{c['from']}>{c['to']} {c['lam']:.2f}" for c in metrics['level_transitions']]
    return ', '.join(steps) + (' (ERROR early)' if metrics['error_before_eol'] else '')


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('out', type=Path)
    parser.add_argument('--lives', type=float, nargs='+', default=[300.0, 3000.0])
    parser.add_argument('--seeds', type=int, nargs='+', default=[1, 2, 3])
    parser.add_argument('--rate', type=float, default=100.0, help='sample rate [Hz]')
    parser.add_argument('--laws', nargs='+', choices=list(RATES), default=list(RATES))
    parser.add_argument('--reuse', action='store_true',
                        help='analyse the bags of an earlier run in OUT again')
    parser.add_argument('extra', nargs='*', help='extra analyze options (after --)')
    args = parser.parse_args()
    rows = []
    for life in args.lives:
        for law in args.laws:
            for seed in args.seeds:
                rows.append(run(args.out / f'{law}_{life:.0f}_{args.rate:.0f}_{seed}', law,
                                life, seed, args.extra, args.rate, args.reuse))
                print(rows[-1], flush=True)
    (args.out / 'table.md').write_text('\n'.join(rows) + '\n')
    return 0


if __name__ == '__main__':
    sys.exit(main())
