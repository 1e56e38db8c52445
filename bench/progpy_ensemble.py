"""progpy on the random-life ensemble of bench/ensemble.py (issue 23: progpy side by side).

For each life that bench/ensemble.py simulated and analysed, the eq-13 pseudo-measurements of
u that gear_phm's filter accepted (``analyze_bag(...).measurements``, with the life's ratio and
eta_opposing_min) go to bench/progpy_baseline.py's worker in the progpy venv: a UKF and a
MonteCarlo predictor with a linear and with an exponential wear model. Predictions are made at
t_P + lambda (t_EOL - t_P) for lambda 0.5, 0.75, 0.9 and every 2 % of the life (t_P the onset),
and scored with gear_phm.prognostics.metrics.acceptance as `gear-phm evaluate` scores gear_phm
(progpy has no health levels). A healthy life is predicted every 2 % of its record and passes
when every median is inf. Results are cached in each life's directory (progpy.json).
"""
from __future__ import annotations

import argparse
import json
import math
from multiprocessing import Pool
from pathlib import Path
import subprocess
from typing import Any

import numpy as np

from progpy_baseline import earliest_prediction, GRID, prediction_times, write_exchange

MODELS = ('linear', 'exponential')
LAMBDAS = (0.5, 0.75, 0.9)


def _life(task: tuple[dict[str, Any], argparse.Namespace]) -> dict[str, Any]:
    """Run progpy on one life; return {model: acceptance scores} (cached in progpy.json)."""
    from gear_phm.offline import analyze_bag
    from gear_phm.prognostics.metrics import acceptance, healthy_acceptance

    result, args = task
    directory, life = Path(result['directory']), result['life']
    cache = directory / 'progpy.json'
    if args.reuse and cache.is_file():
        cached: dict[str, Any] = json.loads(cache.read_text())
        return cached
    analysis = analyze_bag(directory / 'bag', float(life['ratio']),
                           eta_opposing_min=float(life['eta_opposing_min']), plot=False)
    rows = [(stamp * 1e-9, m.u, m.u_variance) for stamp, m, accepted in analysis.measurements
            if accepted and math.isfinite(m.u)]
    measured = np.array(rows)
    if life['healthy']:
        t_start, t_end = float(measured[0, 0]), float(life['duration_s'])
        t_pred = t_start + np.arange(1, GRID + 1) / GRID * (t_end - t_start)
        t_pred = t_pred[t_pred >= earliest_prediction(measured)]
    else:
        t_start, t_end = float(life['onset_s']), float(life['end_of_life_s'])
        t_pred = prediction_times(t_start, t_end, LAMBDAS, measured)
    exchange, predictions = directory / 'progpy_in.npz', directory / 'progpy_out.npz'
    write_exchange(exchange, measured, t_pred, float(life['u_eol']))
    subprocess.run(['nice', '-n', '19', args.progpy_python,
                    str(Path(__file__).with_name('progpy_baseline.py')), '--worker',
                    str(exchange), str(predictions), '--samples', str(args.samples),
                    '--seed', str(life['seed'])], check=True)
    data = np.load(predictions)
    scored = {}
    for model in MODELS:
        if life['healthy']:
            scored[model] = {'healthy': healthy_acceptance(data[model])}
        else:
            scored[model] = acceptance(t_pred, data[model], data[f'{model}_p5'],
                                       data[f'{model}_p95'], t_end, t_start)
    cache.write_text(json.dumps(scored, indent=2) + '\n')
    return scored


def progpy_results(results: list[dict[str, Any]], args: argparse.Namespace
                   ) -> dict[str, list[dict[str, Any]]]:
    """Return, per progpy model, the lives with progpy's scores in place of gear_phm's."""
    with Pool(args.workers) as pool:
        scores = pool.map(_life, [(result, args) for result in results])
    return {model: [{'life': result['life'], 'evaluation': {'acceptance': score[model]}}
                    for result, score in zip(results, scores)] for model in MODELS}
