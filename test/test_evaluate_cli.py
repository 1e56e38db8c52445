"""gear-phm evaluate on recordings written with the lead's rosbag2 MCAP writer."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from gear_phm.bagio import Rosbag2McapWriter
from gear_phm.cli.main import main
from gear_phm.interfaces import HEALTH_EFFICIENCY, HEALTH_RUL, TRUTH_FRICTION, Vector3Out


def _write(directory: Path, topic: str, rows) -> None:
    with Rosbag2McapWriter(directory, compression=None) as writer:
        for t, x, y, z in rows:
            writer.write_output(Vector3Out(topic, int(round(t * 1e9)), x, y, z))


@pytest.fixture()
def bags(tmp_path: Path) -> tuple[Path, Path]:
    t = np.arange(0.0, 1000.0, 10.0)
    true_u = 0.05 + 0.55 * t / 600.0                     # reaches u_eol 0.6 at t = 600 s
    _write(tmp_path / 'truth', TRUTH_FRICTION, [(ti, ui, ui, 0.0) for ti, ui in zip(t, true_u)])
    ruls = 1.1 * (600.0 - t[t < 600.0])                  # 10 % too long: inside alpha 0.2
    _write(tmp_path / 'run' / 'bag', HEALTH_RUL,
           [(ti, r, 0.8 * r, 1.2 * r) for ti, r in zip(t, ruls)])
    return tmp_path / 'run', tmp_path / 'truth'


def test_evaluate_against_truth_bag(bags, capsys) -> None:
    run, truth = bags
    assert main(['evaluate', str(run), '--truth', str(truth)]) == 0
    result = json.loads((run / 'bag' / 'evaluation.json').read_text())
    assert result['t_eol_s'] == 600.0 and result['u_eol'] == pytest.approx(0.6)
    assert [c['passed'] for c in result['alpha_lambda']] == [True, True, True]
    assert result['relative_accuracy']['0.5'] == pytest.approx(0.9)
    # |0.1 (600 - t)| <= 0.2 * 600 everywhere: PH = whole span
    assert result['prognostic_horizon_s'] == 600.0
    assert 'PASS' in capsys.readouterr().out


def test_evaluate_csv_truth_and_stricter_eol(bags, tmp_path: Path) -> None:
    run, _ = bags
    csv = tmp_path / 'truth.csv'
    csv.write_text('time,true_eol\n0,500\n100,480\n')
    out = tmp_path / 'm.json'
    assert main(['evaluate', str(run), '--truth', str(csv), '--output', str(out)]) == 0
    result = json.loads(out.read_text())
    assert result['t_eol_s'] == 480.0
    assert not result['alpha_lambda'][2]['passed']        # 1.1 (600 - t) vs 480 - t


def test_evaluate_with_only_eta_opposing_min(bags) -> None:
    """eta_opposing_min 0.7 alone (above the old fixed eta_warn 0.6): u_eol 0.29 at 262 s."""
    run, truth = bags
    assert main(['evaluate', str(run), '--truth', str(truth), '--eta-opposing-min', '0.7']) != 2
    result = json.loads((run / 'bag' / 'evaluation.json').read_text())
    assert result['u_eol'] == pytest.approx(0.9 / 3.1)         # eta_D = 0.7 at R = 3
    assert result['t_eol_s'] == 270.0                           # first truth stamp past it


def test_evaluate_errors_are_one_line(bags, tmp_path: Path, capsys) -> None:
    run, truth = bags
    assert main(['evaluate', str(truth), '--truth', str(truth)]) == 2
    assert 'no bag with topic gear_phm/health/rul' in capsys.readouterr().err
    assert main(['evaluate', str(run), '--truth', str(truth), '--u-max', '0.0',
                 '--eta-opposing-min', '0.1', '--eta-warn', '0.2',
                 '--no-self-locking-eol']) == 2
    assert 'never reaches u_eol' in capsys.readouterr().err
    assert main(['evaluate', str(run), '--truth', str(truth), '--eta-warn', '0.4']) == 2
    err = capsys.readouterr().err.strip()
    assert err.count('\n') == 0 and 'eta_warn must be > eta_opposing_min' in err


def _run_with_levels(directory: Path, error_at: float) -> None:
    """RUL inf before 100 s, then 10 % long; band tight (misses) before 300 s; levels."""
    t = np.arange(0.0, 700.0, 10.0)
    rows, states = [], []
    for ti in t:
        r = math.inf if ti < 100.0 else 1.1 * max(600.0 - ti, 0.0)
        low = 0.8 if ti >= 300.0 else 0.95          # true RUL = r / 1.1 = 0.909 r
        rows.append((ti, r, low * r, 1.2 * r))
        level = 0 if ti < 200.0 else (1 if ti < error_at else 2)
        states.append((ti, 0.7, 0.6, float(level)))
    with Rosbag2McapWriter(directory, compression=None) as writer:
        for ti, x, y, z in rows:
            writer.write_output(Vector3Out(HEALTH_RUL, int(round(ti * 1e9)), x, y, z))
        for ti, x, y, z in states:
            writer.write_output(Vector3Out(HEALTH_EFFICIENCY, int(round(ti * 1e9)), x, y, z))


@pytest.mark.parametrize('error_at', [550.0, 610.0])
def test_evaluate_scores_finiteness_band_and_level_transitions(bags, tmp_path: Path, capsys,
                                                               error_at: float) -> None:
    """The acceptance measures of docs/prognostics.md, computed by the CLI a user runs."""
    _, truth = bags
    run = tmp_path / f'levels_{error_at:.0f}'
    _run_with_levels(run, error_at)
    out = tmp_path / f'm_{error_at:.0f}.json'
    assert main(['evaluate', str(run), '--truth', str(truth), '--output', str(out)]) == 0
    result = json.loads(out.read_text())
    # last inf at 90 s, the next prediction at 100 s: 100 / 600 of the life
    assert result['rul_finite_from'] == pytest.approx(100.0 / 600.0)
    # from lambda 0.25 (150 s) to 590 s: 45 predictions, the band holds from 300 s on (30)
    assert result['band_coverage'] == {'from_lambda': 0.25, 'share': pytest.approx(30 / 45),
                                       'predictions': 45}
    steps = [(c['from'], c['to'], c['t']) for c in result['level_transitions']]
    assert steps == [('OK', 'WARN', 200.0), ('WARN', 'ERROR', error_at)]
    assert result['level_transitions'][1]['lam'] == pytest.approx(error_at / 600.0)
    assert result['error_before_eol'] is (error_at < 600.0)
    text = capsys.readouterr().out
    assert 'RUL finite from lambda 0.1666' in text
    assert f'ERROR before the true end of life: {"YES" if error_at < 600.0 else "no"}' in text
    # --band-from moves the counted span: from 0.5 (300 s) every band holds
    assert main(['evaluate', str(run), '--truth', str(truth), '--output', str(out),
                 '--band-from', '0.5']) == 0
    assert json.loads(out.read_text())['band_coverage']['share'] == 1.0


def test_evaluate_without_levels_and_never_finite(bags, tmp_path: Path) -> None:
    """A run without levels has no level keys; an RUL inf to the end is finite from 'inf'.

    Its band never holds.
    """
    _, truth = bags
    run = tmp_path / 'never'
    t = np.arange(0.0, 600.0, 10.0)
    _write(run, HEALTH_RUL, [(ti, math.inf, math.inf, math.inf) for ti in t])
    out = tmp_path / 'never.json'
    assert main(['evaluate', str(run), '--truth', str(truth), '--output', str(out)]) == 0
    result = json.loads(out.read_text())
    assert result['rul_finite_from'] == 'inf'
    assert result['band_coverage']['share'] == 0.0
    assert 'level_transitions' not in result and 'error_before_eol' not in result
