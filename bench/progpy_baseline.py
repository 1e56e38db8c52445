"""Peer baseline: NASA progpy against gear_phm on the RUL matrix bags (docs/prognostics.md).

Per scenario of bench/rul_matrix.py (linear, exponential, power wear from u = 0.05 to
u_eol = 0.6, ratio 3, eta_opposing_min 0.5, LIFE seconds at 100 Hz, per seed), gear_phm runs
its chain `simulate` -> `analyze` -> `evaluate` (only --ratio and --eta-opposing-min). progpy
gets the same bag's eq-13 pseudo-measurements of u (one per energy window, with its variance,
those gear_phm's filter accepted: `analyze_bag(...).measurements`), filters them with
progpy.state_estimators.UnscentedKalmanFilter and predicts the end of life with
progpy.predictors.MonteCarlo, once with a linear wear model (state u, rate) and once with an
exponential one (state u, growth). Both are scored by gear_phm.prognostics.metrics as
`gear-phm evaluate` scores gear_phm: the same t_start, true end of life and alpha = 0.2, with
predictions at lambda = 0.25, 0.5, 0.75, 0.9 and every 2 % of the life (for the horizon);
gear_phm's horizon is also given on that grid (its latest RUL at each grid time), since its
1 Hz predictions have more chances to leave the cone.
Prints one markdown row per run and writes OUT/table.md.

progpy runs in its own virtual environment (bench/requirements.txt), in a subprocess that
exchanges .npz files with this script; gear_phm runs in the project's environment:

    python3 -m venv /tmp/progpy_venv && /tmp/progpy_venv/bin/pip install -r bench/requirements.txt
    .venv/bin/python bench/progpy_baseline.py OUT --progpy-python /tmp/progpy_venv/bin/python

Options: --lives 300 3000, --seeds 1 2 3, --laws linear exponential power, --samples 100,
--q-rate 1e-10 (the UKFs' process noise), --reuse (keep the gear_phm runs already in OUT and
redo only progpy: for a process-noise sensitivity check), --told-law (also run gear_phm told
the true wear law, `analyze --trend LAW`, into OUT/<scenario>/told: the same information as
the progpy model of that law; its columns are added to the table).
"""
from __future__ import annotations

import argparse
from collections.abc import Sequence
import json
import math
from pathlib import Path
import subprocess
import sys
import time
from typing import Any

import numpy as np

LAMBDAS = (0.25, 0.5, 0.75, 0.9)
#: Extra prediction times for the prognostic horizon: every 2 % of the life.
GRID = 50
#: Process noise of the UKFs, fixed for every scenario (no tuning to the answer): the wear-rate
#: random walk of the linear model [(1/s)^2/s] is gear_phm's former hand-set process_noise
#: value; the growth random walk of the exponential model [(1/s)^2/s] is that divided by
#: u^2 at u = 0.3 (rate = growth * u).
Q_RATE = 1e-10
U_TYPICAL = 0.3
#: gear_phm's `--trend` for each simulated wear law with --told-law: the simulator's
#: exponential wear, u0 exp(k t), is gear_phm's proportional law (docs/prognostics.md).
TOLD_TREND = {'linear': 'linear', 'exponential': 'proportional', 'power': 'power'}


def earliest_prediction(measured: np.ndarray) -> float:
    """Return the first time [s] a prediction is made: the sixth measurement's (or the last's)."""
    return float(measured[min(5, len(measured) - 1), 0])


def prediction_times(t_start: float, t_end: float, lambdas: Sequence[float],
                     measured: np.ndarray) -> np.ndarray:
    """Return the prediction times [s]: at each lambda and every 1/GRID of [t_start, t_end].

    Only those from :func:`earliest_prediction` on.
    """
    t_pred = np.unique(np.concatenate([
        t_start + np.array(lambdas) * (t_end - t_start),
        t_start + np.arange(1, GRID) / GRID * (t_end - t_start)]))
    return t_pred[t_pred >= earliest_prediction(measured)]


def write_exchange(path: Path, measured: np.ndarray, t_pred: np.ndarray, u_eol: float) -> None:
    """Write the worker's input: measurements (t [s], u, variance), prediction times, u_eol."""
    np.savez(path, t=measured[:, 0], u=measured[:, 1], u_variance=measured[:, 2],
             t_pred=t_pred, u_eol=u_eol)


def _worker(source: Path, target: Path, samples: int, seed: int, q_rate: float) -> None:
    """Bench-venv side: UKF + MonteCarlo for both wear models; writes RULs [s].

    Per model, NAME: the median, NAME_p5 and NAME_p95 (percentiles of the samples' times of
    event, inf counted as the largest).
    """
    import warnings
    warnings.filterwarnings('ignore')
    from progpy import PrognosticsModel
    from progpy.predictors import MonteCarlo
    from progpy.state_estimators import UnscentedKalmanFilter
    from progpy.uncertain_data import MultivariateNormalDist

    data = np.load(source)
    t, z, var = data['t'], data['u'], data['u_variance']
    # progpy's estimators need strictly increasing times: of measurements with one stamp
    # (1 kHz life 60 had two) the first is kept
    rising = np.concatenate(([True], np.diff(t) > 0.0))
    t, z, var = t[rising], z[rising], var[rising]
    t_pred, u_eol = data['t_pred'], float(data['u_eol'])

    class LinearWear(PrognosticsModel):  # type: ignore[misc]
        """u' = rate, rate' = 0 (+ random walk in the filter); EOL when u >= u_eol."""

        inputs: list[str] = []
        states = ['u', 'rate']
        outputs = ['u']
        events = ['EOL']
        default_parameters = {'u_eol': u_eol, 'x0': {'u': 0.05, 'rate': 0.0},
                              'process_noise': 0.0, 'measurement_noise': 0.0}

        def next_state(self, x: Any, _: Any, dt: float) -> Any:
            x['u'] = x['u'] + x['rate'] * dt
            return x

        def output(self, x: Any) -> Any:
            return self.OutputContainer({'u': x['u']})

        def event_state(self, x: Any) -> dict[str, float]:
            return {'EOL': max(0.0, 1.0 - float(x['u']) / self['u_eol'])}

        def threshold_met(self, x: Any) -> dict[str, bool]:
            return {'EOL': bool(x['u'] >= self['u_eol'])}

    class ExponentialWear(LinearWear):
        """u' = growth u, growth' = 0 (+ random walk in the filter); EOL when u >= u_eol."""

        states = ['u', 'growth']
        default_parameters = {'u_eol': u_eol, 'x0': {'u': 0.05, 'growth': 0.0},
                              'process_noise': 0.0, 'measurement_noise': 0.0}

        def next_state(self, x: Any, _: Any, dt: float) -> Any:
            x['u'] = x['u'] * math.exp(x['growth'] * dt)
            return x

    def mean_rul(model: str, u: float, slope: float) -> float:
        if model == 'linear':
            return (u_eol - u) / slope if slope > 0.0 else math.inf
        return math.log(u_eol / u) / slope if slope > 0.0 and u > 0.0 else math.inf

    results = {}
    for name, cls, q in (('linear', LinearWear, q_rate),
                         ('exponential', ExponentialWear, q_rate / U_TYPICAL ** 2)):
        np.random.seed(seed)
        model = cls()
        u0 = float(np.mean(z[:5]))
        # u0 from the first windows; the rate/growth prior is wide (std 0.01/s).
        x0 = MultivariateNormalDist(model.states, [u0, 0.0],
                                    np.diag([float(np.var(z[:5])) + float(var[0]), 1e-4]))
        ukf = UnscentedKalmanFilter(model, x0, t0=float(t[0]), alpha=1e-3, beta=2.0,
                                    kappa=0.0)
        predictor = MonteCarlo(model)
        rul = np.full(t_pred.size, math.inf)
        bands = np.full((t_pred.size, 2), math.inf)
        k = 1
        for i, when in enumerate(t_pred):
            while k < t.size and t[k] <= when:
                dt = float(t[k] - t[k - 1])
                # progpy's UKF may have moved its own clock past t[k] (life 25: 5.01 s after
                # its first update at 3.01 s): such a measurement is skipped
                if dt > 0.0 and float(t[k]) > float(ukf.t):
                    ukf.filter.Q = np.array([[q * dt ** 3 / 3, q * dt ** 2 / 2],
                                             [q * dt ** 2 / 2, q * dt]])
                    if name == 'exponential':
                        ukf.filter.Q = np.diag([0.0, q * dt])
                    ukf.filter.R = np.array([[float(var[k])]])
                    ukf.estimate(float(t[k]), model.InputContainer({}),
                                 model.OutputContainer({'u': float(z[k])}))
                k += 1
            mean = ukf.filter.x
            guess = mean_rul(name, float(mean[0]), float(mean[1]))
            elapsed = max(float(when - t[0]), 1.0)
            # Step and horizon from the mean state's RUL (past u_eol: a short horizon).
            horizon = 5.0 * guess if math.isfinite(guess) else 20.0 * elapsed
            horizon = min(max(horizon, 0.01 * elapsed, 1.0), 100.0 * elapsed)
            result = predictor.predict(ukf.x, lambda *_: model.InputContainer({}),
                                       n_samples=samples, dt=horizon / 400.0,
                                       horizon=horizon, save_freq=horizon, t0=ukf.t)
            toe = np.array([math.inf if s['EOL'] is None else s['EOL']
                            for s in result.time_of_event])
            rul[i] = float(np.median(toe)) - float(when)
            bands[i] = np.percentile(toe, [5.0, 95.0], method='inverted_cdf') - float(when)
        results[name] = rul
        results[f'{name}_p5'], results[f'{name}_p95'] = bands[:, 0], bands[:, 1]
    np.savez(target, **results)


def _scenario(out: Path, law: str, life: float, seed: int, args: argparse.Namespace
              ) -> tuple[str, dict[str, Any]]:
    """Run gear_phm's chain and progpy on one bag; return the row and its numbers."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from rul_matrix import run as gear_phm_chain

    from gear_phm.bagio.series import read_vector_topic
    from gear_phm.offline.evaluation import find_bag
    from gear_phm.interfaces import HEALTH_RUL
    from gear_phm.offline import analyze_bag
    from gear_phm.prognostics.metrics import evaluate, prognostic_horizon

    started = time.perf_counter()
    if not (args.reuse and (out / 'a' / 'evaluation.json').is_file()):
        gear_phm_chain(out, law, life, seed, [])
    gear = json.loads((out / 'a' / 'evaluation.json').read_text())
    if args.told_law and not (args.reuse and (out / 'told' / 'evaluation.json').is_file()):
        gear_phm_chain(out, law, life, seed, ['--trend', TOLD_TREND[law]], reuse=True,
                       analysis_name='told')
    t_start, t_eol = float(gear['t_start_s']), float(gear['t_eol_s'])
    analysis = analyze_bag(out / 'bag', 3.0, eta_opposing_min=0.5, plot=False)
    rows = [(stamp * 1e-9, m.u, m.u_variance) for stamp, m, accepted in analysis.measurements
            if accepted and math.isfinite(m.u)]
    measured = np.array(rows)
    u_eol = float(gear['u_eol'])
    t_pred = prediction_times(t_start, t_eol, LAMBDAS, measured)
    exchange, predictions = out / 'progpy_in.npz', out / 'progpy_out.npz'
    write_exchange(exchange, measured, t_pred, u_eol)
    subprocess.run([args.progpy_python, __file__, '--worker', str(exchange), str(predictions),
                    '--samples', str(args.samples), '--seed', str(seed),
                    '--q-rate', repr(args.q_rate)], check=True)
    progpy = np.load(predictions)

    def horizon_on_grid(analysis: Path) -> float:
        """Horizon [s] of a gear_phm run from its latest RUL at each of progpy's times."""
        times, values = read_vector_topic(find_bag(analysis), HEALTH_RUL)
        before = times < t_eol
        index = np.searchsorted(times[before], t_pred, side='right') - 1
        return prognostic_horizon(t_pred[index >= 0], values[before, 0][index[index >= 0]],
                                  t_eol, 0.2, t_start)

    scored = {'gear_phm': gear}
    for name in ('linear', 'exponential'):
        scored[f'progpy_{name}'] = evaluate(t_pred, progpy[name], t_eol, 0.2, LAMBDAS, t_start)
    gear['prognostic_horizon_on_grid_s'] = horizon_on_grid(out / 'a')
    if args.told_law:
        told = json.loads((out / 'told' / 'evaluation.json').read_text())
        told['prognostic_horizon_on_grid_s'] = horizon_on_grid(out / 'told')
        told['trend'] = TOLD_TREND[law]
        scored['gear_phm_told_law'] = told
    (out / 'baseline.json').write_text(json.dumps(scored, indent=2) + '\n')

    def cells(metrics: dict[str, Any]) -> str:
        checks = {check['lam']: check for check in metrics['alpha_lambda']}
        parts = []
        for lam in (0.5, 0.75, 0.9):
            check = checks[lam]
            predicted = check['predicted_rul']
            error = (predicted / check['true_rul'] - 1.0 if isinstance(predicted, float)
                     else math.inf)
            parts.append(f"{'pass' if check['passed'] else 'FAIL'} {error:+.0%}")
        horizon = f"{float(metrics['prognostic_horizon_s']) / (t_eol - t_start):.0%}"
        if 'prognostic_horizon_on_grid_s' in metrics:
            on_grid = float(metrics['prognostic_horizon_on_grid_s'])
            horizon += f' ({on_grid / (t_eol - t_start):.0%})'
        return ' | '.join(parts) + f' | {horizon}'

    row = (f'| {law} | {life:.0f} | {seed} | ' + ' | '.join(cells(m) for m in scored.values())
           + ' |')
    return row, {'seconds': time.perf_counter() - started}


def main() -> int:
    """Run the matrix (or, with --worker, the progpy side of one scenario)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('out', type=Path, nargs='?')
    parser.add_argument('--progpy-python', default='/tmp/progpy_venv/bin/python',
                        help='python of the bench venv with progpy (bench/requirements.txt)')
    parser.add_argument('--lives', type=float, nargs='+', default=[300.0, 3000.0])
    parser.add_argument('--seeds', type=int, nargs='+', default=[1, 2, 3])
    parser.add_argument('--laws', nargs='+', default=['linear', 'exponential', 'power'])
    parser.add_argument('--samples', type=int, default=100,
                        help='MonteCarlo samples per prediction (default 100)')
    parser.add_argument('--q-rate', type=float, default=Q_RATE,
                        help='UKF wear-rate random walk [(1/s)^2/s] (default %(default)g)')
    parser.add_argument('--reuse', action='store_true',
                        help='keep gear_phm runs already in OUT; redo only progpy')
    parser.add_argument('--told-law', action='store_true',
                        help='also run gear_phm told the true wear law (analyze --trend)')
    parser.add_argument('--seed', type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument('--worker', type=Path, nargs=2, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker is not None:
        _worker(args.worker[0], args.worker[1], args.samples, args.seed, args.q_rate)
        return 0
    if args.out is None:
        parser.error('OUT is required')
    if not Path(args.progpy_python).is_file():
        parser.error(f'no bench python at {args.progpy_python}: python3 -m venv /tmp/progpy_venv '
                     '&& /tmp/progpy_venv/bin/pip install -r bench/requirements.txt')
    header = ('| law | life [s] | seed | gear_phm 0.5 | 0.75 | 0.9 | PH | progpy linear 0.5 | '
              '0.75 | 0.9 | PH | progpy exponential 0.5 | 0.75 | 0.9 | PH |\n'
              '|---|---|---|' + '---|' * 12)
    if args.told_law:
        header = header.replace(' |\n|', ' | gear_phm told the law 0.5 | 0.75 | 0.9 | PH |\n|')
        header += '---|' * 4
    print(header, flush=True)
    rows = [header]
    for life in args.lives:
        for law in args.laws:
            for seed in args.seeds:
                row, info = _scenario(args.out / f'{law}_{life:.0f}_{seed}', law, life, seed,
                                      args)
                rows.append(row)
                print(row, f'<!-- {info["seconds"]:.0f} s -->', flush=True)
    (args.out / 'table.md').write_text('\n'.join(rows) + '\n')
    return 0


if __name__ == '__main__':
    sys.exit(main())
