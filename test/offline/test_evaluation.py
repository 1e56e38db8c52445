"""Scoring a run's RUL predictions against the truth (gear_phm.offline.evaluation)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gear_phm.bagio import Rosbag2McapWriter
from gear_phm.interfaces import HEALTH_RUL, TRUTH_FRICTION, Vector3Out
from gear_phm.offline.evaluation import (evaluate_run, EvaluationError, find_bag,
                                         health_config, overlap, read_levels,
                                         read_predictions)
from gear_phm.offline.truth import LifeRecord
from gear_phm.prognostics import HealthConfig

#: The truth reaches u_eol 0.6 (ratio 3, eta_opposing_min 0.5) at t = 600 s.
CONFIG = HealthConfig(ratio=3.0, eta_opposing_min=0.5)
SCORING = {'alpha': 0.2, 'lambdas': (0.25, 0.5, 0.75), 'band_from': 0.25}


def _write(directory: Path, topic: str, rows: list[tuple[float, float, float, float]]
           ) -> Path:
    with Rosbag2McapWriter(directory, compression=None) as writer:
        for t, x, y, z in rows:
            writer.write_output(Vector3Out(topic, int(round(t * 1e9)), x, y, z))
    return directory


@pytest.fixture()
def bags(tmp_path: Path) -> tuple[Path, Path]:
    """Return (run directory, truth bag): RUL 10 % too long, its band +/- 20 %."""
    t = np.arange(0.0, 1000.0, 10.0)
    true_u = 0.05 + 0.55 * t / 600.0
    truth = _write(tmp_path / 'truth', TRUTH_FRICTION,
                   [(ti, ui, ui, 0.0) for ti, ui in zip(t, true_u)])
    ruls = 1.1 * (600.0 - t[t < 600.0])
    _write(tmp_path / 'run' / 'bag', HEALTH_RUL,
           [(ti, r, 0.8 * r, 1.2 * r) for ti, r in zip(t, ruls)])
    return tmp_path / 'run', truth


def test_a_run_is_scored_against_its_truth_bag(bags: tuple[Path, Path]) -> None:
    run, truth = bags
    bag = find_bag(run)
    assert bag == run / 'bag'
    predictions = read_predictions(bag)
    assert predictions.span == (0.0, 590.0) and predictions.median[0] == pytest.approx(660.0)
    assert read_levels(bag) is None                  # no health/efficiency topic
    result = evaluate_run(bag, truth, CONFIG, **SCORING)
    assert result.u_eol == pytest.approx(0.6) and result.t_eol == pytest.approx(600.0)
    metrics = result.metrics
    assert [c['passed'] for c in metrics['alpha_lambda']] == [True, True, True]
    assert metrics['predictions'] == 60 and metrics['prognostic_horizon_s'] == 600.0
    assert metrics['band_coverage']['share'] == 1.0       # 0.8 r <= true RUL <= 1.2 r
    assert metrics['rul_finite_from'] == 0.0
    assert 'acceptance' not in metrics and 'level_transitions' not in metrics
    assert result.warnings == ()


def test_a_healthy_life_is_scored_on_staying_ok(bags: tuple[Path, Path]) -> None:
    run, truth = bags
    life = LifeRecord(3.0, 0.5, 0.6, None, None, True)
    result = evaluate_run(find_bag(run), truth, CONFIG, life=life, **SCORING)
    assert math.isnan(result.t_eol) and result.metrics['healthy'] is True
    score = result.metrics['acceptance']['healthy']
    assert score['predictions'] == 60 and score['finite'] == 60 and not score['passed']


def test_health_config_takes_the_life_s_defaults() -> None:
    life = LifeRecord(5.0, 0.65, 0.2, 10.0, 100.0, False)
    config = health_config({'eta_opposing_min': None}, None, life)
    assert config.ratio == 5.0 and config.eta_opposing_min == 0.65
    given = health_config({'eta_opposing_min': 0.7}, 2.0, life)
    assert given.ratio == 2.0 and given.eta_opposing_min == 0.7
    with pytest.raises(EvaluationError, match='eta_opposing_min'):
        health_config({'eta_opposing_min': 7.0}, 2.0, None)


def test_overlap_and_missing_runs(tmp_path: Path) -> None:
    assert overlap((0.0, 100.0), None, tmp_path) == []
    assert overlap((0.0, 100.0), (0.0, 100.5), tmp_path) == []       # within 1 %
    partly = overlap((0.0, 100.0), (50.0, 150.0), tmp_path)
    assert len(partly) == 1 and partly[0].endswith('they overlap only partly')
    with pytest.raises(EvaluationError, match='they do not overlap'):
        overlap((0.0, 10.0), (50.0, 150.0), tmp_path)
    with pytest.raises(EvaluationError, match='does not exist'):
        find_bag(tmp_path / 'none')
    (tmp_path / 'empty').mkdir()
    with pytest.raises(EvaluationError, match='no bag with topic'):
        find_bag(tmp_path / 'empty', 'left')
