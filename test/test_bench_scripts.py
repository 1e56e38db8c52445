"""Each benchmark script runs on a tiny input (the benchmarks themselves are not tests)."""
from __future__ import annotations

import json
from pathlib import Path
import subprocess
import sys

import pytest

BENCH = Path(__file__).resolve().parents[1] / 'bench'


def run(script: str, *args: str, timeout: float = 240.0) -> str:
    result = subprocess.run([sys.executable, str(BENCH / script), *args, '--no-append'],
                            capture_output=True, text=True, timeout=timeout)
    assert result.returncode == 0, result.stderr[-2000:]
    return result.stdout


def test_bench_models_tiny() -> None:
    out = run('bench_models.py', '--size', '1000', '--repeat', '1')
    assert '| `eta_opposing(u, R)` |' in out and 'ratio to bare numpy' in out


def test_bench_offline_analyze_tiny() -> None:
    out = run('offline_analyze.py', '--samples', '3000', '--repeat', '1')
    assert 'rosbags read + deserialize_cdr (baseline)' in out
    assert '`gear-phm analyze` end to end' in out


def test_bench_memory_logic_tiny() -> None:
    out = run('memory.py', '--mode', 'logic', '--samples', '36000')
    assert '36,000 (1 h)' in out and '6,000 (10 min)' in out


@pytest.mark.integration
def test_bench_live_pipeline_tiny() -> None:
    out = run('live_pipeline.py', '--duration', '1', '--rates', '200',
              '--latency-rates', '200', '--targets', 'bare subscriber (baseline),estimator',
              '--cpu-rates', '200', '--idle', '1')
    assert '| estimator | 200 |' in out and 'p99 [ms]' in out
    assert 'estimator [us/msg]' in out and 'estimator [% of a core]' in out


@pytest.mark.integration
def test_bench_monitor_vs_processes_tiny() -> None:
    out = run('monitor_vs_processes.py', '--bag', str(BENCH.parent / 'bags' / 'healthy'),
              '--rate-factor', '40')
    assert '| three processes (baseline) |' in out and '`gear-phm monitor`' in out


def test_bench_fleet_scale_tiny() -> None:
    out = run('fleet_scale.py', '--units', '2', '--recordings', '2', '--duration', '5',
              '--repeat', '1')
    assert '| 2 |' in out and 'core-hours' in out and '| yes |' in out


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
                             '--first', '55', '--seeds', '2'],
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
