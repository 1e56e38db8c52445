"""The ground truth a run is scored against (gear_phm.offline.truth)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gear_phm.bagio import Rosbag2McapWriter
from gear_phm.interfaces import drive_topic, TRUTH_FRICTION, Vector3Out
from gear_phm.offline.truth import (LifeRecord, read_life, read_truth_csv, topic_of,
                                    truth_eol, truth_eol_and_span, TruthError)
from gear_phm.simulation.lives import LIFE_FILE


def _truth(directory: Path, topic: str = TRUTH_FRICTION) -> Path:
    """Write a truth bag with u = 0.05 + 0.55 t / 600 s, every 10 s from 0 to 990 s."""
    with Rosbag2McapWriter(directory, compression=None) as writer:
        for t in np.arange(0.0, 1000.0, 10.0):
            u = 0.05 + 0.55 * t / 600.0
            writer.write_output(Vector3Out(topic, int(round(t * 1e9)), u, u, 0.0))
    return directory


def test_end_of_life_of_a_truth_bag(tmp_path: Path) -> None:
    bag = _truth(tmp_path / 'truth')
    assert truth_eol(bag, 0.6) == pytest.approx(600.0, abs=1e-9)   # u 0.6 first at 600 s
    eol, span = truth_eol_and_span(bag, 0.3)
    assert eol == pytest.approx(280.0, abs=1e-9)     # 0.05 + 0.55 * 280 / 600 = 0.3067
    assert span == pytest.approx((0.0, 990.0), abs=1e-9)
    with pytest.raises(TruthError, match=r'never reaches u_eol = 0\.96 \(max 0\.9575\)'):
        truth_eol(bag, 0.96)


def test_a_drive_has_its_own_truth_topic(tmp_path: Path) -> None:
    assert topic_of(TRUTH_FRICTION, None) == TRUTH_FRICTION
    assert topic_of(TRUTH_FRICTION, 'left') == drive_topic('left', TRUTH_FRICTION)
    bag = _truth(tmp_path / 'truth', drive_topic('left', TRUTH_FRICTION))
    assert truth_eol(bag, 0.6, 'left') == pytest.approx(600.0, abs=1e-9)


def test_truth_csv_gives_its_last_row(tmp_path: Path) -> None:
    path = tmp_path / 'truth.csv'
    path.write_text('# comment\n\ntime,true_eol\n0,500\n100,480.5\n')
    assert read_truth_csv(path) == 480.5
    eol, span = truth_eol_and_span(path, 0.6)
    assert eol == 480.5 and span is None
    path.write_text('time,true_eol\n0,-1\n')
    with pytest.raises(TruthError, match='line 2 column true_eol: expected a finite number > 0'):
        read_truth_csv(path)
    path.write_text('t,eol\n0,1\n')
    with pytest.raises(TruthError, match='missing time, true_eol'):
        read_truth_csv(path)


def test_life_record_beside_the_truth(tmp_path: Path) -> None:
    bag = _truth(tmp_path / 'truth')
    assert read_life(bag) is None
    life = {'ratio': 3.0, 'eta_opposing_min': 0.7, 'u_eol': 0.29, 'onset_s': 10.0,
            'end_of_life_s': 262.0, 'healthy': False, 'seed': 1}
    (bag / LIFE_FILE).write_text(json.dumps(life))
    assert read_life(bag) == LifeRecord(3.0, 0.7, 0.29, 10.0, 262.0, False)
    (bag / LIFE_FILE).write_text(json.dumps({**life, 'onset_s': None, 'healthy': 'no'}))
    with pytest.raises(TruthError, match="field 'healthy': expected true or false"):
        read_life(bag)
    (bag / LIFE_FILE).write_text(json.dumps({'ratio': 3.0}))
    with pytest.raises(TruthError, match='missing eta_opposing_min, u_eol'):
        read_life(bag)
