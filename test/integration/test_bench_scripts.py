"""Each benchmark script runs on a tiny input (the benchmarks themselves are not tests).

The tables they print are read back: counts as the input implies, rates and times finite and
positive, and every ratio the quotient of its row's value and the baseline's, to the printed
rounding.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
import subprocess
import sys

import pytest

BENCH = Path(__file__).resolve().parents[2] / 'bench'


def run(script: str, *args: str, timeout: float = 240.0) -> str:
    result = subprocess.run([sys.executable, str(BENCH / script), *args, '--no-append'],
                            capture_output=True, text=True, timeout=timeout)
    assert result.returncode == 0, result.stderr[-2000:]
    return result.stdout


def table(out: str, first_column: str) -> list[dict[str, str]]:
    """Return the rows of the printed markdown table whose first heading is ``first_column``."""
    lines = out.splitlines()
    for start, line in enumerate(lines):
        cells = [c.strip() for c in line.strip().strip('|').split('|')]
        if line.startswith('| ') and cells[0] == first_column:
            rows = []
            for row in lines[start + 2:]:
                if not row.startswith('|'):
                    break
                rows.append(dict(zip(cells, (c.strip() for c in row.strip().strip('|')
                                             .split('|')))))
            return rows
    raise AssertionError(f'no table headed {first_column!r} in:\n{out}')


def number(cell: str) -> float:
    """Return the finite value of a table cell; thousands separators and units stripped."""
    value = float(cell.replace(',', '').split()[0].rstrip('%'))
    assert math.isfinite(value), cell
    return value


def _half_unit(text: str) -> float:
    """Half the last printed digit of a number as printed (0.05 for '1.7', 0.5 for '32')."""
    digits = text.strip().replace(',', '').split('e')[0]
    return 0.5 * 10.0 ** -(len(digits.split('.')[1]) if '.' in digits else 0)


def assert_ratio(ratio: str, value: str, base: str) -> None:
    """``ratio`` is value / base as printed: within the rounding of all three numbers.

    All are finite; value and base are positive; the printed ratio may round to 0 (a 2 000 x
    slower row).
    """
    v, b, r = number(value), number(base), number(ratio)
    assert b > 0 and v > 0, (value, base)
    assert r >= 0
    dv, db, dr = _half_unit(value), _half_unit(base), _half_unit(ratio)
    low, high = max(v - dv, 0.0) / (b + db), (v + dv) / max(b - db, 1e-300)
    assert low * (1 - 1e-9) - dr <= r <= high * (1 + 1e-9) + dr, (ratio, value, base)


def test_bench_models_tiny() -> None:
    out = run('bench_models.py', '--size', '1000', '--repeat', '1')
    assert '| `eta_opposing(u, R)` |' in out and 'ratio to bare numpy' in out
    rows = table(out, 'function')
    assert len(rows) == 7 and rows[0]['function'].endswith('(baseline)')
    base = rows[0]['evaluations/s']
    for row in rows:
        assert_ratio(row['ratio to bare numpy eq 10'], row['evaluations/s'], base)
    assert number(rows[0]['ratio to bare numpy eq 10']) == 1.0


def test_bench_offline_analyze_tiny() -> None:
    out = run('offline_analyze.py', '--samples', '3000', '--repeat', '1')
    assert 'rosbags read + deserialize_cdr (baseline)' in out
    assert '`gear-phm analyze` end to end' in out
    rows = table(out, 'stage')
    assert len(rows) == 5
    [rosbags] = [r['samples/s'] for r in rows if r['stage'].endswith('(baseline)')]
    [raw] = [r['samples/s'] for r in rows if r['stage'].startswith('mcap raw')]
    for row in rows:
        assert_ratio(row['ratio to rosbags decode'], row['samples/s'], rosbags)
        assert_ratio(row['ratio to mcap raw'], row['samples/s'], raw)
    assert '3,000 JointState samples' in out


def test_bench_analyze_e2e_tiny() -> None:
    out = run('analyze_e2e.py', '--samples', '2000', '--rates', '100', '--repeat', '1')
    assert '| 2,000 samples, 100 Hz |' in out and 'ratio analyze / rosbags (wall)' in out


def test_bench_memory_logic_tiny() -> None:
    out = run('memory.py', '--mode', 'logic', '--samples', '36000')
    assert '36,000 (1 h)' in out and '6,000 (10 min)' in out
    rows = {row['samples (1 kHz)']: row for row in table(out, 'samples (1 kHz)')}
    assert list(rows) == ['0 (start)', '6,000 (10 min)', '36,000 (1 h)', 'run time']
    rss = [number(rows[k]['RSS [MiB]']) for k in ('0 (start)', '6,000 (10 min)', '36,000 (1 h)')]
    assert all(value > 0 for value in rss)
    # growth in % of the 10-min RSS, to the printed 0.1 MiB and 0.1 %
    growth = number(rows['36,000 (1 h)']['growth vs 10-min mark'])
    assert growth == pytest.approx(100 * (rss[2] - rss[1]) / rss[1], abs=0.1 + 10 / rss[1])
    assert number(rows['run time']['RSS [MiB]']) > 0
    assert number(rows['run time']['growth vs 10-min mark']) > 0        # samples/s


def test_bench_memory_analyze_tiny() -> None:
    out = run('memory.py', '--mode', 'analyze', '--samples', '3000', '6000')
    assert '| gear-phm analyze --no-plot | 6,000 |' in out
    assert '| Python API analyze_bag(bag, 3.0), defaults | 3,000 |' in out


@pytest.mark.integration
@pytest.mark.long(30)
def test_bench_live_pipeline_tiny() -> None:
    out = run('live_pipeline.py', '--duration', '1', '--rates', '200',
              '--latency-rates', '200', '--targets', 'bare subscriber (baseline),estimator',
              '--cpu-rates', '200', '--idle', '1')
    assert '| estimator | 200 |' in out and 'p99 [ms]' in out
    assert 'estimator [us/msg]' in out and 'estimator [% of a core]' in out
    trials = table(out[out.index('Trials:'):], 'target')
    assert {r['target'] for r in trials} == {'bare subscriber (baseline)', 'estimator'}
    for row in trials:
        sent, received, lost = (int(row[k]) for k in ('sent', 'received', 'lost'))
        assert row['rate [Hz]'] == '200' and sent == 200          # 1 s at 200 Hz
        assert 0 < received <= sent and lost == sent - received
    cpu = table(out, 'rate [Hz]')[0]              # the CPU table; latency comes after it
    assert_ratio(cpu['ratio'], cpu['estimator [us/msg]'], cpu['bare [us/msg]'])
    [idle] = table(out, 'run')
    assert all(number(idle[k]) >= 0 for k in ('bare [% of a core]', 'estimator [% of a core]'))
    latency = table(out[out.index('Live latency'):], 'rate [Hz]')
    assert len(latency) == 1 and int(latency[0]['estimates']) > 0
    p50, p99, worst = (number(latency[0][k]) for k in ('p50 [ms]', 'p99 [ms]', 'max [ms]'))
    assert 0 < p50 <= p99 <= worst


@pytest.mark.integration
def test_bench_monitor_vs_processes_tiny(tmp_path: Path) -> None:
    """Both modes replay a 30 s healthy bag (bags/healthy's plant, u = 0.05, seed 1).

    bags/healthy (120 s) made each mode process 12 000 messages: 10.6 s of CPU, 5.3 s with
    this bag, its simulation (in this process) included.
    """
    from gear_phm.cli.main import main
    bag = tmp_path / 'healthy_30s'
    assert main(['simulate', '--out', str(bag), '--duration', '30', '--rate', '100',
                 '--seed', '1', '--wear', 'constant', '--friction-initial', '0.05']) == 0
    out = run('monitor_vs_processes.py', '--bag', str(bag), '--rate-factor', '40')
    assert '| three processes (baseline) |' in out and '`gear-phm monitor`' in out
    base, monitor = table(out, 'mode')
    assert base['mode'] == 'three processes (baseline)'
    for row in (base, monitor):
        assert number(row['wall [s]']) > 0
        assert_ratio(row['CPU ratio'], row['CPU [s]'], base['CPU [s]'])
        assert_ratio(row['RSS ratio'], row['peak RSS, all processes [MiB]'],
                     base['peak RSS, all processes [MiB]'])
        assert 0.03 < number(row['last u reported']) < 0.08      # healthy: u = 0.05


@pytest.mark.long(12)
def test_bench_fleet_scale_tiny() -> None:
    out = run('fleet_scale.py', '--units', '2', '--recordings', '2', '--duration', '5',
              '--repeat', '1')
    assert '| 2 |' in out and 'core-hours' in out and '| yes |' in out
    one, two = table(out, 'workers')
    assert (one['workers'], two['workers'], two['tables identical']) == ('1', '2', 'yes')
    for row in (one, two):
        assert_ratio(row['speed-up'], one['wall [s]'], row['wall [s]'])
        # 2 units x 2 recordings x 5 s at 100 Hz = 2 000 samples; 4 recordings: each rate is
        # that count over the printed wall time, within the rounding of both
        assert_ratio(row['samples/s'], '2000', row['wall [s]'])
        assert_ratio(row['recordings/s'], '4', row['wall [s]'])
    assert '(2,000 samples)' in out


def test_bench_idle_gaps_small() -> None:
    """Two units a week between recordings: the operating-time RUL passes, elapsed time fails."""
    result = subprocess.run([sys.executable, str(BENCH / 'idle_gaps.py'), '--units', '2'],
                            capture_output=True, text=True, timeout=240)
    assert result.returncode == 0, result.stdout + result.stderr[-2000:]
    rows = [line for line in result.stdout.splitlines() if line.startswith('| unit_')]
    assert len(rows) == 2
    scored = [row.split(' | ') for row in rows if 'not reached' not in row]
    assert scored and all(cells[2].startswith(('FAIL pass pass', 'pass pass pass'))
                          and cells[3].startswith('FAIL FAIL FAIL') for cells in scored)


def test_bench_recorder_cost_tiny() -> None:
    tree = str(BENCH.parent)
    result = subprocess.run([sys.executable, str(BENCH / 'recorder_cost.py'), tree, tree,
                             '--seconds', '5', '--repeat', '1', '--inputs'],
                            capture_output=True, text=True, timeout=240)
    assert result.returncode == 0, result.stderr[-2000:]
    assert '5 s of node time, 405 records (inputs recorded)' in result.stdout
    assert '| A |' in result.stdout and 'B / A = ' in result.stdout


def test_bench_simulate_speed_tiny() -> None:
    tree = str(BENCH.parent)
    result = subprocess.run([sys.executable, str(BENCH / 'simulate_speed.py'), tree, tree,
                             '--samples', '3000', '--repeat', '1'],
                            capture_output=True, text=True, timeout=240)
    assert result.returncode == 0, result.stderr[-2000:]
    assert '3,000 samples at 1000 Hz, medians of 1 runs' in result.stdout
    assert result.stdout.count('| A: ') == 1 and 'A / B: wall ' in result.stdout


def test_bench_ensemble_two_short_lives(tmp_path: Path) -> None:
    """Seeds 55 (healthy, 355 s) and 56 (linear, 353 s): the table is evaluate's numbers."""
    result = subprocess.run([sys.executable, str(BENCH / 'ensemble.py'), str(tmp_path),
                             '--first', '55', '--seeds', '2', '--nice', '0'],
                            capture_output=True, text=True, timeout=240.0)
    assert result.returncode == 0, result.stderr[-2000:]
    summary = json.loads((tmp_path / 'ensemble.json').read_text())
    assert summary['lives'] == 2
    every = summary['gear_phm']['all']
    assert (every['wear_lives'], every['healthy_lives'], every['alpha_lambda_pairs']) == (1, 1, 3)
    score = json.loads((tmp_path / '100hz' / 'life_56' / 'a' / 'evaluation.json').read_text())
    life = json.loads((tmp_path / '100hz' / 'life_56' / 'bag' / 'life.json').read_text())
    assert score['t_start_s'] == life['onset_s'] and score['t_eol_s'] == life['end_of_life_s']
    accept = score['acceptance']
    band, below = accept['band'], accept['not_optimistic']
    assert band['predictions'] > 100 and below['predictions'] > 50
    assert every['band'] == pytest.approx(band['held'] / band['predictions'])
    assert every['not_optimistic'] == pytest.approx(below['held'] / below['predictions'])
    assert every['alpha_lambda'] == pytest.approx(
        sum(c['passed'] for c in accept['alpha_lambda']) / 3)
    assert every['finite'] == float(accept['finite']['passed'])
    assert every['healthy'] == float(json.loads(
        (tmp_path / '100hz' / 'life_55' / 'a' / 'evaluation.json').read_text())
        ['acceptance']['healthy']['passed'])
    assert summary['gear_phm']['healthy']['band'] is None
    row = next(line for line in result.stdout.splitlines() if line.startswith('| **all'))
    assert f"| {every['band']:.0%} FAIL |" in row or f"| {every['band']:.0%} PASS |" in row


def test_bench_multi_drive_tiny() -> None:
    out = run('multi_drive.py', '--drives', '2', '--duration', '10', '--rate', '100',
              '--repeat', '1')
    rows = table(out, 'analysis')
    from gear_phm.offline.parallel import AUTO_MIN_SAMPLES
    assert 1000 * 2 < AUTO_MIN_SAMPLES          # too small a bag: --jobs 0 starts no worker
    assert [r['analysis'] for r in rows] == [
        '2 single-drive runs (`--ratio`, one process each)',
        'one pass (`--transmissions --jobs 1`, one process)',
        'one pass (`--transmissions`, default `--jobs 0`: 0 worker processes)']
    for column in ('wall', 'CPU'):
        base = rows[0][f'{column} [s]']
        for row in rows:
            assert_ratio(row[f'N runs / one pass ({column})'], base, row[f'{column} [s]'])
    assert '2 drives in one JointState stream (4 joints), 1,000 messages' in out
    worst = float(out.split('its single run: u ')[1].split()[0].rstrip(','))
    assert 0.0 <= worst <= 1e-9


@pytest.mark.integration
def test_bench_multi_drive_live_tiny() -> None:
    out = run('multi_drive_live.py', '--drives', '2', '--duration', '2', '--rate', '200')
    [row] = table(out, 'drives')
    assert row['drives'] == '2' and row['rate [Hz]'] == '200'
    assert_ratio(row['ratio'], row['many drives [us/msg]'], row['one drive [us/msg]'])
    many, one, sent = (int(v) for v in row['received many / one / sent'].split(' / '))
    assert sent == 400 and 0 < many <= sent and 0 < one <= sent


def test_bench_rul_ceiling_tiny() -> None:
    """The oracle's ceiling: 1 for deterministic lives, a probability for stochastic ones."""
    sys.path.insert(0, str(BENCH))
    from rul_ceiling import best_pass_probability
    assert best_pass_probability([100.0] * 5) == 1.0
    assert best_pass_probability([100.0, 200.0]) == 0.5        # no p holds both within 20 %
    assert best_pass_probability([100.0, 140.0, math.inf, math.inf]) == 0.5
    assert best_pass_probability([math.inf]) == 0.0
    result = subprocess.run([sys.executable, str(BENCH / 'rul_ceiling.py'), '--seeds', '4',
                             '--rates', '100', '--futures', '20', '--workers', '1'],
                            capture_output=True, text=True, timeout=240.0)
    assert result.returncode == 0, result.stderr[-2000:]
    rows = table(result.stdout, 'rate')
    assert rows and rows[0]['lives'] == 'all'
    for row in rows:
        assert 0.0 <= number(row['alpha-lambda ceiling (all pairs)']) <= 100.0
        if row['lives'] == 'deterministic':
            assert number(row['alpha-lambda ceiling (all pairs)']) == 100.0


def test_bench_analyze_floor_tiny() -> None:
    out = run('analyze_floor.py', '--samples', '2000', '--rates', '100', '--repeat', '1')
    [row] = table(out, 'bag')
    assert row['bag'] == '2,000 samples, 100 Hz'
    assert_ratio(row['budget of 3x [s]'], row['rosbags read + deserialize [s]'], '3')
    parts = [number(row[key]) for key in ('start-up [s]',
                                          'assessment chain [s] (of it RUL refits)',
                                          'plot draw [s]')]
    assert number(row['floor [s]']) == pytest.approx(sum(parts), abs=0.02)
    assert_ratio(row['floor / budget'], row['floor [s]'], row['budget of 3x [s]'])


def test_bench_no_load_cost_tiny() -> None:
    result = subprocess.run([sys.executable, str(BENCH / 'no_load_cost.py'), '--duration',
                             '30', '--rate', '100', '--repeat', '1'],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert '| ratio B / A |' in result.stdout
