"""Random-life ensemble: simulate -> analyze -> evaluate on seeds 1..N (issue 23, prognostics.md).

For each seed, `gear-phm simulate --random-life SEED` (at 100 Hz, and with --rates 100 1000
also at 1 kHz for lives up to 3 000 s) writes a bag and its life.json; `gear-phm analyze` runs
with only `--ratio` and `--eta-opposing-min` from life.json (under `nice -n 19`), and
`gear-phm evaluate RUN --truth BAG` scores it from the wear onset with the life's own
eta_opposing_min (it reads life.json itself). The acceptance measures of issue 23 are then
aggregated over all lives, per family and per feature, with pass/fail against its thresholds:
printed as markdown and written to OUT/table.md and OUT/ensemble.json.

Usage: .venv/bin/python bench/ensemble.py OUT [--seeds 60] [--first 1] [--rates 100 [1000]]
       [--prior paper|bench] [--workers 1] [--reuse] [--progpy] [--progpy-python PY]

--prior bench draws the lives from the prior with every real-gearbox effect on (no-load drag
and oil warming, varying loads, sensor errors, encoders, cold restarts; docs/lives.md); the
1 kHz limit then applies to a life's operating length (its idle gap left out).

OUT/<rate>hz/life_<seed>/bag holds the bag and life.json, .../a the analysis and its
evaluation.json. --reuse keeps lives already simulated, analysed and scored (a `done` marker
in each step's directory, an evaluation.json with the acceptance scores; delete those to
rescore), so an interrupted run resumes. --progpy runs bench/progpy_baseline.py's
UKF + MonteCarlo (linear and exponential wear models, its own venv) on the same analyses'
pseudo-measurements and scores both models with the same measures (no health levels).
"""
from __future__ import annotations

import argparse
from collections.abc import Iterable
import json
import math
from multiprocessing import Pool
import os
from pathlib import Path
import shutil
import subprocess
import sys
import time
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
GEAR_PHM = [sys.executable, '-m', 'gear_phm.cli.main']
#: Niceness of the analysis processes (``--nice``; children read it from the environment).
NICE_ENV = 'GEAR_PHM_BENCH_NICE'


def _nice() -> list[str]:
    return ['nice', '-n', os.environ.get(NICE_ENV, '19')]


#: 1 kHz lives are run only up to this record length [s] (issue 23).
FAST_RATE_MAX_DURATION = 3000.0
#: Issue 23's acceptance thresholds.
ALPHA_LAMBDA_SHARE = 0.9
BAND_RANGE = (0.8, 0.98)
BAND_PER_LIFE_MIN = 0.5
NOT_OPTIMISTIC_SHARE = 0.95
FINITE_SHARE = 0.9


def _environment() -> dict[str, str]:
    env = dict(os.environ)
    env['PYTHONPATH'] = os.pathsep.join(
        [str(ROOT)] + [p for p in env.get('PYTHONPATH', '').split(os.pathsep) if p])
    return env


def _step(directory: Path, command: list[str], reuse: bool) -> None:
    """Run ``command`` for ``directory`` unless --reuse finds its ``done`` marker."""
    if reuse and (directory / 'done').is_file():
        return
    shutil.rmtree(directory, ignore_errors=True)
    result = subprocess.run(command, capture_output=True, text=True, env=_environment())
    if result.returncode != 0:
        raise RuntimeError(f'{" ".join(command)} failed:\n{result.stderr[-2000:]}')
    (directory / 'done').write_text(result.stdout, encoding='utf-8')


def run_life(task: tuple[Path, int, float, bool, bool, str, str, tuple[str, ...]]
             ) -> dict[str, Any]:
    """Simulate, analyse and evaluate one life; return its life.json and evaluation.json."""
    out, seed, rate, reuse, prepare_only, prior, name, extra = task
    started = time.perf_counter()
    bag, analysis = out / 'bag', out / name
    _step(bag, [*_nice(), *GEAR_PHM, 'simulate', '--random-life', str(seed), '--rate', repr(rate),
                '--prior', prior, '--out', str(bag),
                '--truth-every', str(max(1, round(rate / 10.0)))], reuse)
    life = json.loads((bag / 'life.json').read_text())
    health = ['--ratio', repr(life['ratio']), '--eta-opposing-min',
              repr(life['eta_opposing_min'])]
    try:
        _step(analysis, [*_nice(), *GEAR_PHM, 'analyze', str(bag), *health, *extra, '--out',
                         str(analysis), '--no-plot', '--no-progress'], reuse)
    except RuntimeError as exc:         # a life the analysis refuses counts as failed
        return {'life': life, 'failed': str(exc).splitlines()[-1], 'directory': str(out),
                'seconds': time.perf_counter() - started}
    if prepare_only:
        return {'life': life, 'seconds': time.perf_counter() - started}
    evaluation = analysis / 'evaluation.json'
    if reuse and evaluation.is_file() and 'acceptance' in json.loads(evaluation.read_text()):
        return {'life': life, 'evaluation': json.loads(evaluation.read_text()),
                'directory': str(out), 'seconds': time.perf_counter() - started}
    result = subprocess.run([*_nice(), *GEAR_PHM, 'evaluate', str(analysis), '--truth', str(bag)],
                            capture_output=True, text=True, env=_environment())
    if result.returncode != 0:
        raise RuntimeError(f'evaluate {analysis} failed:\n{result.stderr[-2000:]}')
    return {'life': life, 'evaluation': json.loads(evaluation.read_text()),
            'directory': str(out), 'seconds': time.perf_counter() - started}


def _share(passed: int, total: int) -> float:
    return passed / total if total else math.nan


def aggregate(results: Iterable[dict[str, Any]]) -> dict[str, Any]:
    """Return the issue's acceptance measures over ``results`` (lives and their scores)."""
    pairs = pairs_passed = 0
    held = band_total = below = optimism_total = finite = levels = 0
    wear = healthy = healthy_ok = with_levels = 0
    band_min = math.inf
    band_lives: list[float] = []
    for result in results:
        score = result['evaluation']['acceptance']
        if result['life']['healthy']:
            healthy += 1
            healthy_ok += bool(score['healthy']['passed'])
            continue
        wear += 1
        for check in score['alpha_lambda']:
            pairs += 1
            pairs_passed += bool(check['passed'])
        band = score['band']
        held += band['held']
        band_total += band['predictions']
        band_lives.append(band['held'] / band['predictions'] if band['predictions'] else 0.0)
        band_min = min(band_min, band_lives[-1])
        optimism = score['not_optimistic']
        below += optimism['held']
        optimism_total += optimism['predictions']
        finite += bool(score['finite']['passed'])
        if 'levels' in score:
            with_levels += 1
            levels += bool(score['levels']['passed'])
    return {'wear_lives': wear, 'healthy_lives': healthy,
            'alpha_lambda': _share(pairs_passed, pairs), 'alpha_lambda_pairs': pairs,
            'band': _share(held, band_total), 'band_min_life': band_min if wear else math.nan,
            'band_mean_life': sum(band_lives) / wear if wear else math.nan,
            'not_optimistic': _share(below, optimism_total),
            'finite': _share(finite, wear), 'levels': _share(levels, with_levels),
            'healthy': _share(healthy_ok, healthy)}


def groups(results: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Aggregate measures of all lives and of each family present, by family name."""
    rows = {'all': aggregate(results)}
    for family in sorted({r['life']['family'] for r in results}):
        rows[family] = aggregate([r for r in results if r['life']['family'] == family])
    return rows


def verdicts(row: dict[str, Any]) -> dict[str, bool | None]:
    """Pass/fail of each aggregate measure against issue 23's thresholds (None: no lives)."""
    def check(value: float, test: Any) -> bool | None:
        return None if math.isnan(value) else bool(test(value))
    return {
        'alpha_lambda': check(row['alpha_lambda'], lambda v: v >= ALPHA_LAMBDA_SHARE),
        'band': check(row['band'], lambda v: BAND_RANGE[0] <= v <= BAND_RANGE[1]),
        'band_min_life': check(row['band_min_life'], lambda v: v >= BAND_PER_LIFE_MIN),
        'band_mean_life': None,
        'not_optimistic': check(row['not_optimistic'], lambda v: v >= NOT_OPTIMISTIC_SHARE),
        'finite': check(row['finite'], lambda v: v >= FINITE_SHARE),
        'levels': check(row['levels'], lambda v: v >= 1.0),
        'healthy': check(row['healthy'], lambda v: v >= 1.0),
    }


COLUMNS = ('alpha_lambda', 'band', 'band_min_life', 'band_mean_life', 'not_optimistic', 'finite',
           'levels', 'healthy')
HEADER = ('| group | wear lives | healthy lives | alpha-lambda pairs passed (>= 90 %) | '
          "band coverage from lambda 0.25 (80-98 %) | worst life's band (>= 50 %) | "
          "mean of the lives' bands | "
          'p5 <= true RUL from lambda 0.5 (>= 95 %) | RUL finite from lambda 0.25 (>= 90 % '
          'of lives) | levels as required (all lives) | healthy: OK, RUL inf (all lives) |\n'
          '|---|---|---|---|---|---|---|---|---|---|---|')


def table_row(name: str, row: dict[str, Any], marks: bool = True) -> str:
    """One markdown row: the group, its counts, each measure with PASS/FAIL."""
    passed = verdicts(row)
    cells = []
    for column in COLUMNS:
        value = row[column]
        if math.isnan(value):
            cells.append('-')
            continue
        verdict = '' if not marks or passed[column] is None else (
            ' PASS' if passed[column] else ' FAIL')
        cells.append(f'{value:.0%}{verdict}')
    return (f'| {name} | {row["wear_lives"]} | {row["healthy_lives"]} | ' + ' | '.join(cells)
            + ' |')


def tables(results: list[dict[str, Any]]) -> str:
    """Markdown: aggregate, per family and per feature rows, per rate."""
    lines = [HEADER]
    for rate in sorted({r['life']['rate_hz'] for r in results}):
        at_rate = [r for r in results if r['life']['rate_hz'] == rate]
        tag = f'{rate:g} Hz'
        lines.append(table_row(f'**all, {tag}**', aggregate(at_rate)))
        for family in ('healthy', 'linear', 'exponential', 'power', 'mixed'):
            group = [r for r in at_rate if r['life']['family'] == family]
            if group:
                lines.append(table_row(f'{family}, {tag}', aggregate(group), marks=False))
        for feature in sorted({f for r in at_rate for f in r['life']['features']}):
            group = [r for r in at_rate if feature in r['life']['features']]
            lines.append(table_row(f'with {feature}, {tag}', aggregate(group), marks=False))
    return '\n'.join(lines)


def life_row(result: dict[str, Any]) -> str:
    """One markdown row per life: its draw and its scores."""
    life, score = result['life'], result['evaluation']['acceptance']
    head = (f"| {life['seed']} | {life['rate_hz']:g} | {life['family']} | "
            f"{','.join(life['features']) or '-'} | {life['duration_s']:.0f} | ")
    if life['healthy']:
        healthy = score['healthy']
        return head + (f"- | - | - | - | - | {'OK' if healthy['passed'] else 'FAIL'} "
                       f"(finite share {healthy['finite_share']:.0%}, levels "
                       f"{','.join(healthy['levels_seen']) or '-'}) |")
    checks = ' '.join(f"{'p' if c['passed'] else 'F'}{_error(c)}" for c in score['alpha_lambda'])
    band, optimism = score['band'], score['not_optimistic']
    levels = score.get('levels', {})
    return head + (f'{checks} | {_ratio(band)} | {_ratio(optimism)} | '
                   f"{_fraction(score['finite']['finite_from'])} | "
                   f'{_sequence(levels.get("sequence", []))} | {_levels_verdict(levels)} |')


def _sequence(steps: list[str]) -> str:
    """Return the level transitions, or their counts when there are more than four."""
    if len(steps) <= 4:
        return ','.join(steps) or '-'
    counts = {step: steps.count(step) for step in dict.fromkeys(steps)}
    return f'{len(steps)} changes: ' + ', '.join(f'{k} x{v}' for k, v in counts.items())


def _levels_verdict(levels: dict[str, Any]) -> str:
    if not levels:
        return '-'
    if levels['passed']:
        return 'ok'
    reasons = [text for key, text in (('warn_before_onset', 'WARN before onset'),
                                      ('error_before_eol', 'ERROR before EOL'))
               if levels[key]]
    return 'FAIL' + (f' ({", ".join(reasons)})' if reasons else '')


def _error(check: dict[str, Any]) -> str:
    predicted = check['predicted_rul']
    if isinstance(predicted, str):
        return predicted
    return f'{predicted / check["true_rul"] - 1.0:+.0%}'


def _fraction(value: Any) -> str:
    return value if isinstance(value, str) else f'{value:.2f}'


def _ratio(part: dict[str, Any]) -> str:
    count = part['predictions']
    return f"{part['held'] / count:.0%}" if count else '-'


LIFE_HEADER = ('| seed | rate [Hz] | family | features | record [s] | alpha-lambda 0.5 0.75 0.9 '
               '(RUL error) | band | p5 <= true | finite from | levels | levels ok / healthy |'
               '\n|---|---|---|---|---|---|---|---|---|---|---|')


def main() -> int:
    """Run the ensemble and print its tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('out', type=Path)
    parser.add_argument('--seeds', type=int, default=60, help='number of lives (default 60)')
    parser.add_argument('--first', type=int, default=1, help='first seed (default 1)')
    parser.add_argument('--rates', type=float, nargs='+', default=[100.0],
                        help='sample rates [Hz]; rates above 100 Hz only for lives up to '
                             f'{FAST_RATE_MAX_DURATION:.0f} s (default 100)')
    parser.add_argument('--workers', type=int, default=1, help='parallel lives (default 1)')
    parser.add_argument('--prior', choices=('paper', 'bench', 'architectures'),
                        default='paper',
                        help='prior of the random lives (gear-phm simulate --prior; bench: '
                             'every real-gearbox effect on; architectures: the gear train, '
                             'planetary, worm and screw plants; docs/lives.md) (default paper)')
    parser.add_argument('--nice', type=int, default=19,
                        help='niceness of simulate/analyze/evaluate (default 19)')
    parser.add_argument('--reuse', action='store_true',
                        help='keep lives already simulated and analysed in OUT')
    parser.add_argument('--analysis', default='a', metavar='NAME',
                        help="each life's analysis folder (default a): several configurations "
                             'of the same lives side by side, the bags shared')
    parser.add_argument('--analyze-arg', action='append', default=[], metavar='ARG',
                        help='one more argument of gear-phm analyze (repeat it), e.g. '
                             '--analyze-arg=--param --analyze-arg=no_load_model=true')
    parser.add_argument('--prepare-only', action='store_true',
                        help='only simulate and analyse (no scoring)')
    parser.add_argument('--progpy', action='store_true',
                        help='also score progpy (bench/progpy_baseline.py) on the same lives')
    parser.add_argument('--progpy-python', default='/tmp/progpy_venv/bin/python')
    parser.add_argument('--samples', type=int, default=100,
                        help='progpy MonteCarlo samples per prediction (default 100)')
    args = parser.parse_args()
    os.environ[NICE_ENV] = str(args.nice)
    sys.path.insert(0, str(ROOT))
    from gear_phm.simulation.lives import random_life

    tasks = []
    for seed in range(args.first, args.first + args.seeds):
        for rate in args.rates:
            life = random_life(seed, rate, args.prior).to_json()
            operating = life.get('operating_duration_s', life['duration_s'])   # no idle gap
            if rate > 100.0 and operating > FAST_RATE_MAX_DURATION:
                continue
            tasks.append((args.out / f'{rate:g}hz' / f'life_{seed}', seed, rate, args.reuse,
                          args.prepare_only, args.prior, args.analysis,
                          tuple(args.analyze_arg)))
    args.out.mkdir(parents=True, exist_ok=True)
    results: list[dict[str, Any]] = []
    failed: list[dict[str, Any]] = []
    print(LIFE_HEADER, flush=True)
    with Pool(args.workers) as pool:
        for result in pool.imap(run_life, tasks):
            if 'failed' in result:
                failed.append(result)
                print(f"failed: life {result['life']['seed']} at {result['life']['rate_hz']:g} "
                      f"Hz: {result['failed']}", flush=True)
                continue
            results.append(result)
            if args.prepare_only:
                print(f"prepared {result['life']['seed']} at {result['life']['rate_hz']:g} Hz "
                      f"({result['seconds']:.0f} s)", flush=True)
                continue
            print(life_row(result), f'<!-- {result["seconds"]:.0f} s -->', flush=True)
    if args.prepare_only:
        return 0
    text = ['\n'.join([LIFE_HEADER] + [life_row(r) for r in results]), tables(results)]
    if failed:
        text.append('Lives the analysis refused (not in the tables): ' + '; '.join(
            f"{r['life']['seed']} at {r['life']['rate_hz']:g} Hz ({r['failed']})"
            for r in failed))
    commit = subprocess.run(['git', '-C', str(ROOT), 'describe', '--always', '--dirty'],
                            capture_output=True, text=True).stdout.strip()
    text.insert(0, f'Commit {commit}; command: {" ".join(sys.argv)}')
    summary: dict[str, Any] = {'commit': commit, 'lives': len(results),
                               'failed': [r['life']['seed'] for r in failed],
                               'gear_phm': groups(results)}
    if args.progpy:
        from progpy_ensemble import progpy_results
        scored = progpy_results(results, args)
        text.append(progpy_tables(results, scored))
        summary['progpy'] = {name: groups(rows) for name, rows in scored.items()}
    print('\n\n'.join(text[2:]))
    tables_name = '' if args.analysis == 'a' else f'_{args.analysis}'
    (args.out / f'table{tables_name}.md').write_text('\n\n'.join(text) + '\n', encoding='utf-8')
    (args.out / f'ensemble{tables_name}.json').write_text(
        json.dumps(_json_ready(summary), indent=2) + '\n', encoding='utf-8')
    return 0


def _json_ready(value: Any) -> Any:
    """``value`` with NaN as None (strict JSON)."""
    if isinstance(value, dict):
        return {key: _json_ready(item) for key, item in value.items()}
    return None if isinstance(value, float) and math.isnan(value) else value


def progpy_tables(results: list[dict[str, Any]], scored: dict[str, list[dict[str, Any]]]
                  ) -> str:
    """Aggregate rows of gear_phm and each progpy model, side by side."""
    lines = [HEADER, table_row('gear_phm', aggregate(results))]
    lines += [table_row(f'progpy {name}', aggregate(rows)) for name, rows in scored.items()]
    return '\n'.join(lines)


if __name__ == '__main__':
    sys.exit(main())
