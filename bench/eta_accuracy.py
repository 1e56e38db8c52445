"""Efficiency accuracy of an ensemble's analyses against the load-dependent truth.

For each life of a `bench/ensemble.py` output (OUT/<rate>hz/life_<seed>/bag and its analysis
folder), the estimated eta_D and eta_I on `gear_phm/efficiency` at each /diagnostics tick
after the filter settled (from max(120 s, 5 % of the record) on) are compared with the true
ones on `gear_phm/truth/efficiency` at the same time. A life passes when at least 90 % of its
settled ticks are within 0.01 on eta_D and on eta_I; the table gives each life's share and
the share of lives that pass.

Usage: .venv/bin/python bench/eta_accuracy.py OUT [--analysis a] [--tolerance 0.01]
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path
import sys

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from gear_phm.bagio.series import read_vector_topic  # noqa: E402

SETTLE_S = 120.0
SETTLE_SHARE = 0.05
PASS_SHARE = 0.9


def life_accuracy(life_dir: Path, analysis: str, tolerance: float) -> dict[str, float] | None:
    """Return the share of settled ticks within ``tolerance`` of the truth (None if none)."""
    bag, out = life_dir / 'bag', life_dir / analysis
    if not (out / 'summary.json').is_file():
        return None
    t_truth, truth = read_vector_topic(bag, 'gear_phm/truth/efficiency')
    t_est, estimate = read_vector_topic(out, 'gear_phm/efficiency')
    if t_truth.size == 0 or t_est.size == 0:
        return None
    t0, span = float(t_truth[0]), float(t_truth[-1] - t_truth[0])
    settled = t_est >= t0 + max(SETTLE_S, SETTLE_SHARE * span)
    t_est, estimate = t_est[settled], estimate[settled]
    if not t_est.size:
        return None
    # one tick a second, as the /diagnostics statuses
    pick = np.searchsorted(t_est, np.arange(t_est[0], t_est[-1] + 1.0, 1.0)).clip(
        0, t_est.size - 1)
    t_est, estimate = t_est[pick], estimate[pick]
    at = np.searchsorted(t_truth, t_est).clip(0, t_truth.size - 1)
    error_d = np.abs(estimate[:, 0] - truth[at, 0])
    error_i = np.abs(estimate[:, 1] - truth[at, 1])
    within = (error_d <= tolerance) & (error_i <= tolerance)
    return {'share': float(np.mean(within)), 'median_error_d': float(np.median(error_d)),
            'median_error_i': float(np.median(error_i)), 'ticks': int(t_est.size)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('out', type=Path)
    parser.add_argument('--analysis', default='a')
    parser.add_argument('--tolerance', type=float, default=0.01)
    args = parser.parse_args()
    rows = []
    for life_dir in sorted(args.out.glob('*hz/life_*'),
                           key=lambda p: (p.parent.name, int(p.name.split('_')[1]))):
        score = life_accuracy(life_dir, args.analysis, args.tolerance)
        life = json.loads((life_dir / 'bag' / 'life.json').read_text())
        rows.append((life_dir.parent.name, life['seed'], life['healthy'], score))
    print('| rate | seed | healthy | settled ticks within | median error eta_D | '
          'median error eta_I |')
    print('|---|---|---|---|---|---|')
    for rate, seed, healthy, score in rows:
        if score is None:
            print(f'| {rate} | {seed} | {healthy} | no estimate | - | - |')
            continue
        print(f"| {rate} | {seed} | {healthy} | {100 * score['share']:.0f} % | "
              f"{score['median_error_d']:.4f} | {score['median_error_i']:.4f} |")
    for rate in sorted({row[0] for row in rows}):
        scores = [row[3] for row in rows if row[0] == rate]
        passed = sum(1 for s in scores if s is not None and s['share'] >= PASS_SHARE)
        print(f'\n{rate}: {passed} of {len(scores)} lives ({100 * passed / len(scores):.0f} %) '
              f'have >= {100 * PASS_SHARE:.0f} % of their settled ticks within '
              f'{args.tolerance:g} on both efficiencies')
    return 0


if __name__ == '__main__':
    sys.exit(main())
