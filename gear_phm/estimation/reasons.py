"""The estimator's counters by reason: what each means and its key in the status.

Every sample the estimator is given is used, rejected for one of :data:`SAMPLE_REASONS`, or
missing (a gap in the stamps); a message that gives no sample at all is rejected for one of
:data:`MESSAGE_REASONS`. Windows that give no measurement count by :data:`WINDOW_REASONS`,
and :data:`EVENTS` count what happened to the stream (they count no sample).
"""
from __future__ import annotations

import functools

#: Per-sample rejection reasons (each counts into "samples rejected").
SAMPLE_REASONS = ('nonfinite', 'zero_speed', 'deadband', 'impossible', 'backwards',
                  'future', 'duplicate_stamp')
#: Message-level reasons (a message that gives no sample at all).
MESSAGE_REASONS = ('missing_joint', 'short_arrays', 'truncated', 'bad_encoding', 'bad_message')
#: What each message-level reason means, for error messages (gear_phm.codec decides them).
MESSAGE_REASON_TEXT = {
    'missing_joint': 'without one of the joint names',
    'short_arrays': 'whose velocity or effort array is too short for the joints (not published?)',
    'truncated': 'truncated', 'bad_encoding': 'not in little-endian CDR',
    'bad_message': 'not a readable JointState'}
#: Window / measurement reasons and events (do not count as rejected samples).
WINDOW_REASONS = ('short_window', 'low_energy', 'wrong_energy_sign', 'out_of_domain', 'gated',
                  'not_identifiable')
EVENTS = ('timeout', 'stamp_reset', 'reinitialised')
#: Every counter, in the order of the estimator's ``counts``.
ALL_REASONS = SAMPLE_REASONS + MESSAGE_REASONS + WINDOW_REASONS + EVENTS


@functools.lru_cache(maxsize=16)
def count_keys(reasons: tuple[str, ...]) -> tuple[str, ...]:
    """Return the status keys of the counters ``reasons`` (windows, events, drops)."""
    return tuple(f'windows_rejected_{reason}' if reason in WINDOW_REASONS
                 else f'events_{reason}' if reason in EVENTS else f'dropped_{reason}'
                 for reason in reasons)
