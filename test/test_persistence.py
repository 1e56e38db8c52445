"""State files: atomic round trip, bad files kept aside and reported, another transmission
refused unless reset."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from gear_phm.persistence import load_state, save_state, StateMismatch

IDENTITY = {'ratio': 30.0, 'motor_joint': 'motor', 'load_joint': 'load'}


def test_round_trip_and_missing_file(tmp_path: Path) -> None:
    path = tmp_path / 'sub' / 'gb.state.json'
    assert load_state(path, 'estimator', IDENTITY).state is None       # fresh start
    save_state(path, 'estimator', IDENTITY, {'x': [0.1, 2e-5], 'n': 3})
    loaded = load_state(path, 'estimator', IDENTITY)
    assert loaded.state == {'x': [0.1, 2e-5], 'n': 3} and loaded.problem == ''
    assert not (tmp_path / 'sub' / 'gb.state.json.tmp').exists()
    with pytest.raises(ValueError):
        save_state(path, 'estimator', IDENTITY, {'x': float('nan')})   # never written
    assert load_state(path, 'estimator', IDENTITY).state == {'x': [0.1, 2e-5], 'n': 3}


@pytest.mark.parametrize('content, reason', [
    (b'{"format": "gear_phm.state", "schema": 1, "ki', 'not valid JSON'),
    (b'\xff\xfe garbage', 'unreadable'),
    (b'[1, 2]', 'not a gear_phm.state file'),
    (json.dumps({'format': 'gear_phm.state', 'schema': 99, 'kind': 'estimator',
                 'identity': IDENTITY, 'state': {}}).encode(), 'schema 99'),
    (json.dumps({'format': 'gear_phm.state', 'schema': 1, 'kind': 'health',
                 'identity': IDENTITY, 'state': {}}).encode(), "holds 'health' state"),
])
def test_bad_file_is_kept_aside_and_reported(tmp_path: Path, content: bytes,
                                             reason: str) -> None:
    path = tmp_path / 'gb.state.json'
    path.write_bytes(content)
    loaded = load_state(path, 'estimator', IDENTITY)
    assert loaded.state is None and reason in loaded.problem
    assert not path.exists() and loaded.kept_as == tmp_path / 'gb.state.json.bad-1'
    assert loaded.kept_as.read_bytes() == content                      # nothing lost
    path.write_bytes(content)
    assert load_state(path, 'estimator', IDENTITY).kept_as.name == 'gb.state.json.bad-2'


def test_other_transmission_refused_unless_reset(tmp_path: Path) -> None:
    path = tmp_path / 'gb.state.json'
    save_state(path, 'estimator', IDENTITY, {'x': 1})
    other = {**IDENTITY, 'ratio': 3.0}
    with pytest.raises(StateMismatch, match=r'ratio 30\.0 \(file\) != 3\.0'):
        load_state(path, 'estimator', other)
    assert path.exists()                                              # untouched
    loaded = load_state(path, 'estimator', other, reset=True)
    assert loaded.state is None and 'reset on request' in loaded.problem
    assert loaded.kept_as is not None and loaded.kept_as.exists()
