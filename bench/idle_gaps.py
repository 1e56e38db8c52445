"""Idle gaps: the RUL on operating time against a RUL on elapsed time, on a simulated fleet.

Simulates a fleet (``gear-phm simulate --fleet``) whose recordings are separated by idle gaps
(a week by default; ``--gap-spread`` scatters them as irregular flights would), analyses each
unit's campaign with the Python API (``gear_phm.offline.analyze_bag`` over its recordings) and
scores, for every unit that reaches its end of life within its recordings, the alpha-lambda
checks (``gear_phm.prognostics.metrics.ALPHA``) and the prognostic horizon of:

- **operating time**: the diagnostics' ``rul_operating`` against the true RUL in operating
  time (the true end of life, from the ``gear_phm/truth/friction`` topic, mapped through the
  analysis's own operating clock);
- **elapsed time**: the same estimates through a HealthAssessor whose trend runs on the stamps
  (their operating time withheld, as before issue 13), against the true RUL in elapsed time.

Usage: .venv/bin/python bench/idle_gaps.py [--units 8] [--recordings 10] [--duration 30]
       [--gap 604800] [--gap-spread 0] [--wear linear] [--seed 11]
"""
from __future__ import annotations

import argparse
from dataclasses import fields
import math
from pathlib import Path
import subprocess
import sys
import tempfile

import numpy as np

from gear_phm.estimation import FrictionEstimate
from gear_phm.interfaces import TRUTH_FRICTION
from gear_phm.offline import analyze_bag
from gear_phm.offline.records import EstimateHistory
from gear_phm.prognostics import end_of_life_u, HealthAssessor, HealthConfig
from gear_phm.prognostics.metrics import ALPHA, evaluate, LAMBDAS, true_end_of_life_index

GEAR_PHM = Path(sys.executable).parent / 'gear-phm'
RATIO, ETA_MIN = 3.0, 0.7333


def estimates_of(history: EstimateHistory) -> list[FrictionEstimate]:
    """Return the estimates as records, without their operating time (NaN)."""
    names = [f.name for f in fields(history)]
    columns = {name: getattr(history, name) for name in names}
    out = []
    for i in range(history.stamp_ns.size):
        out.append(FrictionEstimate(
            int(columns['stamp_ns'][i]), float(columns['u'][i]), float(columns['rate'][i]),
            (float(columns['p_uu'][i]), float(columns['p_ur'][i]), float(columns['p_rr'][i])),
            float(columns['eta_opposing'][i]), float(columns['eta_aiding'][i]),
            float(columns['measured_efficiency'][i]), float(columns['innovation'][i]),
            float(columns['innovation_variance'][i]), float(columns['nis'][i]),
            int(columns['samples_used'][i]), int(columns['samples_rejected'][i]),
            int(columns['power_flow'][i])))
    return out


def score(t: np.ndarray, rul: np.ndarray, t_eol: float) -> tuple[list[bool], float]:
    """(alpha-lambda passes at LAMBDAS, prognostic horizon as a share of the life)."""
    result = evaluate(t, rul, t_eol, lambdas=LAMBDAS)
    passes = [bool(check['passed']) for check in result['alpha_lambda']]
    horizon = result['prognostic_horizon_s']
    life = t_eol - float(result['t_start_s'])
    share = float(horizon) / life if isinstance(horizon, float) and life > 0 else 0.0
    return passes, share


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--units', type=int, default=8)
    parser.add_argument('--recordings', type=int, default=10)
    parser.add_argument('--duration', type=float, default=30.0, help='per recording [s]')
    parser.add_argument('--gap', type=float, default=7 * 86400.0, help='idle gap [s]')
    parser.add_argument('--gap-spread', type=float, default=0.0)
    parser.add_argument('--wear', default='linear')
    parser.add_argument('--friction-final', type=float, default=0.30)
    parser.add_argument('--seed', type=int, default=11)
    args = parser.parse_args()
    u_eol, _ = end_of_life_u(RATIO, ETA_MIN)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / 'fleet'
        subprocess.run([str(GEAR_PHM), 'simulate', '--fleet', str(args.units), '--recordings',
                        str(args.recordings), '--duration', str(args.duration), '--gap',
                        str(args.gap), '--gap-spread', str(args.gap_spread), '--wear',
                        args.wear, '--friction-initial', '0.05', '--friction-final',
                        str(args.friction_final), '--truth-every', '10', '--seed',
                        str(args.seed), '--out', str(root)], check=True, capture_output=True)
        for unit in sorted(root.iterdir()):
            bags = sorted(unit.glob('rec_*'))
            analysis = analyze_bag(bags, RATIO, eta_opposing_min=ETA_MIN, plot=True)
            truth = analysis.truth[TRUTH_FRICTION]           # (stamp [ns], u, value, 0)
            reached = true_end_of_life_index(truth[:, 1], u_eol)
            if reached is None:
                rows.append((unit.name, None))
                continue
            eol_stamp = truth[reached, 0] * 1e-9
            e, h = analysis.estimates, analysis.health
            eol_operating = float(np.interp(eol_stamp, e.t, e.operating_time))
            operating = score(h.operating_time, h.rul_operating_median, eol_operating)
            assessor = HealthAssessor(HealthConfig(ratio=RATIO, eta_opposing_min=ETA_MIN))
            states = [s for s in map(assessor.on_estimate, estimates_of(e)) if s is not None]
            elapsed = score(np.array([s.stamp_ns * 1e-9 for s in states]),
                            np.array([s.rul.median for s in states]), eol_stamp)
            converted = score(h.t, h.rul_median, eol_stamp)
            rows.append((unit.name, (eol_operating, eol_stamp / 86400.0, operating, elapsed,
                                     converted)))
    print(f'fleet: {args.units} units x {args.recordings} recordings of {args.duration:g} s, '
          f'gaps {args.gap:g} s (spread {args.gap_spread:g}), {args.wear} wear, seed '
          f'{args.seed}; alpha {ALPHA:g}, lambda {", ".join(map(str, LAMBDAS))}\n')
    print('| unit | EOL: operating time [s] / elapsed [days] | RUL on operating time: '
          'alpha-lambda, horizon | RUL on elapsed time (trend on stamps) | rul_s '
          '(rul_operating / utilisation) |')
    print('|---|---|---|---|---|')

    def cell(result: tuple[list[bool], float]) -> str:
        passes, share = result
        marks = ' '.join('pass' if p else 'FAIL' for p in passes)
        return f'{marks}; {100 * share:.0f} %'

    for name, result in rows:
        if result is None:
            print(f'| {name} | not reached in its recordings | - | - | - |')
            continue
        eol_op, eol_days, operating, elapsed, converted = result
        print(f'| {name} | {eol_op:.1f} / {eol_days:.2f} | {cell(operating)} | {cell(elapsed)} '
              f'| {cell(converted)} |')
    scored = [r for _, r in rows if r is not None]
    ok = all(all(r[2][0][1:]) for r in scored)
    print(f'\nunits at end of life: {len(scored)}; operating-time RUL passes lambda 0.5 and '
          f'0.75 on all of them: {ok}')
    return 0 if ok and not math.isnan(len(scored)) else 1


if __name__ == '__main__':
    raise SystemExit(main())
