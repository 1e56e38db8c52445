"""The estimator's /diagnostics status: level, message and keys from its summary values."""
from __future__ import annotations

from typing import Any

import numpy as np

from gear_phm.estimation import EstimatorConfig, EstimatorPipeline
from gear_phm.estimation.status import (compose_status, LossPeriod, mark_suffixes,
                                        NO_LOAD_STATUS_KEYS, NOT_IDENTIFIABLE,
                                        STATUS_SUMMARY_KEYS, StatusSnapshot)
from gear_phm.status import OK, WARN

CONFIG = EstimatorConfig(ratio=3.0)


def _summary(**changes: Any) -> dict[str, Any]:
    """Return a fresh pipeline's summary, as after some updates, with ``changes``."""
    values = EstimatorPipeline(CONFIG).summary()
    values.update(filter_updates=4, samples_seen=400)
    values.update(changes)
    return values


def _compose(summary: dict[str, Any], gated: int = 0, loss: float = 0.0,
             no_load: bool = False, received: int | None = None) -> Any:
    return compose_status(summary, 'gear_phm: estimator', gated=gated, loss=loss,
                          loss_warn=0.05, no_load_model=no_load, messages_received=received)


def test_an_estimating_filter_is_ok_with_its_keys_in_order() -> None:
    out = _compose(_summary(), received=401)
    assert (out.level, out.message, out.hardware_id) == (OK, 'estimating', 'gear_phm')
    keys = [key for key, _ in out.values]
    assert keys[:1 + len(STATUS_SUMMARY_KEYS)] == ['messages_received', *STATUS_SUMMARY_KEYS]
    assert keys[len(STATUS_SUMMARY_KEYS) + 1] == 'loss_ratio'
    assert dict(out.values)['messages_received'] == '401'
    assert 'dropped_deadband' in keys and 'windows_rejected_gated' in keys
    assert 'windows_rejected_not_identifiable' not in keys      # without the no-load model


def test_the_level_follows_the_filter_and_each_problem_adds_to_the_message() -> None:
    assert _compose(_summary(timed_out=True)).message.startswith('sensor timeout')
    assert _compose(_summary(filter_updates=0)).message == 'no efficiency measurement yet'
    gated = _compose(_summary(), gated=3)
    assert (gated.level, gated.message) == (WARN, '3 measurement(s) gated')
    ratio = _compose(_summary(ratio_check='wrong ratio'), gated=2)
    assert (ratio.level, ratio.message) == (WARN, '2 measurement(s) gated; wrong ratio')
    alone = _compose(_summary(over_unity='over unity'))
    assert (alone.level, alone.message) == (WARN, 'over unity')
    loss = _compose(_summary(), loss=0.25)
    assert (loss.level, loss.message) == (
        WARN, '25 % of samples missing over the last status period')
    drift = _compose(_summary(direction_offset_drift_z=-7.5, direction_offset=0.01))
    assert drift.level == OK and drift.message == (
        'estimating; direction offset drifted -7.5 sigma since it settled (now 0.01)')


def test_held_windows_of_an_unidentified_no_load_loss_are_said() -> None:
    held = _summary(filter_updates=0, counts={'not_identifiable': 3})
    assert (_compose(held).level, _compose(held).message) == (OK, NOT_IDENTIFIABLE)
    pipeline = EstimatorPipeline(CONFIG.replace(no_load_model=True))
    values = pipeline.summary()
    values.update(filter_updates=2, counts={'not_identifiable': 1}, no_load_identified=False)
    out = _compose(values, no_load=True)
    assert out.message == f'estimating; {NOT_IDENTIFIABLE}'
    keys = [key for key, _ in out.values]
    start = len(STATUS_SUMMARY_KEYS)
    assert keys[start:start + len(NO_LOAD_STATUS_KEYS)] == list(NO_LOAD_STATUS_KEYS)


def test_the_loss_period_is_the_share_missing_since_the_last_close() -> None:
    period = LossPeriod()
    assert period.close(90, 10) == 0.1 and period.ratio == 0.1
    assert period.close(90, 10) == 0.0                  # nothing since
    period.restart(200, 10)
    assert period.close(230, 20) == 0.25 and period.mark == (230, 20)


def test_a_snapshot_without_later_messages_counts_them_out() -> None:
    values = {'counts': {'missing_joint': 2, 'bad_message': 1}, 'samples_rejected': 3}
    snap = StatusSnapshot(5, 1, values)
    assert snap.without_messages([]) is snap
    less = snap.without_messages(['missing_joint', 'not_a_reason'])
    assert less.values == {'counts': {'missing_joint': 1, 'bad_message': 0},
                           'samples_rejected': 1}
    assert values['counts']['missing_joint'] == 2                   # the original stays


def test_mark_suffixes_count_the_samples_from_each_mark_on() -> None:
    deadband = np.array([1, 0, 1, 1, 0], dtype=bool)
    used = np.cumsum(~deadband)
    rejected = np.cumsum(deadband)
    got = mark_suffixes([1, 3], {'deadband': deadband}, used, rejected,
                        np.array([4]), np.array([], dtype=np.int64))
    assert got == [
        {'deadband': 2, 'samples_seen': 4, 'samples_used': 2, 'samples_rejected': 2,
         'timeout': 1, 'short_window': 0},
        {'deadband': 1, 'samples_seen': 2, 'samples_used': 1, 'samples_rejected': 1,
         'timeout': 1, 'short_window': 0}]
    assert mark_suffixes([], {}, used, rejected, np.array([]), np.array([])) == []
