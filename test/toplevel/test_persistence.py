"""Persisted wear state (no ROS).

The document, its atomic write and typed load errors, and the to_state/from_state round trips
of the estimator pipeline and the health assessor.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from gear_phm.estimation import EstimatorConfig, EstimatorPipeline
from gear_phm.persistence import (decode_float, encode_float, load_state, save_state, SCHEMA,
                                  StateCorrupt, StateForeign, StateMismatch)
from gear_phm.prognostics import HealthAssessor, HealthConfig
from helpers.plant import lever_plant

IDENTITY = {'ratio': 3.0, 'motor_joint': 'motor', 'load_joint': 'load'}
CONFIG = EstimatorConfig(ratio=3.0, motor_torque_noise=0.05, load_torque_noise=0.05,
                         motor_inertia=0.01)


def _wearing_run(seconds: float = 240.0):
    return lever_plant(7, seconds, lambda t: 0.05 + 0.3 * (t / 240.0) ** 2, rate=200.0)


def _columns(run, part: slice) -> list[np.ndarray]:
    return [np.asarray(c)[part] for c in (run.stamp_ns, run.motor_velocity, run.motor_effort,
                                          run.load_velocity, run.load_effort)]


def test_float_encoding_round_trips_non_finite_values() -> None:
    for value in (0.0, -1.5e-300, 1.0 / 3.0, math.inf, -math.inf):
        assert decode_float(json.loads(json.dumps(encode_float(value)))) == value
    assert math.isnan(decode_float(encode_float(math.nan)))
    with pytest.raises(ValueError):
        decode_float('1.0')
    with pytest.raises(ValueError):
        decode_float(True)


def test_save_is_atomic_and_load_round_trips(tmp_path: Path) -> None:
    path = tmp_path / 'wear.json'
    assert load_state(path, 'estimator', IDENTITY) is None          # missing: fresh
    save_state(path, 'estimator', IDENTITY, {'a': [1.0, 'inf']}, 123)
    save_state(path, 'estimator', IDENTITY, {'a': [2.0, 'nan']}, 456)
    assert sorted(p.name for p in tmp_path.iterdir()) == ['wear.json']   # no temp left over
    doc = json.loads(path.read_text())
    assert doc['schema'] == SCHEMA and doc['kind'] == 'estimator'
    assert doc['saved_stamp_ns'] == 456 and doc['identity'] == IDENTITY
    assert load_state(path, 'estimator', IDENTITY) == {'a': [2.0, 'nan']}
    with pytest.raises(ValueError):                     # a bare NaN is not JSON
        save_state(path, 'estimator', IDENTITY, {'a': math.nan})
    assert load_state(path, 'estimator', IDENTITY) == {'a': [2.0, 'nan']}   # old file intact


@pytest.mark.parametrize('content, reason', [
    ('{"schema": 1, "kind": "estimator", "ident', 'not JSON'),
    (json.dumps({'schema': 99, 'kind': 'estimator', 'identity': IDENTITY, 'state': {}}),
     'schema 99'),
    (json.dumps({'schema': SCHEMA, 'kind': 'diagnostics', 'identity': IDENTITY, 'state': {}}),
     "kind 'diagnostics'"),
])
def test_corrupt_file_is_set_aside_with_its_reason(tmp_path: Path, content: str,
                                                   reason: str) -> None:
    path = tmp_path / 'wear.json'
    path.write_text(content)
    with pytest.raises(StateCorrupt, match=reason) as caught:
        load_state(path, 'estimator', IDENTITY)
    assert not path.exists()
    moved = caught.value.moved_to
    assert moved is not None and moved.name.startswith('wear.json.bad-')
    assert moved.read_text() == content
    assert str(moved) in str(caught.value)
    assert load_state(path, 'estimator', IDENTITY) is None          # then: fresh


@pytest.mark.parametrize('content', ['[1, 2]', 'ratio: 30.0\n', 'my notes', b'\xff\xfe\x00'])
def test_a_file_that_is_no_state_file_is_refused_and_left_as_it_is(
        tmp_path: Path, content: str | bytes) -> None:
    """A state_file pointing at a user's file moved it aside and wrote over its name."""
    path = tmp_path / 'wear.json'
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    with pytest.raises(StateForeign, match='it is left as it is'):
        load_state(path, 'estimator', IDENTITY)
    assert list(tmp_path.iterdir()) == [path]
    assert path.read_bytes() == (content if isinstance(content, bytes) else content.encode())


def test_a_folder_is_refused_and_left_as_it_is(tmp_path: Path) -> None:
    """state_file:=/tmp moved the whole of /tmp aside (an adversarial probe did that)."""
    folder = tmp_path / 'state'
    folder.mkdir()
    (folder / 'precious.txt').write_text('keep')
    with pytest.raises(StateForeign, match='is a folder or not a regular file'):
        load_state(folder, 'estimator', IDENTITY)
    assert list(tmp_path.iterdir()) == [folder]
    assert (folder / 'precious.txt').read_text() == 'keep'


def test_identity_mismatch_refused_unless_reset(tmp_path: Path) -> None:
    path = tmp_path / 'wear.json'
    save_state(path, 'estimator', IDENTITY, {'x': 1})
    other = dict(IDENTITY, ratio=5.0)
    with pytest.raises(StateMismatch, match=r'ratio 3\.0 in the file, 5\.0 now'):
        load_state(path, 'estimator', other)
    with pytest.raises(StateMismatch, match='motor_joint'):
        load_state(path, 'estimator', dict(IDENTITY, motor_joint='m2'))
    assert path.exists()                                            # refused: file kept
    assert load_state(path, 'estimator', dict(IDENTITY, ratio=3.0 * (1 + 1e-12))) == {'x': 1}
    assert load_state(path, 'estimator', other, reset=True) is None
    assert not path.exists()
    assert [p.name.startswith('wear.json.old-') for p in tmp_path.iterdir()] == [True]


def test_pipeline_restored_from_json_continues_as_if_never_stopped() -> None:
    run = _wearing_run()
    cut = run.stamp_ns.size // 2
    whole = EstimatorPipeline(CONFIG)
    whole.on_batch(*_columns(run, slice(None)))
    first = EstimatorPipeline(CONFIG)
    first.on_batch(*_columns(run, slice(None, cut)))
    text = json.dumps(first.to_state(), allow_nan=False)
    second = EstimatorPipeline(CONFIG)
    second.from_state(json.loads(text))
    assert json.dumps(second.to_state(), allow_nan=False) == text      # exact round trip
    np.testing.assert_array_equal(second.filter.P, first.filter.P)
    second.on_batch(*_columns(run, slice(cut, None)))
    a, b = whole.summary(), second.summary()
    # the open energy window is in the state: nothing is lost, the same windows and updates
    assert [b[k] for k in ('samples_seen', 'samples_used', 'filter_updates')] == \
        [a[k] for k in ('samples_seen', 'samples_used', 'filter_updates')]
    assert [b[k] for k in ('u', 'sigma_u', 'process_noise', 'operating_time_s')] == \
        pytest.approx([a[k] for k in ('u', 'sigma_u', 'process_noise', 'operating_time_s')],
                      rel=1e-9)
    fresh = EstimatorPipeline(CONFIG)
    fresh.on_batch(*_columns(run, slice(cut, None)))
    assert abs(fresh.summary()['u'] - a['u']) > 3 * abs(b['u'] - a['u'])  # the state matters


def test_five_restarts_mid_window_lose_no_window() -> None:
    run = _wearing_run()
    n = run.stamp_ns.size
    whole = EstimatorPipeline(CONFIG)
    whole.on_batch(*_columns(run, slice(None)))
    cuts = [0, *(n * k // 5 + 37 * k for k in range(1, 5)), n]
    pipeline, opened = EstimatorPipeline(CONFIG), 0
    for start, end in zip(cuts[:-1], cuts[1:]):
        pipeline.on_batch(*_columns(run, slice(start, end)))
        state = json.loads(json.dumps(pipeline.to_state(), allow_nan=False))
        opened += state['window']['open'] is not None
        pipeline = EstimatorPipeline(CONFIG)
        pipeline.from_state(state)
    assert opened >= 3                  # most cuts fall inside a window
    a, b = whole.summary(), pipeline.summary()
    assert b['filter_updates'] == a['filter_updates']
    assert (b['u'], b['sigma_u']) == pytest.approx((a['u'], a['sigma_u']), rel=1e-9)


def test_pipeline_refuses_a_malformed_state_unchanged() -> None:
    pipeline = EstimatorPipeline(CONFIG)
    state = pipeline.to_state()
    state['filter']['P'] = [1.0, 0.0, 0.0]
    with pytest.raises(ValueError):
        pipeline.from_state(state)
    with pytest.raises(KeyError):
        pipeline.from_state({'filter': pipeline.to_state()['filter']})
    state = pipeline.to_state()
    state['window'] = {'open': [1, 0.0, 0.1], 'last': None, 'last_usable': True}
    with pytest.raises(ValueError):
        pipeline.from_state(state)
    assert pipeline.to_state() == EstimatorPipeline(CONFIG).to_state()


def test_assessor_restored_from_json_gives_identical_health() -> None:
    run = _wearing_run()
    estimates = EstimatorPipeline(CONFIG).on_batch(*_columns(run, slice(None)))
    assert len(estimates) > 100
    config = HealthConfig(ratio=3.0, eta_opposing_min=0.5, level_dwell=1.0)
    whole = HealthAssessor(config)
    expected = [whole.on_estimate(e) for e in estimates]
    assert math.isfinite(expected[-1].rul.median)           # the trend was detected
    cut = len(estimates) * 3 // 5
    first = HealthAssessor(config)
    for estimate in estimates[:cut]:
        first.on_estimate(estimate)
    text = json.dumps(first.to_state(), allow_nan=False)
    second = HealthAssessor(config)
    second.from_state(json.loads(text))
    assert json.dumps(second.to_state(), allow_nan=False) == text
    assert second.latest == first.latest
    assert [second.on_estimate(e) for e in estimates[cut:]] == expected[cut:]
    assert second.predictor.fits == whole.predictor.fits
