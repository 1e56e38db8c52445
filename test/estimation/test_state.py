"""PipelineState: the estimator's persisted state, its layout and older layouts."""
from __future__ import annotations

import json
import math

import pytest

from gear_phm.estimation.reasons import ALL_REASONS
from gear_phm.estimation.state import PipelineState

#: A state as the estimator writes it (the parts' own states abridged).
STATE = {
    'filter': {'x': [0.1, 0.0]}, 'counts': {'deadband': 7, 'gated': 1},
    'samples_seen': 120, 'samples_used': 100, 'samples_rejected': 8, 'samples_missing': 12,
    'windows_used': 4, 'operating_time': 31.5, 'max_stamp': 5_000_000_000,
    'last_group_stamp': 4_990_000_000, 'origin_ns': 1_000_000, 'grid': 49, 'last_code': 1,
    'last_eta': 'nan', 'last_stamp': 5_000_000_000, 'carry': [0.1, 1e-4, 30.0, 0.5, 0.002],
    'inertia': {'blocks': []}, 'window': {'open': None}, 'no_load': {'n': 0},
    'no_load_band': {'band': []}}


def test_the_layout_round_trips_through_json_exactly() -> None:
    state = PipelineState.from_json(json.loads(json.dumps(STATE)), ALL_REASONS)
    assert state.counts == {**dict.fromkeys(ALL_REASONS, 0), 'deadband': 7, 'gated': 1}
    assert math.isnan(state.last_eta) and state.carry == (0.1, 1e-4, 30.0, 0.5, 0.002)
    assert state.kalman == {'x': [0.1, 0.0]}
    written = state.to_json()
    assert list(written) == list(STATE)                     # the keys in the file's order
    assert written == {**STATE, 'counts': state.counts}


def test_an_older_state_without_the_later_parts_still_loads() -> None:
    old = {key: value for key, value in STATE.items()
           if key not in ('carry', 'inertia', 'window', 'no_load', 'no_load_band')}
    state = PipelineState.from_json(old, ('deadband', 'timeout'))
    assert state.counts == {'deadband': 7, 'timeout': 0}     # only the counters kept
    assert (state.carry, state.inertia, state.window, state.no_load) == (None,) * 4
    short = PipelineState.from_json({**old, 'carry': [0.1, 1e-4, 30.0]}, ALL_REASONS)
    assert short.carry == (0.1, 1e-4, 30.0, 0.0, 0.0)       # h and bias came later


@pytest.mark.parametrize(('key', 'value', 'error'), [
    ('samples_seen', None, TypeError), ('samples_seen', 'many', ValueError),
    ('operating_time', [], ValueError), ('counts', [], TypeError),
    ('filter', 3, TypeError), ('carry', 'x', TypeError), ('origin_ns', {}, TypeError)])
def test_a_malformed_state_raises_what_the_loaders_catch(key: str, value: object,
                                                         error: type[Exception]) -> None:
    with pytest.raises(error):
        PipelineState.from_json({**STATE, key: value}, ALL_REASONS)


def test_a_state_without_a_counter_of_the_first_layout_raises_key_error() -> None:
    with pytest.raises(KeyError):
        PipelineState.from_json({k: v for k, v in STATE.items() if k != 'windows_used'},
                                ALL_REASONS)
