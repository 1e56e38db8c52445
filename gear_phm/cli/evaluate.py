"""``gear-phm evaluate``: score RUL predictions against ground truth (Saxena metrics).

Predictions: ``gear_phm/health/rul`` (x = median RUL [s], stamped with the time of the
estimate) in a rosbag2 directory -- a diagnostics recording or an ``analyze`` output (the
directory itself or a bag directly inside it). Truth: a simulated bag with
``gear_phm/truth/friction`` (EOL = first stamp where true u >= u_eol, u_eol from the health
options) or a CSV with the header ``time,true_eol`` (seconds, finite, true_eol > 0; the last
row's true_eol is used). A truth bag whose stamps do not overlap the run's is refused; a
partial overlap, or a run that ends before the last lambda of the life, is warned about on
stderr and in the JSON (``warnings``). The JSON is written whole or not at all, never over an
input.
Also scored: from which fraction of the life the RUL stays finite, how often its p5-p95 band
(y, z of the RUL topic) holds the true RUL from ``--band-from``, and, when the run has
``gear_phm/health/efficiency`` (z = level), its health-level transitions and whether ERROR came
before the true end of life. Prints the metrics and writes them as JSON (``--output``).

A truth bag written by ``gear-phm simulate --random-life`` has ``life.json`` beside it: its
``ratio`` and ``eta_opposing_min`` are then the defaults of ``--ratio`` and
``--eta-opposing-min``, its wear onset that of ``--t-start`` (t_P = onset), its
``end_of_life_s`` the true end of life (when the options give its u_eol), and the
per-life acceptance scores are added (``acceptance``); a healthy life, which has no end of
life, is scored on whether it stays OK with RUL inf. Definitions: docs/prognostics.md.
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import os
from pathlib import Path
import re
import sys
from typing import Any

import numpy as np

from gear_phm.bagio import BagError, BagReader
from gear_phm.cli.main import CliError
from gear_phm.cli.options import add_health_arguments, health_values
from gear_phm.codec import decode_vector3_stamped_buffer
from gear_phm.interfaces import (drive_topic, field_index, HEALTH_EFFICIENCY, HEALTH_LAYOUT,
                                 HEALTH_RUL, stamp_to_ns, TRUTH_FRICTION, VECTOR3_STAMPED_TYPE)
from gear_phm.parameters import RATIO
from gear_phm.prognostics import end_of_life_u, HealthConfig
from gear_phm.prognostics.metrics import (acceptance, ALPHA, band_coverage, BAND_FROM,
                                          evaluate, finite_from, healthy_acceptance, LAMBDAS,
                                          level_transitions, true_end_of_life_index)
from gear_phm.simulation.lives import LIFE_FILE
from gear_phm.staging import write_atomic
from gear_phm.status import ERROR, LEVEL_NAMES
from gear_phm.transmissions import load_transmissions, TransmissionsError

#: life.json fields that are the defaults of the health options of the same name.
LIFE_HEALTH = ('eta_opposing_min',)
#: life.json fields evaluate reads.
LIFE_FIELDS = ('ratio', 'eta_opposing_min', 'u_eol', 'onset_s', 'end_of_life_s', 'healthy')
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
                        help='accuracy cone half-width, a fraction of the true RUL in (0, 1) '
                             f'(default {ALPHA})')
    parser.add_argument('--lambdas', type=float, nargs='+', default=list(LAMBDAS),
                        help='fractions of life where alpha-lambda is checked (default '
                             f'{" ".join(f"{lam:g}" for lam in LAMBDAS)})')
    parser.add_argument('--band-from', type=float, default=BAND_FROM,
                        help='fraction of the life from which the p5-p95 band coverage is '
                             f'counted (default {BAND_FROM})')
    parser.add_argument('--t-start', type=float, default=None,
                        help=f'prognostics start time t_P [s] (default: the wear onset of the '
                             f"truth's {LIFE_FILE}, else the first prediction)")
    parser.add_argument('--ratio', type=float, default=None,
                        help='gearbox ratio R for u_eol from --eta-opposing-min (default: '
                             f"that of the truth's {LIFE_FILE}, else {RATIO.default})")
    parser.add_argument('--drive', default=None, metavar='NAME',
                        help='one drive of many (gear-phm analyze --transmissions): its '
                             'gear_phm/<drive>/health/... in the run and '
                             'gear_phm/<drive>/truth/friction in the truth bag')
    parser.add_argument('--transmissions', type=Path, default=None, metavar='FILE.yaml',
                        help="score each drive of the file (or --drive's only) against its "
                             "truth, with the drive's ratio and health parameters; each "
                             'writes <run>/evaluation_<drive>.json')
    parser.add_argument('--no-life', dest='life', action='store_false',
                        help=f'ignore a {LIFE_FILE} beside the truth bag')
    add_health_arguments(parser)
    # None: from life.json when the truth has one, else the parameter's default.
    parser.set_defaults(**{f'health_{name}': None for name in LIFE_HEALTH})


def read_life(truth: Path) -> dict[str, Any] | None:
    """Return the random life's record beside a truth bag (in it or beside its file), or None.

    Raises CliError if that file is unreadable or lacks a field evaluate needs.
    """
    path = (truth if truth.is_dir() else truth.parent) / LIFE_FILE
    if not path.is_file():
        return None
    try:
        life: dict[str, Any] = json.loads(path.read_text(encoding='utf-8'))
    except (OSError, ValueError) as exc:
        raise CliError(f'cannot read {path}: {exc}') from None
    missing = [key for key in LIFE_FIELDS if not isinstance(life, dict) or key not in life]
    if missing:
        raise CliError(f'{path} is not a life record of gear-phm simulate --random-life '
                       f'(missing {", ".join(missing)})')
    return life


def _topic(topic: str, drive: str | None) -> str:
    """Return ``topic``, or one drive's own (``gear_phm/<drive>/...``)."""
    return topic if drive is None else drive_topic(drive, topic)


def _find_bag(run: Path, drive: str | None = None) -> Path:
    if not run.exists():
        raise CliError(f'{run} does not exist')
    candidates = [run] + (sorted(p.parent for p in run.glob('*/metadata.yaml'))
                          if run.is_dir() else [])
    for candidate in candidates:
        try:
            with BagReader(candidate) as bag:
                if bag.resolve_topic(_topic(HEALTH_RUL, drive)) in bag.topics:
                    return candidate
        except BagError:
            continue
    raise CliError(f'no bag with topic {_topic(HEALTH_RUL, drive)} in {run}')


def read_vector_topic(path: Path, topic: str) -> tuple[np.ndarray, np.ndarray]:
    """(stamps [s], N x 3 values) of a Vector3Stamped topic, sorted by stamp.

    Decoded in batches (:func:`~gear_phm.codec.decode_vector3_stamped_buffer`); a topic with
    a payload that decoder refuses is read again message by message with rosbags.
    """
    try:
        with BagReader(path) as bag:
            name = bag.require_topic(topic, VECTOR3_STAMPED_TYPE)
            parts = [decode_vector3_stamped_buffer(batch.buffer, batch.offsets, batch.lengths)
                     for batch in bag.raw_batches([name])]
            if all(part is not None for part in parts):
                decoded = [part for part in parts if part is not None]
                stamps = np.concatenate([s for s, _ in decoded]) if decoded else np.zeros(0)
                values = np.concatenate([v for _, v in decoded]) if decoded \
                    else np.zeros((0, 3))
            else:
                rows = [(stamp_to_ns(m.header.stamp), m.vector.x, m.vector.y, m.vector.z)
                        for _, _, m in bag.messages([name])]
                stamps = np.array([r[0] for r in rows], dtype=np.int64)
                values = np.array([r[1:] for r in rows], dtype=float).reshape(-1, 3)
    except BagError as exc:
        raise CliError(str(exc)) from None
    if not stamps.size:
        raise CliError(f'topic {topic} in {path} has no messages')
    order = np.argsort(stamps, kind='stable')
    return stamps[order] * 1e-9, values[order]


def _levels(bag: Path, drive: str | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """(stamps [s], levels) of the run's health states, or None without that topic."""
    with BagReader(bag) as reader:
        if reader.resolve_topic(_topic(HEALTH_EFFICIENCY, drive)) not in reader.topics:
            return None
    times, vectors = read_vector_topic(bag, _topic(HEALTH_EFFICIENCY, drive))
    return times, vectors[:, field_index(HEALTH_LAYOUT, HEALTH_EFFICIENCY, 'level')]


#: Columns of a truth CSV, in its header line.
CSV_COLUMNS = ('time', 'true_eol')


def read_truth_csv(path: Path) -> float:
    """Return the true end of life [s] of a CSV ``time,true_eol`` [s]: its last row's.

    The first line that is not empty nor a ``#`` comment is the header naming both columns;
    every value must be a finite number, time >= 0 and true_eol > 0. Raises CliError naming
    the file, line and column otherwise.
    """
    try:
        with open(path, newline='', encoding='utf-8') as stream:
            lines = [(number, row) for number, row in enumerate(csv.reader(stream), 1)
                     if row and ''.join(row).strip() and not row[0].lstrip().startswith('#')]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        reason = exc.strerror if isinstance(exc, OSError) else exc
        raise CliError(f'cannot read {path}: {reason}') from None
    if not lines:
        raise CliError(f'{path} holds no header {",".join(CSV_COLUMNS)} and no row')
    number, header = lines[0]
    names = [name.strip() for name in header]
    missing = [name for name in CSV_COLUMNS if name not in names]
    if missing:
        raise CliError(f'{path} line {number}: the header must name the columns '
                       f'{",".join(CSV_COLUMNS)}, got {",".join(header)!r} (missing '
                       f'{", ".join(missing)})')
    columns = [names.index(name) for name in CSV_COLUMNS]
    eol = math.nan
    for number, row in lines[1:]:
        values = []
        for name, column in zip(CSV_COLUMNS, columns):
            text = row[column].strip() if column < len(row) else ''
            try:
                value = float(text)
            except ValueError:
                value = math.nan
            low, bound = (0.0, '>= 0') if name == 'time' else (math.ulp(0.0), '> 0')
            if not (math.isfinite(value) and value >= low):
                raise CliError(f'{path} line {number} column {name}: expected a finite number '
                               f'{bound} [s], got {text!r}')
            values.append(value)
        eol = values[1]
    if math.isnan(eol):
        raise CliError(f'{path} holds a header but no {",".join(CSV_COLUMNS)} row')
    return eol


def truth_eol(truth: Path, u_eol: float, drive: str | None = None) -> float:
    """Return the true end of life [s], from a truth bag or a CSV (module docstring)."""
    return truth_eol_and_span(truth, u_eol, drive)[0]


def truth_eol_and_span(truth: Path, u_eol: float, drive: str | None = None
                       ) -> tuple[float, tuple[float, float] | None]:
    """Return :func:`truth_eol` and the truth's stamp range [s] (None for a CSV)."""
    if truth.suffix.lower() == '.csv':
        return read_truth_csv(truth), None
    times, vectors = read_vector_topic(truth, _topic(TRUTH_FRICTION, drive))
    index = true_end_of_life_index(vectors[:, 0], u_eol)
    if index is None:
        raise CliError(f'true u in {truth} never reaches u_eol = {u_eol:.4g} (max '
                       f'{vectors[:, 0].max():.4g}): no end of life to score against')
    return float(times[index]), (float(times[0]), float(times[-1]))


def _bag_span(path: Path) -> tuple[float, float] | None:
    """Return the first and last log time [s] of the bag ``path``, or None if unreadable."""
    try:
        with BagReader(path) as bag:
            return bag.start_ns * 1e-9, bag.end_ns * 1e-9
    except BagError:
        return None


def _config(args: argparse.Namespace, life: dict[str, Any] | None) -> HealthConfig:
    """Health options, unset ones from ``life`` (else their defaults); CliError if invalid."""
    values = health_values(args)
    for name in LIFE_HEALTH:
        if values[name] is None:
            values.pop(name)
            if life is not None:
                values[name] = float(life[name])
    ratio = args.ratio if args.ratio is not None else (
        float(life['ratio']) if life is not None else RATIO.default)
    try:
        return HealthConfig(ratio=float(ratio), **values)
    except (TypeError, ValueError) as exc:
        raise CliError(str(exc)) from None


def run(args: argparse.Namespace) -> int:
    if args.transmissions is None:
        return _run_one(args)
    try:
        drives = load_transmissions(args.transmissions)
    except TransmissionsError as exc:
        raise CliError(str(exc)) from None
    chosen = [d for d in drives if args.drive in (None, d.name)]
    if not chosen:
        raise CliError(f'--drive {args.drive} is not in {args.transmissions} '
                       f'({", ".join(d.name for d in drives)})')
    if len(chosen) > 1 and args.output is not None:
        raise CliError('--output names one file: give --drive, or leave --output out '
                       '(each drive writes <run>/evaluation_<drive>.json)')
    given = health_values(args)
    failed: list[str] = []
    for drive in chosen:
        one = argparse.Namespace(**vars(args))
        one.drive = drive.name
        one.ratio = drive.ratio if args.ratio is None else args.ratio
        for name, value in drive.health.items():
            if name in given:
                setattr(one, f'health_{name}', value)
        print(f'drive {drive.name}:')
        try:
            _run_one(one)
        except CliError as exc:             # the other drives are still scored
            failed.append(f'{drive.name}: {exc}')
    if failed:
        raise CliError(f'{len(failed)} of {len(chosen)} drives not scored: '
                       + '; '.join(failed))
    return 0


def _check_options(args: argparse.Namespace) -> None:
    """Raise CliError for an --alpha, --lambdas or --band-from outside its range."""
    if not 0.0 < args.alpha < 1.0:
        raise CliError(f'--alpha must be a fraction of the true RUL in (0, 1), got '
                       f'{args.alpha!r}')
    for option, values in (('--lambdas', args.lambdas), ('--band-from', [args.band_from])):
        for value in values:
            if not 0.0 <= value < 1.0:
                raise CliError(f'{option} must be in [0, 1) (a fraction of the life), got '
                               f'{value!r}')
    if args.t_start is not None and not math.isfinite(args.t_start):
        raise CliError(f'--t-start must be finite, got {args.t_start!r}')


def _overlap(run: tuple[float, float], truth: tuple[float, float] | None,
             path: Path) -> list[str]:
    """Check that the run's stamps [s] overlap the truth's; return warnings if only partly.

    Raises CliError when they do not overlap at all.
    """
    if truth is None:
        return []
    spans = (f"the run's predictions are stamped {run[0]:.6g}-{run[1]:.6g} s, the truth "
             f'{path} {truth[0]:.6g}-{truth[1]:.6g} s')
    if run[1] < truth[0] or run[0] > truth[1]:
        raise CliError(f'{spans}: they do not overlap (not the same time base?)')
    slack = 0.01 * (truth[1] - truth[0])      # a thinned truth topic ends a little early
    if run[0] < truth[0] - slack or run[1] > truth[1] + slack:
        return [f'{spans}: they overlap only partly']
    return []


def _warn(warnings: list[str]) -> None:
    for text in warnings:
        print(f'gear-phm evaluate: warning: {text}', file=sys.stderr)


def _run_one(args: argparse.Namespace) -> int:
    """Score one run (one transmission, or ``args.drive`` of many)."""
    _check_options(args)
    life = read_life(args.truth) if args.life else None
    config = _config(args, life)
    u_eol, _ = end_of_life_u(config.ratio, config.eta_opposing_min, config.self_locking_eol,
                             config.u_max)
    bag = _find_bag(args.run, args.drive)
    output = _output(args, bag)
    times, values = read_vector_topic(bag, _topic(HEALTH_RUL, args.drive))
    median, p5, p95 = (values[:, field_index(HEALTH_LAYOUT, HEALTH_RUL, f'rul.{name}')]
                       for name in ('median', 'p5', 'p95'))
    run_span = (float(times[0]), float(times[-1]))
    same_eol = life is not None and math.isclose(u_eol, float(life['u_eol']), rel_tol=1e-9)
    if same_eol and life is not None and (life['healthy'] or life['end_of_life_s'] is not None):
        truth_span = _bag_span(args.truth)
        warnings = _overlap(run_span, truth_span, args.truth)
        if life['healthy']:
            return _healthy(args, bag, output, median, u_eol, warnings)
        t_eol = float(life['end_of_life_s'])
    else:
        t_eol, truth_span = truth_eol_and_span(args.truth, u_eol, args.drive)
        warnings = _overlap(run_span, truth_span, args.truth)
    if args.t_start is None and life is not None and life['onset_s'] is not None:
        args.t_start = float(life['onset_s'])
    before = times < t_eol
    if not before.any():
        raise CliError(f'no prediction before the true end of life at {t_eol:.6g} s')
    levels = _levels(bag, args.drive)
    try:
        metrics = evaluate(times[before], median[before], t_eol, args.alpha, args.lambdas,
                           args.t_start)
        start = float(metrics['t_start_s'])
        share, counted = band_coverage(times, p5, p95, t_eol, args.band_from, start)
        changes = () if levels is None else level_transitions(*levels, t_eol, start)
        finite = finite_from(times[before], median[before], t_eol, start)
        scores = None if life is None else acceptance(times, median, p5, p95, t_eol, start,
                                                      levels, args.alpha)
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
    if scores is not None:
        metrics['acceptance'] = scores
    last = max(c['lam'] for c in metrics['alpha_lambda'])
    if times[-1] < start + last * (t_eol - start):
        warnings.append(f"the run's last prediction at {times[-1]:.6g} s comes before lambda "
                        f'{last:g} of the life ({start:.6g}-{t_eol:.6g} s): later checks '
                        'score that prediction')
    _warn(warnings)
    if warnings:
        metrics['warnings'] = warnings
    _write(args, bag, output, metrics, u_eol)
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
    if scores is not None:
        _print_acceptance(scores)
    print(f'metrics written to {output}')
    return 0


def _output(args: argparse.Namespace, bag: Path) -> Path:
    """Return the JSON file to write; CliError if it is an input or cannot be a file.

    Refused: a directory, an input file (the run, the truth, life.json, a file of their
    bags), a file in the truth's directory, an existing file other than ``evaluation*.json``
    in the run's.
    """
    name = 'evaluation' if args.drive is None else f'evaluation_{args.drive}'
    output: Path = args.output or (bag / f'{name}.json' if bag.is_dir()
                                   else bag.with_suffix(f'.{name}.json'))
    if output.is_dir():
        raise CliError(f'--output {output} is a directory; give a file name')
    if not output.parent.is_dir():
        raise CliError(f'cannot write {output}: directory {output.parent} does not exist')
    if not os.access(output.parent, os.W_OK | os.X_OK):
        raise CliError(f'cannot write {output}: directory {output.parent} is not writable')

    def directory(path: Path) -> Path | None:
        if path.is_dir():
            return path
        return path.parent if (path.parent / 'metadata.yaml').is_file() else None

    runs = {d for d in (directory(args.run), directory(bag)) if d is not None}
    truths = {d for d in (directory(args.truth),) if d is not None} - runs
    inputs = [p for p in (args.run, bag, args.truth,
                          (args.truth if args.truth.is_dir() else args.truth.parent) / LIFE_FILE)
              if p.is_file()]
    inputs += [p for d in runs | truths for p in d.iterdir() if p.is_file()
               and (d in truths or not re.fullmatch(r'evaluation.*\.json', p.name))]
    real = os.path.realpath(output)
    inside = [d for d in truths if os.path.commonpath([real, os.path.realpath(d)])
              == os.path.realpath(d)]
    if output.exists():
        inside += [p for p in inputs if _same(output, p)]
    if inside:
        raise CliError(f'--output {output} would overwrite or write into the input '
                       f'{inside[0]}; give a file outside the inputs')
    return output


def _same(path: Path, other: Path) -> bool:
    try:
        return os.path.samefile(path, other)
    except OSError:
        return False


def _write(args: argparse.Namespace, bag: Path, output: Path, metrics: dict[str, Any],
           u_eol: float) -> None:
    """Add u_eol and the paths to ``metrics``, write it as JSON to ``output`` atomically."""
    metrics['u_eol'] = u_eol
    metrics['run'] = str(bag)
    if args.drive is not None:
        metrics['drive'] = args.drive
    metrics['truth'] = str(args.truth)
    try:
        write_atomic(output, json.dumps(metrics, indent=2) + '\n')
    except OSError as exc:
        raise CliError(f'cannot write {output}: {exc.strerror or exc}') from None


def _healthy(args: argparse.Namespace, bag: Path, output: Path, median: np.ndarray,
             u_eol: float, warnings: list[str]) -> int:
    """Score a healthy random life: RUL inf and level OK throughout."""
    levels = _levels(bag, args.drive)
    score = healthy_acceptance(median, None if levels is None else levels[1])
    metrics: dict[str, Any] = {'healthy': True, 'predictions': score['predictions'],
                               'acceptance': {'healthy': score}}
    _warn(warnings)
    if warnings:
        metrics['warnings'] = warnings
    _write(args, bag, output, metrics, u_eol)
    print(f'healthy life (u_eol {u_eol:.4g}): {score["finite"]} of {score["predictions"]} '
          f'RUL predictions finite, levels {", ".join(score["levels_seen"]) or "none"}: '
          f'{"PASS" if score["passed"] else "FAIL"}')
    print(f'metrics written to {output}')
    return 0


def _print_acceptance(scores: dict[str, Any]) -> None:
    """Print the per-life acceptance scores (docs/prognostics.md)."""
    checks = ', '.join(f'{c["lam"]:g} {"PASS" if c["passed"] else "FAIL"}'
                       for c in scores['alpha_lambda'])
    band, below, finite = scores['band'], scores['not_optimistic'], scores['finite']
    print(f'  life from t_P {scores["t_start_s"]:.6g} s: alpha-lambda {checks}; band holds '
          f'{band["held"]} of {band["predictions"]} from lambda {band["from_lambda"]:g}; '
          f'p5 <= true RUL at {below["held"]} of {below["predictions"]} from lambda '
          f'{below["from_lambda"]:g}; RUL finite from lambda {finite["finite_from"]} '
          f'({"PASS" if finite["passed"] else "FAIL"} by {finite["by_lambda"]:g})')
    if 'levels' in scores:
        levels = scores['levels']
        print(f'  levels {" ".join(levels["sequence"]) or "no change"}: '
              f'{"PASS" if levels["passed"] else "FAIL"} (WARN before onset: '
              f'{"YES" if levels["warn_before_onset"] else "no"})')
