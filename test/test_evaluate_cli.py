"""gear-phm evaluate on recordings written with the lead's rosbag2 MCAP writer."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gear_phm.bagio import Rosbag2McapWriter
from gear_phm.cli.main import main
from gear_phm.interfaces import HEALTH_RUL, TRUTH_FRICTION, Vector3Out


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
