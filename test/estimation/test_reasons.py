"""The estimator's counters by reason and their status keys."""
from __future__ import annotations

from gear_phm.estimation.reasons import (ALL_REASONS, count_keys, EVENTS, MESSAGE_REASON_TEXT,
                                         MESSAGE_REASONS, SAMPLE_REASONS, WINDOW_REASONS)


def test_every_reason_is_counted_once_and_every_message_reason_explained() -> None:
    assert len(set(ALL_REASONS)) == len(ALL_REASONS) == 21
    assert set(MESSAGE_REASON_TEXT) == set(MESSAGE_REASONS)


def test_the_status_key_names_the_kind_of_counter() -> None:
    assert count_keys(('deadband', 'gated', 'timeout', 'missing_joint')) == (
        'dropped_deadband', 'windows_rejected_gated', 'events_timeout',
        'dropped_missing_joint')
    assert len(count_keys(ALL_REASONS)) == len(SAMPLE_REASONS + MESSAGE_REASONS
                                               + WINDOW_REASONS + EVENTS)
