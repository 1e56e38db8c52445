"""``gear-phm evaluate``: score RUL predictions against ground truth (Saxena metrics).

The command line of :func:`gear_phm.offline.evaluation.evaluate_run`, which holds what is
read and scored. The run: a rosbag2 directory with ``gear_phm/health/rul`` (a diagnostics
recording or an ``analyze`` output); the truth: a simulated bag with
``gear_phm/truth/friction`` or a CSV ``time,true_eol`` (:mod:`gear_phm.offline.truth`). u_eol
comes from the health options. Warnings go to stderr and into the JSON (``warnings``). Prints
the metrics and writes them as JSON (``--output``), whole or not at all, never over an input.

A truth bag written by ``gear-phm simulate --random-life`` has ``life.json`` beside it: its
``ratio`` and ``eta_opposing_min`` are then the defaults of ``--ratio`` and
``--eta-opposing-min``, its wear onset that of ``--t-start`` (t_P = onset), its
``end_of_life_s`` the true end of life (when the options give its u_eol), and the
per-life acceptance scores are added (``acceptance``); a healthy life, which has no end of
life, is scored on whether it stays OK with RUL inf. Definitions: docs/prognostics.md.
"""
from __future__ import annotations

import argparse
import json
import math
import os
from pathlib import Path
import re
import sys
from typing import Any

from gear_phm.bagio import BagError
from gear_phm.cli.main import CliError
from gear_phm.cli.options import add_health_arguments, health_values
from gear_phm.offline.evaluation import evaluate_run, EvaluationError, find_bag, health_config
from gear_phm.offline.truth import LIFE_HEALTH, read_life, TruthError
from gear_phm.parameters import RATIO
from gear_phm.prognostics.metrics import ALPHA, BAND_FROM, LAMBDAS
from gear_phm.run import DriveNames
from gear_phm.simulation.lives import LIFE_FILE
from gear_phm.staging import write_atomic
from gear_phm.transmissions import load_transmissions, TransmissionsError

HELP = 'score RUL predictions against ground truth (alpha-lambda, horizon, accuracy)'
#: What the library raises for a run that cannot be scored (each is one line for the user).
_REFUSALS = (BagError, EvaluationError, TruthError)


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


def _warn(warnings: list[str]) -> None:
    for text in warnings:
        print(f'gear-phm evaluate: warning: {text}', file=sys.stderr)


def _run_one(args: argparse.Namespace) -> int:
    """Score one run (one transmission, or ``args.drive`` of many)."""
    _check_options(args)
    try:
        life = read_life(args.truth) if args.life else None
        config = health_config(health_values(args), args.ratio, life)
        bag = find_bag(args.run, args.drive)
        output = _output(args, bag)
        result = evaluate_run(bag, args.truth, config, life=life, drive=args.drive,
                              alpha=args.alpha, lambdas=args.lambdas,
                              band_from=args.band_from, t_start=args.t_start)
    except _REFUSALS as exc:
        raise CliError(str(exc)) from None
    metrics, warnings = result.metrics, list(result.warnings)
    _warn(warnings)
    if warnings:
        metrics['warnings'] = warnings
    _write(args, bag, output, metrics, result.u_eol)
    if metrics.get('healthy'):
        _print_healthy(metrics['acceptance']['healthy'], result.u_eol)
    else:
        _print_metrics(args, metrics, result.t_eol, result.u_eol)
    print(f'metrics written to {output}')
    return 0


#: Why a printed metric is not finite (the JSON keeps 'inf', '-inf' or 'nan').
_WHY_NOT_FINITE = {
    'rul': {'inf': 'no end of life in sight then'},
    'ra': {'-inf': 'the predicted RUL was infinite', 'nan': 'no prediction'},
    'cra': {'-inf': 'a prediction of infinite RUL scores RA -inf',
            'nan': 'no prediction before the end of life'},
    'finite': {'inf': 'the last prediction before the end of life is infinite',
               'nan': 'no prediction before the end of life'},
    'share': {'nan': 'no prediction in the band window'},
}


def _number(value: Any, kind: str, digits: int = 4) -> str:
    """Return ``value`` to ``digits`` significant digits, or why it is not finite."""
    if isinstance(value, (int, float)) and not isinstance(value, bool) \
            and math.isfinite(value):
        return f'{value:.{digits}g}'
    text = str(value)
    why = _WHY_NOT_FINITE.get(kind, {}).get(text)
    return f'{text} ({why})' if why else text


def _print_metrics(args: argparse.Namespace, metrics: dict[str, Any], t_eol: float,
                   u_eol: float) -> None:
    """Print the scores of a life with an end of life, rounded; say why one is infinite."""
    print(f'true end of life {t_eol:.6g} s (u_eol {u_eol:.4g}), {metrics["predictions"]} '
          f'predictions from {metrics["t_start_s"]:.6g} s')
    for check in metrics['alpha_lambda']:
        verdict = 'PASS' if check['passed'] else 'FAIL'
        print(f'  alpha-lambda alpha={args.alpha:g} lambda={check["lam"]:g}: {verdict} '
              f'(t={check["t_lambda"]:.6g} s, RUL {_number(check["predicted_rul"], "rul")} s '
              f'vs true {check["true_rul"]:.6g} s, RA '
              f'{_number(check["relative_accuracy"], "ra", 3)})')
    print(f'  prognostic horizon: {_number(metrics["prognostic_horizon_s"], "ph")} s')
    print(f'  cumulative relative accuracy: '
          f'{_number(metrics["cumulative_relative_accuracy"], "cra", 3)}')
    print(f'  RUL finite from lambda {_number(metrics["rul_finite_from"], "finite", 3)}')
    band = metrics['band_coverage']
    share = band['share']
    share = _number(share * 100.0, 'share', 3) + ' %' if isinstance(share, float) \
        and math.isfinite(share) else _number(share, 'share')
    print(f'  p5-p95 band holds the true RUL at {share} of {band["predictions"]} predictions '
          f'from lambda {args.band_from:g}')
    if 'level_transitions' in metrics:
        steps = ', '.join(f'{c["from"]}>{c["to"]} at {c["t"]:.6g} s (lambda {c["lam"]:.3f})'
                          for c in metrics['level_transitions'])
        print(f'  health levels: {steps or "no change"}; ERROR before the true end of life: '
              f'{"YES" if metrics["error_before_eol"] else "no"}')
    if 'acceptance' in metrics:
        _print_acceptance(metrics['acceptance'])


def _output(args: argparse.Namespace, bag: Path) -> Path:
    """Return the JSON file to write; CliError if it is an input or cannot be a file.

    Refused: a directory, an input file (the run, the truth, life.json, a file of their
    bags), a file in the truth's directory, an existing file other than ``evaluation*.json``
    in the run's.
    """
    name = f'evaluation{DriveNames.chosen(args.drive).file_suffix}'
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
    names = DriveNames.chosen(args.drive)
    if names.listed:
        metrics['drive'] = names.drive
    metrics['truth'] = str(args.truth)
    try:
        write_atomic(output, json.dumps(metrics, indent=2) + '\n')
    except OSError as exc:
        raise CliError(f'cannot write {output}: {exc.strerror or exc}') from None


def _print_healthy(score: dict[str, Any], u_eol: float) -> None:
    """Print the score of a healthy random life: RUL inf and level OK throughout."""
    print(f'healthy life (u_eol {u_eol:.4g}): {score["finite"]} of {score["predictions"]} '
          f'RUL predictions finite, levels {", ".join(score["levels_seen"]) or "none"}: '
          f'{"PASS" if score["passed"] else "FAIL"}')


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
