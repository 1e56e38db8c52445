"""The estimator's ``/diagnostics`` status: its level, message and key values, free of ROS.

:func:`compose_status` turns the estimator's summary values (``EstimatorPipeline.summary``, or
a :class:`StatusSnapshot` of them as of a mark inside a batch) into a :class:`StatusOut`.
:class:`LossPeriod` measures the share of samples missing over each status period, and
:func:`mark_suffixes` the counters of a batch's samples after each mark, which a snapshot
taken at the batch's end leaves out.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
import itertools
import math
import operator
from typing import Any

import numpy as np

from gear_phm.estimation.kalman import OFFSET_DRIFT_Z
from gear_phm.estimation.reasons import count_keys
from gear_phm.estimation.summary import stalled_stamps
from gear_phm.status import format_values, OK, StatusOut, WARN

#: The estimator's summary values (``EstimatorPipeline.summary``): numbers, flags, texts and
#: the counters by reason, read by key.
SummaryValues = dict[str, Any]
#: The summary values of the estimator's status, in its order (after messages_received).
STATUS_SUMMARY_KEYS = (
    'u', 'sigma_u', 'eta_opposing', 'eta_aiding', 'filter_updates', 'samples_used',
    'samples_rejected', 'samples_missing', 'sample_period_s', 'process_noise',
    'mismatch_sigma_opposing', 'mismatch_sigma_aiding', 'direction_offset',
    'direction_offset_sigma', 'direction_offset_drift_z', 'motor_inertia', 'operating_time_s')
_STATUS_SUMMARY = operator.itemgetter(*STATUS_SUMMARY_KEYS)
#: With ``no_load_model``, the status also holds these summary values, after the others.
NO_LOAD_STATUS_KEYS = ('no_load_torque', 'no_load_torque_sigma', 'no_load_coulomb',
                       'no_load_viscous', 'no_load_offset', 'no_load_identified',
                       'total_efficiency')
#: The status message while windows are held because the no-load loss is not identified.
NOT_IDENTIFIABLE = ('no-load loss not identifiable (the load does not vary enough to tell it '
                    'from friction): u held')


@dataclass(frozen=True)
class StatusSnapshot:
    """What ``EstimatorPipeline.status`` reports, as of a mark inside a batch.

    ``position``: the mark (a position in the arrays given to
    ``EstimatorPipeline.on_batch_marked``); ``estimates``: how many of that call's estimates
    came from samples before it; ``values``: ``EstimatorPipeline.summary`` as of the mark,
    plus ``consecutive_gated``.
    """

    position: int
    estimates: int
    values: SummaryValues

    def without_messages(self, reasons: Sequence[str]) -> StatusSnapshot:
        """Return this snapshot without the rejected messages ``reasons`` (counted later)."""
        if not reasons:
            return self
        values = dict(self.values)
        counts = dict(values['counts'])
        for reason in reasons:
            counts[reason if reason in counts else 'bad_message'] -= 1
        values['counts'] = counts
        values['samples_rejected'] -= len(reasons)
        return replace(self, values=values)


class LossPeriod:
    """The share of samples missing over the last status period (``ratio``, 0 before)."""

    def __init__(self) -> None:
        self.mark = (0, 0)          # samples seen, samples missing at the last close
        self.ratio = 0.0

    def restart(self, seen: int, missing: int) -> None:
        """Start the next period from these counts of samples seen and missing."""
        self.mark = (seen, missing)

    def close(self, seen: int, missing: int) -> float:
        """Return the share of samples missing since the previous call (one status period).

        Given the counts of samples seen and missing at the end of that period.
        """
        d_seen, d_missing = seen - self.mark[0], missing - self.mark[1]
        self.mark = (seen, missing)
        total = d_seen + d_missing
        self.ratio = d_missing / total if total > 0 else 0.0
        return self.ratio


def _level_and_message(summary: SummaryValues, gated: int) -> tuple[int, str]:
    """Return the status level and message the filter's progress gives."""
    counts = summary['counts']
    if summary['timed_out']:
        level, message = WARN, 'sensor timeout: no sample for sensor_timeout'
    elif summary['filter_updates'] == 0 and counts.get('not_identifiable', 0):
        level, message = OK, NOT_IDENTIFIABLE
    elif summary['filter_updates'] == 0:
        stalled = stalled_stamps(summary['samples_seen'], summary['filter_updates'],
                                 counts.get('duplicate_stamp', 0))
        level, message = WARN, ('no efficiency measurement yet'
                                + (f': {stalled}' if stalled else ''))
    elif gated:
        level, message = WARN, f'{gated} measurement(s) gated'
    else:
        level, message = OK, 'estimating'
    if level == OK and summary['filter_updates'] and summary.get('no_load_identified') \
            is False and counts.get('not_identifiable', 0):
        message += f'; {NOT_IDENTIFIABLE}'
    drift = summary.get('direction_offset_drift_z', math.nan)
    if abs(drift) > OFFSET_DRIFT_Z:     # a report of its own, not a level (not wear)
        message += (f'; direction offset drifted {drift:+.3g} sigma since it settled '
                    f'(now {summary["direction_offset"]:.4g})')
    return level, message


def compose_status(summary: SummaryValues, name: str, *, gated: int, loss: float,
                   loss_warn: float, no_load_model: bool,
                   messages_received: int | None = None) -> StatusOut:
    """Return the DiagnosticStatus record: level, message, estimate and counters by reason.

    ``summary``: the estimator's summary values; ``gated``: its measurements gated in a row;
    ``loss``: the share of samples missing over the status period (WARN above
    ``loss_warn``); ``no_load_model``: whether the status holds the no-load values.
    """
    level, message = _level_and_message(summary, gated)
    for problem in (summary.get('reversed_torque', ''), summary.get('ratio_check', ''),
                    summary.get('over_unity', ''), summary.get('no_load_band', '')):
        if problem:
            message = problem if level == OK else f'{message}; {problem}'
            level = WARN
    if loss > loss_warn:
        text = f'{100.0 * loss:.3g} % of samples missing over the last status period'
        message = text if level == OK else f'{message}; {text}'
        level = WARN
    counts = sorted(summary['counts'].items())
    no_load = NO_LOAD_STATUS_KEYS if no_load_model else ()
    keys = ((('messages_received',) if messages_received is not None else ())
            + STATUS_SUMMARY_KEYS + no_load + ('loss_ratio',) + count_keys(tuple(
                reason for reason, _ in counts)))
    values = itertools.chain(
        (messages_received,) if messages_received is not None else (),
        _STATUS_SUMMARY(summary), (summary[key] for key in no_load), (loss,),
        (count for _, count in counts))
    return StatusOut(level, name, message, 'gear_phm', tuple(zip(keys, format_values(values))))


def mark_suffixes(ks: list[int], masks: Mapping[str, np.ndarray], used_cum: np.ndarray,
                  rejected_cum: np.ndarray, gap_at: np.ndarray, short_at: np.ndarray
                  ) -> list[dict[str, int]]:
    """Return the counters of the samples from each ``ks`` (0 < k < n) on, all marks at once.

    ``masks``: per-sample rejections by reason; ``used_cum``, ``rejected_cum``: the
    cumulative counts; ``gap_at``, ``short_at``: the samples with a timeout, a short window.
    """
    if not ks:
        return []
    at = np.array(ks, dtype=np.int64)
    n = used_cum.size
    columns = {key: mask.sum() - np.cumsum(mask)[at - 1] for key, mask in masks.items()}
    columns.update({
        'samples_seen': n - at, 'samples_used': used_cum[-1] - used_cum[at - 1],
        'samples_rejected': rejected_cum[-1] - rejected_cum[at - 1],
        'timeout': np.count_nonzero(gap_at[None, :] >= at[:, None], axis=1),
        'short_window': np.count_nonzero(short_at[None, :] >= at[:, None], axis=1)})
    lists = {key: column.tolist() for key, column in columns.items()}
    return [{key: values[i] for key, values in lists.items()} for i in range(at.size)]
