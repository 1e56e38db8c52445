"""The summaries of an analysis: each drive's, the run's of many drives, and its refusals.

:func:`drive_summary` is one drive's :class:`~gear_phm.offline.summary.DriveSummary`;
:func:`combined` the :class:`~gear_phm.offline.summary.RunSummary` of many;
:func:`unmeasured` why an analysis with no filter update stops.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

from gear_phm import codec
from gear_phm.estimation.pipeline import MESSAGE_REASON_TEXT
from gear_phm.estimation.summary import EstimatorSummary
from gear_phm.interfaces import health_key_values
from gear_phm.offline.records import Analysis, EstimateHistory, HealthHistory
from gear_phm.offline.summary import (DriveSummary, HealthSummary, RunInfo, RunSummary,
                                      TrendSummary)
from gear_phm.run import DriveEstimator, DriveHealth
from gear_phm.status import LEVEL_NAMES


def drive_summary(estimator: DriveEstimator, health: DriveHealth, windows: int,
                  run: RunInfo) -> DriveSummary:
    """Return one drive's summary, complete (STALE for a run with no filter update).

    ``windows``: the measured windows; ``run``: the bags read.
    """
    summary = EstimatorSummary.from_dict(estimator.pipeline.summary())
    why = summary.unmeasured(windows)
    assessor = health.assessor
    latest = assessor.latest
    first_seen, dropped = dict(health.first_seen), dict(assessor.rejected)
    if latest is None:
        level = HealthSummary('none', first_seen, dropped)
    else:
        trend = assessor.predictor.trend
        level = HealthSummary(
            LEVEL_NAMES[latest.level], first_seen, dropped, latest.message,
            dict(health_key_values(latest)),
            TrendSummary(trend.model, trend.shape, assessor.u_eol))
    if why:     # the filter's prior is no estimate of the gearbox: no health level
        level = replace(level, level='STALE', message=f'no efficiency measurement: {why}')
    return DriveSummary(summary, run, windows, estimator.pipeline.config, level, why or None)


def run_info(bags: Sequence[Path], topic: str, messages: int, readers: Sequence[str],
             elapsed: float) -> RunInfo:
    """Return what was read: the bags, the topic, its messages, the readers and seconds."""
    return RunInfo(tuple(str(b) for b in bags), topic, messages, tuple(readers), elapsed)


def no_sample(estimator: DriveEstimator, topic: str, joints: tuple[str, str],
              names: Sequence[tuple[str, ...]] = ()) -> str:
    """Return the error of a drive that found no sample: what the messages held instead.

    ``joints``: the drive's motor and load joints; ``names``: the joint-name lists of the
    stream's first messages (a hint at the joints it has).
    """
    motor_joint, load_joint = joints
    found = '; '.join(f'{count} messages {MESSAGE_REASON_TEXT.get(reason, reason)}'
                      for reason, count in estimator.pipeline.counts.items() if count)
    hint = codec.joints_hint(names, motor_joint, load_joint)
    named = f'; {hint}' if hint else ''
    aside = estimator.names.aside
    return (f'no message of topic {topic} has joints {motor_joint!r} and {load_joint!r}{aside} '
            f'with a speed and a torque each: {found or "no message"}{named}')


def summary_of(analysis: Analysis) -> DriveSummary:
    """Return the summary of one drive's Analysis."""
    summary = analysis.summary
    assert isinstance(summary, DriveSummary), 'a run of one drive'
    return summary


def unmeasured(summaries: Sequence[DriveSummary], labels: Sequence[str]) -> str:
    """Return why no drive has a filter update ('' when one has).

    One drive (or every drive) without: the analysis stops. A bench's drive that did not
    move while others did has its summary say so and its level STALE, as the live node's
    for a drive without data. ``labels``: each drive's :attr:`~gear_phm.run.DriveNames.label`.
    """
    if not all(summary.no_measurement for summary in summaries):
        return ''
    which = ('no drive has one; ' if len(summaries) > 1 else '') + labels[0]
    return f'{which}{summaries[0].no_measurement}'


def combined(drives: Sequence[str], analyses: Sequence[Analysis], run: RunInfo,
             workers: int) -> Analysis:
    """Return the Analysis of many drives: the combined summary, each drive's Analysis.

    ``drives``: the drives' names, in the order of ``analyses``; ``run``: the bags read
    (its messages: the first drive's); ``workers``: the drives' worker processes.
    """
    summaries = {drive: summary_of(analysis) for drive, analysis in zip(drives, analyses)}
    summary = RunSummary(run, workers, summaries)
    return Analysis(EstimateHistory.of([]), HealthHistory.of([]), summary, (), {},
                    transmissions=dict(zip(drives, analyses)))
