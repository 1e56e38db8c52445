"""Population prior: how much units at end of life improve the early RUL of the others.

Simulates a fleet that shares one wear law with unit-to-unit scatter (``gear-phm simulate
--fleet``, power law u = u0 + a t^p by default), analyses every unit without a prior, builds
the fleet's prior from the units that reached their end of life
(:func:`gear_phm.offline.fleet.population_prior`: their wear law and its shape), analyses the
units still running again with it, and compares the RUL in operating time at lambda = 0.25 and
0.5 of each running unit's life with and without the prior. The true end of life of a running
unit comes from its truth.yaml (the simulated law), mapped onto the analysis's operating clock.

Usage: .venv/bin/python bench/population_prior.py [--units 16] [--recordings 8]
       [--duration 30] [--wear power] [--exponent 3] [--friction-final 0.27] [--seed 21]
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path
import statistics
import subprocess
import sys
import tempfile

import numpy as np
import yaml

from gear_phm.offline import analyze_bag
from gear_phm.offline.fleet import population_prior
from gear_phm.prognostics import end_of_life_u

GEAR_PHM = Path(sys.executable).parent / 'gear-phm'
RATIO, ETA_MIN, ALPHA = 3.0, 0.7333, 0.2
LAMBDAS = (0.25, 0.5)


def true_eol(truth: dict, u_eol: float) -> float:
    """Plant time [s of recording] at which the simulated law reaches u_eol."""
    wear = truth['wear']
    gap = u_eol - wear['initial']
    if wear['kind'] == 'linear':
        return gap / wear['rate']
    if wear['kind'] == 'power':
        return float((gap / wear['rate']) ** (1.0 / wear['exponent']))
    if wear['kind'] == 'exponential':
        # value(t) = initial * exp(rate t)
        return math.log(u_eol / wear['initial']) / wear['rate']
    raise ValueError(f'no closed-form end of life for {wear["kind"]}')


def early_errors(analysis, eol_plant: float, plant_end: float) -> list[float]:
    """Relative RUL errors (predicted / true - 1) at LAMBDAS of the life, operating time."""
    h, e = analysis.health, analysis.estimates
    scale = float(e.operating_time[-1]) / plant_end        # operating per plant second
    eol = eol_plant * scale
    start = float(h.operating_time[0])
    errors = []
    for lam in LAMBDAS:
        t_lam = start + lam * (eol - start)
        at = int(np.searchsorted(h.operating_time, t_lam))
        if at >= h.operating_time.size:
            errors.append(math.nan)
            continue
        true = eol - float(h.operating_time[at])
        errors.append(float(h.rul_operating_median[at]) / true - 1.0)
    return errors


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--units', type=int, default=16)
    parser.add_argument('--recordings', type=int, default=8)
    parser.add_argument('--duration', type=float, default=30.0)
    parser.add_argument('--wear', default='power')
    parser.add_argument('--exponent', type=float, default=3.0)
    parser.add_argument('--friction-final', type=float, default=0.27,
                        help='nominal u at the end of the recordings')
    parser.add_argument('--seed', type=int, default=21)
    args = parser.parse_args()
    u_eol, _ = end_of_life_u(RATIO, ETA_MIN)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / 'fleet'
        subprocess.run([str(GEAR_PHM), 'simulate', '--fleet', str(args.units), '--recordings',
                        str(args.recordings), '--duration', str(args.duration), '--wear',
                        args.wear, '--wear-exponent', str(args.exponent), '--friction-initial',
                        '0.05', '--friction-final', str(args.friction_final),
                        '--unit-spread', '0.3',
                        '--truth-every', '10', '--seed', str(args.seed), '--out', str(root)],
                       check=True, capture_output=True)
        plant_end = args.recordings * args.duration
        first, running = {}, []
        for unit in sorted(root.iterdir()):
            bags = sorted(unit.glob('rec_*'))
            truth = yaml.safe_load((unit / 'truth.yaml').read_text())
            analysis = analyze_bag(bags, RATIO, eta_opposing_min=ETA_MIN, plot=False)
            first[unit.name] = analysis.summary
            eol = true_eol(truth, u_eol)
            if eol > plant_end:
                running.append((unit, bags, eol, early_errors(analysis, eol, plant_end)))
        prior = population_prior(list(first.values()))
        print(f'fleet: {args.units} units x {args.recordings} recordings of {args.duration:g} s,'
              f' {args.wear} wear (exponent {args.exponent:g}), scatter 30 %, seed {args.seed}')
        print(f'units at end of life: {args.units - len(running)}; prior: {prior}\n')
        if prior is None:
            print('no prior (fewer than 3 units at end of life, or no shared law)')
            return 1
        print('| unit | true end of life [s of recording] | RUL error at lambda 0.25: no '
              'prior / prior | at lambda 0.5: no prior / prior |')
        print('|---|---|---|---|')
        rows = []
        for unit, bags, eol, without in running:
            analysis = analyze_bag(bags, RATIO, eta_opposing_min=ETA_MIN, plot=False,
                                   prior=prior)
            with_prior = early_errors(analysis, eol, plant_end)
            rows.append((without, with_prior))
            print(f'| {unit.name} | {eol:.0f} | '
                  + ' | '.join(f'{100 * a:+.0f} % / {100 * b:+.0f} %'
                               for a, b in zip(without, with_prior)) + ' |')
    for k, lam in enumerate(LAMBDAS):
        pairs = [(a[k], b[k]) for a, b in rows if math.isfinite(a[k]) and math.isfinite(b[k])]
        if not pairs:
            continue
        mean_a = statistics.mean(abs(a) for a, _ in pairs)
        mean_b = statistics.mean(abs(b) for _, b in pairs)
        inside_a = sum(abs(a) <= ALPHA for a, _ in pairs)
        inside_b = sum(abs(b) <= ALPHA for _, b in pairs)
        print(f'\nlambda {lam}: {len(pairs)} running units; mean |RUL error| '
              f'{100 * mean_a:.0f} % without the prior, {100 * mean_b:.0f} % with it; within '
              f'alpha {ALPHA}: {inside_a} without, {inside_b} with')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
