"""``gear-phm evaluate``: score RUL predictions against ground truth (Saxena metrics).

Predictions: ``gear_phm/health/rul`` (x = median RUL [s], stamped with the time of the
estimate) in a rosbag2 directory -- a diagnostics recording or an ``analyze`` output (the
directory itself or a bag directly inside it). Truth: a simulated bag with
``gear_phm/truth/friction`` (EOL = first stamp where true u >= u_eol, u_eol from the health
options) or a CSV ``time,true_eol`` (seconds; the last row's true_eol is used).
Also scored: from which fraction of the life the RUL stays finite, how often its p5-p95 band
(y, z of the RUL topic) holds the true RUL from ``--band-from``, and, when the run has
``gear_phm/health/efficiency`` (z = level), its health-level transitions and whether ERROR came
before the true end of life. Prints the metrics and writes them as JSON (``--output``).
Definitions: docs/prognostics.md.
"""
from __future__ import annotations

import argparse
import csv
import json
import math
from pathlib import Path

import numpy as np

from gear_phm.bagio import BagError, BagReader
from gear_phm.cli.main import CliError
from gear_phm.cli.options import add_health_arguments, health_values
from gear_phm.interfaces import (field_index, HEALTH_EFFICIENCY, HEALTH_LAYOUT, HEALTH_RUL,
                                 stamp_to_ns, TRUTH_FRICTION, VECTOR3_STAMPED_TYPE)
from gear_phm.parameters import RATIO
from gear_phm.prognostics import end_of_life_u, HealthConfig
from gear_phm.prognostics.metrics import (ALPHA, band_coverage, BAND_FROM, evaluate,
                                          finite_from, LAMBDAS, level_transitions,
                                          true_end_of_life_index)
from gear_phm.status import ERROR, LEVEL_NAMES

HELP = 'score RUL predictions against ground truth (alpha-lambda, horizon, accuracy)'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('run', type=Path,
                        help='bag directory with gear_phm/health/rul (diagnostics recording or '
                             'analyze output directory)')
    parser.add_argument('--truth', type=Path, required=True,
                        help='simulated bag with gear_phm/truth/friction, or CSV time,true_eol')
    parser.add_argument('--output', type=Path, default=None,
                        help='JSON file for the metrics (default: <run>/evaluation.json)')
    parser.add_argument('--alpha', type=float, default=ALPHA,
                        help=f'accuracy cone half-width (default {ALPHA})')
    parser.add_argument('--lambdas', type=float, nargs='+', default=list(LAMBDAS),
                        help='fractions of life where alpha-lambda is checked (default '
                             f'{" ".join(f"{lam:g}" for lam in LAMBDAS)})')
    parser.add_argument('--band-from', type=float, default=BAND_FROM,
                        help='fraction of the life from which the p5-p95 band coverage is '
                             f'counted (default {BAND_FROM})')
    parser.add_argument('--t-start', type=float, default=None,
                        help='prognostics start time [s] (default: first prediction)')
    parser.add_argument('--ratio', type=float, default=RATIO.default,
                        help='gearbox ratio R for u_eol from --eta-opposing-min (default '
                             f'{RATIO.default})')
    add_health_arguments(parser)


def _find_bag(run: Path) -> Path:
    if not run.exists():
        raise CliError(f'{run} does not exist')
    candidates = [run] + (sorted(p.parent for p in run.glob('*/metadata.yaml'))
                          if run.is_dir() else [])
    for candidate in candidates:
        try:
            with BagReader(candidate) as bag:
                if bag.resolve_topic(HEALTH_RUL) in bag.topics:
                    return candidate
        except BagError:
            continue
    raise CliError(f'no bag with topic {HEALTH_RUL} in {run}')


def read_vector_topic(path: Path, topic: str) -> tuple[np.ndarray, np.ndarray]:
    """(stamps [s], N x 3 values) of a Vector3Stamped topic, sorted by stamp."""
    try:
        with BagReader(path) as bag:
            name = bag.require_topic(topic, VECTOR3_STAMPED_TYPE)
            rows = [(stamp_to_ns(m.header.stamp) * 1e-9, m.vector.x, m.vector.y, m.vector.z)
                    for _, _, m in bag.messages([name])]
    except BagError as exc:
        raise CliError(str(exc)) from None
    if not rows:
        raise CliError(f'topic {topic} in {path} has no messages')
    data = np.array(sorted(rows, key=lambda r: r[0]))
    return data[:, 0], data[:, 1:]


def _levels(bag: Path) -> tuple[np.ndarray, np.ndarray] | None:
    """(stamps [s], levels) of the run's health states, or None without that topic."""
    with BagReader(bag) as reader:
        if reader.resolve_topic(HEALTH_EFFICIENCY) not in reader.topics:
            return None
    times, vectors = read_vector_topic(bag, HEALTH_EFFICIENCY)
    return times, vectors[:, field_index(HEALTH_LAYOUT, HEALTH_EFFICIENCY, 'level')]


def truth_eol(truth: Path, u_eol: float) -> float:
    """Return the true end-of-life time [s] from a truth bag or a CSV (see module docstring)."""
    if truth.suffix.lower() == '.csv':
        try:
            with open(truth, newline='', encoding='utf-8') as stream:
                rows = [r for r in csv.reader(stream) if r and not r[0].startswith('#')]
        except OSError as exc:
            raise CliError(f'cannot read {truth}: {exc.strerror}') from None
        values = []
        for number, row in enumerate(rows, 1):
            try:
                values.append((float(row[0]), float(row[1])))
            except (ValueError, IndexError):
                if number == 1:
                    continue                      # header line
                raise CliError(f'{truth} line {number}: expected time,true_eol numbers, got '
                               f'{",".join(row)!r}') from None
        if not values or not math.isfinite(values[-1][1]):
            raise CliError(f'{truth} holds no finite time,true_eol row')
        return values[-1][1]
    times, vectors = read_vector_topic(truth, TRUTH_FRICTION)
    index = true_end_of_life_index(vectors[:, 0], u_eol)
    if index is None:
        raise CliError(f'true u in {truth} never reaches u_eol = {u_eol:.4g} (max '
                       f'{vectors[:, 0].max():.4g}): no end of life to score against')
    return float(times[index])


def run(args: argparse.Namespace) -> int:
    try:
        config = HealthConfig(ratio=float(args.ratio), **health_values(args))
    except ValueError as exc:
        raise CliError(str(exc)) from None
    u_eol, _ = end_of_life_u(config.ratio, config.eta_opposing_min, config.self_locking_eol,
                             config.u_max)
    bag = _find_bag(args.run)
    times, values = read_vector_topic(bag, HEALTH_RUL)
    median, p5, p95 = (values[:, field_index(HEALTH_LAYOUT, HEALTH_RUL, f'rul.{name}')]
                       for name in ('median', 'p5', 'p95'))
    t_eol = truth_eol(args.truth, u_eol)
    before = times < t_eol
    if not before.any():
        raise CliError(f'no prediction before the true end of life at {t_eol:.6g} s')
    levels = _levels(bag)
    try:
        metrics = evaluate(times[before], median[before], t_eol, args.alpha, args.lambdas,
                           args.t_start)
        start = float(metrics['t_start_s'])
        share, counted = band_coverage(times, p5, p95, t_eol, args.band_from, start)
        changes = () if levels is None else level_transitions(*levels, t_eol, start)
        finite = finite_from(times[before], median[before], t_eol, start)
    except ValueError as exc:
        raise CliError(str(exc)) from None
    metrics['rul_finite_from'] = 'inf' if math.isinf(finite) else finite
    metrics['band_coverage'] = {'from_lambda': args.band_from,
                                'share': 'nan' if math.isnan(share) else share,
                                'predictions': counted}
    if levels is not None:
        metrics['level_transitions'] = [
            {'t': c.t, 'lam': c.lam, 'from': LEVEL_NAMES.get(c.before, str(c.before)),
             'to': LEVEL_NAMES.get(c.after, str(c.after))} for c in changes]
        metrics['error_before_eol'] = bool(np.any((levels[1] == ERROR) & (levels[0] < t_eol)))
    metrics['u_eol'] = u_eol
    metrics['run'] = str(bag)
    metrics['truth'] = str(args.truth)
    output = args.output or (bag / 'evaluation.json' if bag.is_dir()
                             else bag.with_suffix('.evaluation.json'))
    output.write_text(json.dumps(metrics, indent=2) + '\n', encoding='utf-8')
    print(f'true end of life {t_eol:.6g} s (u_eol {u_eol:.4g}), {metrics["predictions"]} '
          f'predictions from {metrics["t_start_s"]:.6g} s')
    for check in metrics['alpha_lambda']:
        verdict = 'PASS' if check['passed'] else 'FAIL'
        print(f'  alpha-lambda alpha={args.alpha:g} lambda={check["lam"]:g}: {verdict} '
              f'(t={check["t_lambda"]:.6g} s, RUL {check["predicted_rul"]} vs true '
              f'{check["true_rul"]:.6g} s, RA {check["relative_accuracy"]})')
    print(f'  prognostic horizon: {metrics["prognostic_horizon_s"]} s')
    print(f'  cumulative relative accuracy: {metrics["cumulative_relative_accuracy"]}')
    print(f'  RUL finite from lambda {metrics["rul_finite_from"]}')
    print(f'  p5-p95 band holds the true RUL at {metrics["band_coverage"]["share"]} of '
          f'{counted} predictions from lambda {args.band_from:g}')
    if levels is not None:
        steps = ', '.join(f'{c["from"]}>{c["to"]} at {c["t"]:.6g} s (lambda {c["lam"]:.3f})'
                          for c in metrics['level_transitions'])
        print(f'  health levels: {steps or "no change"}; ERROR before the true end of life: '
              f'{"YES" if metrics["error_before_eol"] else "no"}')
    print(f'metrics written to {output}')
    return 0
