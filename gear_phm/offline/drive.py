"""One drive's run in ``gear-phm analyze``: the shared run of :mod:`gear_phm.run`, plus histories.

:class:`DriveRun` holds the drive's :class:`~gear_phm.run.DriveEstimator` and
:class:`~gear_phm.run.DriveHealth` (the code the live estimator and diagnostics nodes hold
per drive) and adds what the offline engine needs around them: the marks of each
/diagnostics tick inside a batch, the output columns of the batch, the histories of
:class:`~gear_phm.offline.histories.DriveHistories` and the drive's Analysis and summary.
"""
from __future__ import annotations

from collections.abc import Iterator, Sequence
import operator
from pathlib import Path

import numpy as np

from gear_phm import codec, interfaces
from gear_phm.estimation import FrictionEstimate, Measurement
from gear_phm.offline.histories import DriveHistories
from gear_phm.offline.options import AnalysisError, DriveSetup
from gear_phm.offline.parallel import Assessed, Column, Estimated, Finished, HealthHalf, Made
from gear_phm.offline.records import Analysis, EstimateHistory, HEALTH
from gear_phm.offline.results import drive_summary, no_sample, run_info
from gear_phm.prognostics import HealthState, ShapePrior
from gear_phm.run import DriveEstimator, DriveHealth, DriveNames
from gear_phm.status import StatusOut


class DriveRun:
    """One drive's run over a stream: estimate, assess, keep; then its Analysis."""

    def __init__(self, setup: DriveSetup, topic: str, history: int | None = None,
                 prior: ShapePrior | None = None) -> None:
        self.names: DriveNames = setup.names
        self.estimator_config = setup.estimator_config
        self.motor_joint, self.load_joint, self.topic = setup.motor_joint, setup.load_joint, topic
        self.kept = DriveHistories(history, setup.estimator_config.no_load_model)
        self.estimator = DriveEstimator(setup.estimator_config, setup.names,
                                        on_measurement=self._on_measurement)
        self.health = DriveHealth(setup.health_config, setup.names, prior)
        self.samples = 0
        #: the Analysis once the run finished (:meth:`finish`), for its plot
        self.analysis: Analysis | None = None

    @property
    def drive(self) -> str:
        """Return the drive's name in a ``transmissions`` list ('' for the single one)."""
        return self.names.drive

    def _on_measurement(self, measurement: Measurement, accepted: bool) -> None:
        stamp_ns = self.estimator.pipeline.stamp_ns(measurement.t)
        self.kept.measured_window(stamp_ns, measurement, accepted)

    def result(self, bags: list[Path], readers: list[str], elapsed: float,
               names: Sequence[tuple[str, ...]] = ()) -> Analysis:
        """Return the Analysis of the run once every bag is read (AnalysisError: no sample).

        ``names``: the joint-name lists of the stream's first messages, for that error.
        """
        if self.estimator.pipeline.samples_seen == 0:
            raise AnalysisError(no_sample(self.estimator, self.topic,
                                          (self.motor_joint, self.load_joint), names))
        self.kept.keep_measurements()
        run = run_info(bags, self.topic, self.samples, readers, elapsed)
        return self.kept.analysis(drive_summary(self.estimator, self.health,
                                                self.kept.measurements.count, run))

    def keep_truth(self, name: str, stamps: np.ndarray, values: np.ndarray) -> None:
        """Add ground-truth rows (stamps [ns], x, y, z) of topic ``name``."""
        self.kept.keep_truth(name, stamps, values, self.health.assessor.u_eol)

    def estimate(self, decoded: codec.JointBatch, messages: int, cuts: list[int],
                 write: bool) -> Estimated:
        """Run the estimator over one decoded batch; return its half of :meth:`advance`.

        ``cuts``: the batch's message index of each /diagnostics tick; ``write``: the
        outputs' columns are wanted (an output bag is written).
        """
        pipeline = self.estimator.pipeline
        index = decoded.message_index
        marks = np.searchsorted(index, cuts, side='left').tolist()
        rejected_at = [(int(np.searchsorted(index, position)), reason)
                       for position, reason in decoded.rejected_at]
        estimates, snapshots = pipeline.on_batch_marked(
            decoded.stamp_ns, decoded.motor_velocity, decoded.motor_effort,
            decoded.load_velocity, decoded.load_effort, marks, rejected_at)
        history = EstimateHistory.of(estimates)     # the columns kept and written
        self.kept.keep_estimates(history, estimates)
        statuses = tuple(self.estimator.status(self.samples + cut, snapshot)
                         for cut, snapshot in zip(cuts, snapshots))
        self.samples += messages
        ends = tuple(snapshot.estimates for snapshot in snapshots)
        stamps = history.stamp_ns
        return Estimated(
            estimates, ends, statuses,
            tuple(int(stamps[end - 1]) if end else -1 for end in ends),
            bool(np.all(np.diff(stamps) > 0)),
            tuple(self._topics(estimate_columns(estimates, history,
                                                pipeline.config.no_load_model)))
            if write else ())

    def assess(self, estimates: Sequence[FrictionEstimate], ends: Sequence[int],
               ticks: Sequence[int], write: bool) -> Assessed:
        """Run the assessor over a batch's estimates; return its half of :meth:`advance`.

        ``ends[i]``: the estimates before /diagnostics tick ``ticks[i]`` [ns].
        """
        assessor = self.health.assessor
        latest = [assessor.latest]              # the newest health state after i estimates
        states: list[HealthState] = []
        first_state = [0]                       # states[first_state[i]:] came after i
        for state in assessor.on_estimates(estimates):
            if state is not None:
                states.append(state)
            latest.append(state if state is not None else latest[-1])
            first_state.append(len(states))
        self.kept.keep_states(states)
        statuses = tuple(self.health.statuses_at(tick, latest[end])
                         for tick, end in zip(ticks, ends))
        columns = (tuple(self._topics(interfaces.vector3_columns(
            states, interfaces.HEALTH_LAYOUT))) if write and states else ())
        return Assessed(statuses, columns,
                        tuple(first_state[end] for end in ends) + (first_state[-1],))

    def advance(self, decoded: codec.JointBatch, messages: int, cuts: list[int],
                ticks: list[int], write: bool) -> Made:
        """Run one decoded batch; return what the stream writes of it (:class:`Made`).

        :meth:`estimate`, then :meth:`assess` of its estimates (which
        :class:`~gear_phm.offline.parallel.SplitDrive` runs in two processes).
        ``cuts``: the batch's message index of each /diagnostics tick ``ticks`` [ns];
        ``write``: the outputs' columns are wanted (an output bag is written).
        """
        estimated = self.estimate(decoded, messages, cuts, write)
        return estimated.made(self.assess(estimated.estimates, estimated.ends, ticks, write))

    def final_statuses(self, stamp_ns: int) -> tuple[StatusOut, ...]:
        """Return the statuses of the final /diagnostics array, at ``stamp_ns`` [ns]."""
        return (self.final_estimator(), *self.final_health(stamp_ns))

    def final_estimator(self) -> StatusOut:
        """Return the estimator's status of the final /diagnostics array."""
        return self.estimator.status(self.samples, None)

    def final_health(self, stamp_ns: int) -> tuple[StatusOut, ...]:
        """Return the health status of the final /diagnostics array (none before a state)."""
        return self.health.statuses_at(stamp_ns, self.health.assessor.latest)

    def health_half(self) -> HealthHalf:
        """Return what :meth:`assess` made of the run, for :meth:`take_health`."""
        return HealthHalf(self.health.assessor, self.kept.states, self.kept.envelopes[HEALTH],
                          self.health.first_seen)

    def take_health(self, half: HealthHalf) -> None:
        """Take the assessor and what it made from another process's copy of this run."""
        self.health.assessor, self.kept.states = half.assessor, half.states
        self.health.first_seen = half.first_seen
        self.kept.envelopes[HEALTH] = half.envelope

    def _topics(self, columns: list[Column]) -> Iterator[Column]:
        """Return output columns under this drive's topics."""
        topic = self.names.topic
        return ((topic(name), stamps, values) for name, stamps, values in columns)

    def finish(self, bags: list[Path], readers: list[str], elapsed: float,
               names: Sequence[tuple[str, ...]] = ()) -> Finished:
        """Return the run's Analysis and why its data contradict its parameters, or its error."""
        try:
            self.analysis = self.result(bags, readers, elapsed, names)
        except AnalysisError as exc:
            return Finished(None, str(exc), '')
        return Finished(self.analysis, '', self.estimator.refusal())

    def plot(self, path: Path, bags: list[Path]) -> None:
        """Draw the finished run's plot into ``path`` (:func:`.plot.plot_analysis`)."""
        from gear_phm.offline.plot import plot_analysis
        assert self.analysis is not None, 'plot after finish'
        plot_analysis(path, self.analysis, self.estimator_config.ratio, bags,
                      drive=self.names.drive)


#: The estimate fields written from the estimates themselves (not :class:`EstimateHistory`).
_FROM_ESTIMATES = ('measurement', 'measurement_variance', 'direction_offset',
                   'measurement_direction', 'measurement_bias', 'no_load_torque',
                   'no_load_sigma', 'total_efficiency')


def estimate_columns(estimates: Sequence[FrictionEstimate], history: EstimateHistory,
                     no_load: bool = False) -> list[Column]:
    """Return :func:`gear_phm.interfaces.vector3_columns` of estimates, from their ``history``.

    The estimator's outputs as ``(topic, stamps [ns], xyz)`` columns, in publishing order
    (:data:`gear_phm.interfaces.ESTIMATE_LAYOUT`; the diagnostics node's are
    ``vector3_columns(states, HEALTH_LAYOUT)``). The measurements and the direction offset,
    which the history does not hold, are read from the estimates; with ``no_load`` also
    :data:`gear_phm.interfaces.NO_LOAD_LAYOUT`.
    """
    row = operator.attrgetter(*_FROM_ESTIMATES)
    measured = np.array([row(e) for e in estimates], dtype=float).reshape(
        -1, len(_FROM_ESTIMATES))
    source = {'u_sigma': history.u_sigma,
              **{name: measured[:, i] for i, name in enumerate(_FROM_ESTIMATES)}}
    return [(topic, history.stamp_ns,
             np.column_stack([source[name] if name in source else getattr(history, name)
                              for name in names]).astype(float))
            for topic, names in interfaces.estimate_layout(no_load)]
