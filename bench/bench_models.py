"""Vectorised throughput of gear_phm.models on 1e6-element arrays.

Baseline, measured in the same run: numpy evaluating the bare rational expression of eq 10
((R - u) / (R (1 + u))) with no validation. Ratio = model rate / baseline rate.

Usage: .venv/bin/python bench/bench_models.py [--size 1000000] [--no-append]
"""
from __future__ import annotations

import argparse
from pathlib import Path
import sys

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import append_section, BENCHMARKS_MD, best_of  # noqa: E402
from gear_phm import models  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--size', type=int, default=1_000_000)
    parser.add_argument('--repeat', type=int, default=5)
    parser.add_argument('--no-append', action='store_true', help='print only')
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    n = args.size
    u = rng.uniform(0.0, 2.0, n)
    ratio = rng.uniform(0.1, 50.0, n)
    eta_d = models.eta_opposing(u, ratio)
    z1 = rng.uniform(20.0, 60.0, n)
    z2 = rng.uniform(20.0, 3000.0, n)
    friction = rng.uniform(0.0, 0.3, n)

    baseline = best_of(lambda: (ratio - u) / (ratio * (1.0 + u)), args.repeat)
    cases = {
        'eta_opposing(u, R)': lambda: models.eta_opposing(u, ratio),
        'eta_aiding(u, R)': lambda: models.eta_aiding(u, ratio),
        'u_from_eta_opposing(eta, R)': lambda: models.u_from_eta_opposing(eta_d, ratio),
        'eta_aiding_from_opposing(eta, R)': lambda: models.eta_aiding_from_opposing(eta_d, ratio),
        'SpurGear(...).efficiencies()': lambda: models.SpurGear(
            z1=z1, z2=z2, module=2e-3, friction=friction, bearing_radius_1=1e-3,
            bearing_radius_2=2e-3).efficiencies(),
        'total_squared_error(eta_D, eta_I, R)': lambda: models.total_squared_error(
            eta_d, models.eta_aiding(u, ratio) * 0.99, ratio),
    }
    rows = [['function', 'evaluations/s', 'ratio to bare numpy eq 10']]
    rows.append(['bare numpy `(R-u)/(R(1+u))` (baseline)', f'{n / baseline:,.0f}', '1.00'])
    for name, func in cases.items():
        elapsed = best_of(func, args.repeat)
        rows.append([f'`{name}`', f'{n / elapsed:,.0f}', f'{baseline / elapsed:.2f}'])
    append_section(f'Models: vectorised throughput, {n:,}-element arrays', rows,
                   'Best of 5 wall times. The gap to the baseline is input validation '
                   '(finite/positive checks) and the NaN masking of the out-of-domain results.',
                   out=None if args.no_append else BENCHMARKS_MD)
    return 0


if __name__ == '__main__':
    sys.exit(main())
