"""The best alpha-lambda any RUL predictor can reach on the random-life prior (issue 23).

An oracle knows everything about a life but the future: its mean wear law (with a regime change
still to come), its running-in, its process, and the true friction at t_lambda. Only the
future increments of a stochastic life (gamma or Wiener, docs/lives.md) are unknown. For each
wear life and lambda of the acceptance (:data:`~gear_phm.prognostics.metrics.
ACCEPTANCE_LAMBDAS`), the true RUL's distribution given all that is drawn from ``--futures``
alternative futures: the life's own path up to t_lambda, then the increments of the same
process under other seeds (its increments are independent, so each is a draw of the future).
The end of life of each future is where the plant's true u reaches the life's u_eol, as
:func:`~gear_phm.simulation.lives.end_of_life` finds it for the recorded path.

A point prediction p passes alpha-lambda when 0.8 r <= p <= 1.2 r, i.e. when the true RUL r
lies in [p / 1.2, p / 0.8]. The best any predictor can do at that (life, lambda) is the largest
probability of that interval over p (searched over the quantiles of the drawn RULs); a
deterministic life's is 1 (the oracle knows its RUL). The mean over every (life, lambda)
pair is the ceiling of the acceptance's "alpha-lambda passes for at least 90 % of the pairs".

Usage: .venv/bin/python bench/rul_ceiling.py [--seeds 60] [--rates 100 1000] [--futures 300]
       [--workers 2] [--json OUT.json]
"""
from __future__ import annotations

import argparse
import json
import math
from multiprocessing import Pool
from pathlib import Path
import sys
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from gear_phm.prognostics.metrics import ACCEPTANCE_LAMBDAS, ALPHA  # noqa: E402
from gear_phm.simulation.lives import random_life  # noqa: E402
from gear_phm.simulation.parameters import config_from_parameters  # noqa: E402

#: 1 kHz lives are drawn only up to this record length [s] (bench/ensemble.py's rule).
FAST_RATE_MAX_DURATION = 3000.0
#: A future's end of life is searched on GRID_POINTS times up to HORIZON times the recorded
#: path's RUL (a resolution of 0.1 % of it; a later end of life counts as none: a miss).
GRID_POINTS = 6000
HORIZON = 6.0


def best_pass_probability(ruls: np.ndarray, alpha: float = ALPHA) -> float:
    """Largest P(p / (1 + alpha) <= r <= p / (1 - alpha)) over point predictions p.

    ``ruls``: drawn true RULs [s] (inf: no end of life in the future drawn).
    """
    r = np.sort(np.asarray(ruls, dtype=float))
    finite = r[np.isfinite(r)]
    if finite.size == 0:
        return 0.0
    candidates = np.unique(np.concatenate([finite * (1.0 + alpha), finite * (1.0 - alpha)]))
    low = np.searchsorted(r, candidates / (1.0 + alpha), side='left')
    high = np.searchsorted(r, candidates / (1.0 - alpha), side='right')
    return float(np.max(high - low) / r.size)


def life_ceiling(task: tuple[int, float, int]) -> dict[str, Any] | None:
    """Ceilings of one life's lambdas, or None for a healthy life (not in alpha-lambda)."""
    seed, rate, futures = task
    life = random_life(seed, rate)
    if life.family == 'healthy' or (rate > 100.0 and life.duration > FAST_RATE_MAX_DURATION):
        return None
    p = dict(life.parameters)
    stochastic = p.get('wear_process', 'none') != 'none'
    plant = config_from_parameters(p).plant
    path = config_from_parameters(p).wear_path()
    start = life.onset if life.onset is not None else 0.0
    eol = float(life.end_of_life)
    ceilings = []
    others = [config_from_parameters({**p, 'seed': 1_000_003 * (k + 1) + seed}).wear_path()
              for k in range(futures if stochastic else 0)]
    for lam in ACCEPTANCE_LAMBDAS:
        if not stochastic:
            ceilings.append(1.0)
            continue
        t = start + lam * (eol - start)
        remaining = eol - t
        grid = t + np.linspace(0.0, HORIZON * remaining, GRID_POINTS)
        now = float(path.value(np.array([t]))[0])
        ruls = np.empty(len(others))
        for k, other in enumerate(others):
            friction = now + other.value(grid) - float(other.value(np.array([t]))[0])
            hits = np.flatnonzero(plant.efficiencies(friction)[0] >= life.u_eol)
            ruls[k] = grid[hits[0]] - t if hits.size else math.inf
        ceilings.append(best_pass_probability(ruls))
    return {'seed': seed, 'rate_hz': rate, 'family': life.family,
            'features': list(life.features), 'stochastic': stochastic,
            'ceilings': dict(zip((str(lam) for lam in ACCEPTANCE_LAMBDAS), ceilings))}


def summary(rows: list[dict[str, Any]]) -> list[tuple[str, int, float, list[float]]]:
    """(group, wear lives, ceiling over its pairs, per lambda) for all and by process."""
    out = []
    groups = [('all', rows), ('stochastic (gamma, Wiener)', [r for r in rows if r['stochastic']]),
              ('deterministic', [r for r in rows if not r['stochastic']])]
    for name, group in groups:
        if not group:
            continue
        values = np.array([[r['ceilings'][str(lam)] for lam in ACCEPTANCE_LAMBDAS]
                           for r in group])
        out.append((name, len(group), float(values.mean()), values.mean(axis=0).tolist()))
    return out


def main() -> int:
    """Draw the lives, print the ceiling table (markdown)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seeds', type=int, default=60)
    parser.add_argument('--rates', type=float, nargs='+', default=[100.0, 1000.0])
    parser.add_argument('--futures', type=int, default=300)
    parser.add_argument('--workers', type=int, default=2)
    parser.add_argument('--json', type=Path, default=None)
    args = parser.parse_args()
    tasks = [(seed, rate, args.futures) for rate in args.rates
             for seed in range(1, args.seeds + 1)]
    with Pool(args.workers) as pool:
        rows = [r for r in pool.map(life_ceiling, tasks, chunksize=1) if r is not None]
    lams = ' | '.join(f'lambda {lam}' for lam in ACCEPTANCE_LAMBDAS)
    print(f'| rate | lives | wear lives | alpha-lambda ceiling (all pairs) | {lams} |')
    print('|---|---|---|---|' + '---|' * len(ACCEPTANCE_LAMBDAS))
    for rate in args.rates:
        for name, count, mean, per in summary([r for r in rows if r['rate_hz'] == rate]):
            cells = ' | '.join(f'{v:.0%}' for v in per)
            print(f'| {rate:g} Hz | {name} | {count} | {mean:.0%} | {cells} |')
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == '__main__':
    sys.exit(main())
