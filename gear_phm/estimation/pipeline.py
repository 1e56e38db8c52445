"""Samples -> energy windows -> Kalman filter -> :class:`FrictionEstimate` records, free of ROS.

:class:`EstimatorPipeline` is the whole estimator: the live node feeds it the samples it
buffered between timer ticks (:meth:`on_samples`), ``gear-phm analyze`` large decoded batches
(:meth:`on_batch`). Both get the same :class:`FrictionEstimate` records back (at most one per
stamp), which their transport turns into messages. Results do not depend on how the samples
are split into batches. Time comes from the sample stamps only. The Kalman filter runs on
operating time (the time with motion, accumulated from the stamps, see ``operating_time``):
wear, and so the rate du/dt [1/s of operation], accrues only while the gearbox moves, not
across the idle gap between two recordings. Energy windows run on stamp time.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
import math

import numpy as np

from gear_phm.estimation.config import EstimatorConfig, PARAMETERS
from gear_phm.estimation.fusion import WindowFusion
from gear_phm.estimation.grouping import OnePerStamp
from gear_phm.estimation.inertia import InertiaLearner
from gear_phm.estimation.kalman import FrictionFilter
from gear_phm.estimation.no_load import NoLoadBand, NoLoadLearner
from gear_phm.estimation.powerflow import classify
from gear_phm.estimation.predictions import BatchCounts, predicted_estimates, PredictionBase
from gear_phm.estimation.quality import DataQuality
from gear_phm.estimation.reasons import (ALL_REASONS, EVENTS, MESSAGE_REASON_TEXT,
                                         MESSAGE_REASONS, SAMPLE_REASONS, WINDOW_REASONS)
from gear_phm.estimation.records import FrictionEstimate, JointSample
from gear_phm.estimation.stamps import Segment, StampScreen
from gear_phm.estimation.state import PipelineState, StateDict
from gear_phm.estimation.status import (compose_status, LossPeriod, mark_suffixes,
                                        NOT_IDENTIFIABLE, StatusSnapshot, SummaryValues)
from gear_phm.estimation.timeline import Timeline
from gear_phm.estimation.windows import EnergyIntegrator, Measurement, Window
from gear_phm.models.lever import efficiencies
from gear_phm.models.power_flow import IMPOSSIBLE
from gear_phm.parameters import refuse_read_only_changes
from gear_phm.status import StatusOut

#: Names other modules take from here (they live in the modules named in the docstring).
__all__ = ['EVENTS', 'EstimatorPipeline', 'MESSAGE_REASONS',
           'MESSAGE_REASON_TEXT', 'NOT_IDENTIFIABLE', 'SAMPLE_REASONS', 'StatusSnapshot',
           'WINDOW_REASONS']


def _ns(seconds: float) -> int:
    return int(round(seconds * 1e9))


@dataclass(frozen=True)
class _Samples:
    """A batch's samples by power flow and by rejection reason (:meth:`_classify`).

    The shaft powers ``p_m``, ``p_l`` [W], the power-flow ``code`` (0 for non-finite values)
    and masks: ``finite`` values, ``ok`` (timely and finite), and of those the rejected
    (``zero_speed``, ``deadband``, ``impossible``) and the ``usable``; ``nonfinite``: timely
    samples that are not finite.
    """

    p_m: np.ndarray
    p_l: np.ndarray
    code: np.ndarray
    finite: np.ndarray
    nonfinite: np.ndarray
    ok: np.ndarray
    zero_speed: np.ndarray
    deadband: np.ndarray
    impossible: np.ndarray
    usable: np.ndarray


#: A mark still to snapshot in :meth:`EstimatorPipeline._emit`: (mark, the local position k
#: of its sample, the counters of the samples from k on).
_Pending = tuple[int, int, dict[str, int]]


class EstimatorPipeline:
    """Friction estimator over a stream of samples; see the module docstring.

    ``on_measurement`` (optional) is called with each :class:`Measurement` and whether the
    filter accepted it (used by ``gear-phm analyze`` for its plot).
    """

    def __init__(self, config: EstimatorConfig,
                 on_measurement: Callable[[Measurement, bool], None] | None = None) -> None:
        self.config = config
        self.on_measurement = on_measurement
        self.counts: dict[str, int] = dict.fromkeys(ALL_REASONS, 0)
        self.samples_seen = 0
        self.samples_used = 0
        self.samples_rejected = 0
        self.samples_missing = 0
        self.windows_used = 0
        #: the evidence of a reversed sign, wrong units or a wrong ratio (not persisted)
        self.quality = DataQuality()
        #: stamp time, the publish grid and operating time (the filter's time axis)
        self.time = Timeline()
        #: the newest estimate's stamp, and a measurement carried to the next estimate
        self.grouping = OnePerStamp()
        self.screen = StampScreen(config.stamp_run, _ns(config.sensor_timeout),
                                  _ns(config.period_hold), config.backwards_policy == 'reset')
        #: Samples held by the screen for a run: (stamps, [4 value arrays]).
        self._held: tuple[np.ndarray, list[np.ndarray]] | None = None
        #: the share of samples missing over the last status period
        self.loss = LossPeriod()
        self._reset_estimator()

    @property
    def loss_ratio(self) -> float:
        """Return the share of samples missing over the last status period (:meth:`status`)."""
        return self.loss.ratio

    # --- state -------------------------------------------------------------------------------
    def _reset_estimator(self) -> None:
        c = self.config
        self._use(WindowFusion(c))
        self.integrator = EnergyIntegrator(
            c.window, c.sensor_timeout, c.motor_inertia, c.load_inertia,
            (c.motor_torque_noise, c.motor_speed_noise, c.load_torque_noise,
             c.load_speed_noise), min_duration=c.min_window)
        self.time.restart()
        self._last_code = 0
        self.grouping.carry = None

    def _use(self, fusion: WindowFusion) -> None:
        """Take the filter, the learned inertia and no-load loss of ``fusion`` as its own.

        ``filter``, ``inertia``, ``no_load`` and ``no_load_band`` are its parts, by name.
        """
        self.fusion = fusion
        self.filter: FrictionFilter = fusion.filter
        self.inertia: InertiaLearner = fusion.inertia
        self.no_load: NoLoadLearner = fusion.no_load
        self.no_load_band: NoLoadBand = fusion.no_load_band

    def reconfigure(self, config: EstimatorConfig) -> None:
        """Apply new settings and keep what was learned.

        The filter (u, its rate and direction offset with their covariance, the learned
        process noise and model mismatch), the learned inertia, the open energy window, the
        counters and the time axes go on as they were: :meth:`to_state`, rebuilt with
        ``config``, :meth:`from_state`. The new settings take effect from the next sample:
        thresholds and the gate, the noise figures of the windows that close from now on,
        window lengths, the prior (for a later :meth:`reset`), the adaptation and the stamp
        screen; a new ``publish_rate`` continues its grid from the newest sample; a new
        ``process_noise`` replaces the learned one (the adaptation goes on from it). Raises
        ValueError naming a structural (read-only) setting that differs: the learned state
        has no meaning under another ratio, effort sign or motor_inertia (:meth:`reset`
        and a new pipeline instead).
        """
        old = self.config
        refuse_read_only_changes(PARAMETERS, old.as_dict(), config.as_dict(),
                                 'start a new pipeline')
        state = self.to_state()
        kept = (self.loss.mark, self.time.timed_out)
        self.config = config
        self._reset_estimator()
        self.from_state(state)
        self.loss.mark, self.time.timed_out = kept
        if config.process_noise != old.process_noise:
            self.filter.process_noise = self.filter.q_test = config.process_noise
        if config.publish_rate != old.publish_rate:
            self.time.regrid(config.publish_rate)
        self.screen.configure(config.stamp_run, _ns(config.sensor_timeout),
                              _ns(config.period_hold), config.backwards_policy == 'reset')

    def reset(self) -> None:
        """Forget what was learned, on purpose (a new gearbox on the rig).

        The filter goes back to the prior, and the learned inertia, the open window and the
        time origin start afresh, as after a run of stamps far back; the counters stay.
        """
        self._reset_estimator()
        self.time.max_stamp = None

    def to_state(self) -> StateDict:
        """Return what a restart needs to continue as if it never stopped (JSON-safe).

        The filter, counters, operating time and stamp origin (see :mod:`gear_phm.persistence`;
        the layout: :mod:`gear_phm.estimation.state`).

        Kept too: the open energy window and the previous sample, so that a restart loses no
        sample. Not kept: the stamp screen's learnt period (relearnt from the next samples).
        """
        time = self.time
        return PipelineState(
            dict(self.counts), self.samples_seen, self.samples_used, self.samples_rejected,
            self.samples_missing, self.windows_used, time.operating_time, time.max_stamp,
            self.grouping.last_stamp, time.origin_ns, time.grid, self._last_code,
            self.fusion.last_eta, time.last_stamp, self.grouping.carry, self.filter.to_state(),
            self.inertia.to_state(), self.integrator.to_state(), self.no_load.to_state(),
            self.no_load_band.to_state()).to_json()

    def from_state(self, state: Mapping[str, object]) -> None:
        """Restore :meth:`to_state` into a pipeline built with the same configuration.

        KeyError/ValueError/TypeError on a malformed dict (the pipeline is then unchanged).
        """
        fresh = EstimatorPipeline(self.config)      # validate everything before changing self
        restored = PipelineState.from_json(state, tuple(self.counts))
        fresh.filter.from_state(restored.kalman)
        if restored.inertia is not None:    # added within schema 2
            fresh.inertia.from_state(restored.inertia)
        if restored.window is not None:     # added within schema 2
            fresh.integrator.from_state(restored.window)
        if restored.no_load is not None and restored.no_load_band is not None:
            fresh.no_load.from_state(restored.no_load)
            fresh.no_load_band.from_state(restored.no_load_band)
        self._use(fresh.fusion)
        self.fusion.last_eta = restored.last_eta
        self.integrator = fresh.integrator
        self.counts = dict(restored.counts)
        self.grouping.carry = restored.carry
        self.grouping.last_stamp = restored.last_group_stamp
        (self.samples_seen, self.samples_used, self.samples_rejected, self.samples_missing,
         self.windows_used, self._last_code) = (
            restored.samples_seen, restored.samples_used, restored.samples_rejected,
            restored.samples_missing, restored.windows_used, restored.last_code)
        time = self.time
        (time.operating_time, time.max_stamp, time.origin_ns, time.grid, time.last_stamp) = (
            restored.operating_time, restored.max_stamp, restored.origin_ns, restored.grid,
            restored.last_stamp)
        self.loss.restart(self.samples_seen, self.samples_missing)

    def stamp_ns(self, t: float) -> int:
        """Return the stamp [ns] of pipeline time ``t`` [s] (times count from the first sample).

        Raises ValueError before the first sample.
        """
        return self.time.stamp_ns(t)

    @property
    def operating_time(self) -> float:
        """Return the time with motion so far [s], the filter's time axis (the module doc)."""
        return self.time.operating_time

    @property
    def timed_out(self) -> bool:
        """Return whether no sample came for ``sensor_timeout`` (:meth:`on_silence`)."""
        return self.time.timed_out

    # --- inputs ------------------------------------------------------------------------------
    def reject_message(self, reason: str, count: int = 1) -> None:
        """Count messages that gave no sample (e.g. ``missing_joint``)."""
        key = reason if reason in self.counts else 'bad_message'
        self.counts[key] += count
        self.samples_rejected += count

    def on_samples(self, samples: list[JointSample]) -> list[FrictionEstimate]:
        """Process a buffer of samples (e.g. collected by the live node between timer ticks)."""
        if not samples:
            return []
        columns = np.array([(s.motor_velocity, s.motor_effort, s.load_velocity, s.load_effort)
                            for s in samples], dtype=float).reshape(-1, 4)
        stamps = np.array([s.stamp_ns for s in samples], dtype=np.int64)
        return self.on_batch(stamps, *columns.T)

    def on_batch(self, stamp_ns: np.ndarray, motor_velocity: np.ndarray,
                 motor_effort: np.ndarray, load_velocity: np.ndarray,
                 load_effort: np.ndarray) -> list[FrictionEstimate]:
        """Process samples in arrival order: stamps [ns] (int64), speeds [rad/s], torques [N m]."""
        return self.on_batch_marked(stamp_ns, motor_velocity, motor_effort, load_velocity,
                                    load_effort)[0]

    def on_batch_marked(self, stamp_ns: np.ndarray, motor_velocity: np.ndarray,
                        motor_effort: np.ndarray, load_velocity: np.ndarray,
                        load_effort: np.ndarray, marks: Sequence[int] = (),
                        rejected_at: Sequence[tuple[int, str]] = ()
                        ) -> tuple[list[FrictionEstimate], list[StatusSnapshot]]:
        """:meth:`on_batch`, plus what :meth:`status` would report at ``marks``.

        ``marks`` are ascending positions 0..n in the arrays. The :class:`StatusSnapshot` of a
        mark holds the state after the samples before that position only, without cutting the
        batch (``gear-phm analyze`` stamps its 1 Hz /diagnostics so: cutting a 100 Hz bag at
        every tick cost more than the estimator). ``rejected_at`` are messages that gave no
        sample, as (position of the next sample, reason), counted as :meth:`reject_message`
        does. Drops by the stamp screen (duplicates, strays) count from the next accepted
        sample on. Raises ValueError for arrays of different shapes or marks out of order.
        """
        stamps, arrays = self._checked_batch(
            stamp_ns, (motor_velocity, motor_effort, load_velocity, load_effort), marks)
        for _, reason in rejected_at:
            self.reject_message(reason)
        held = 0
        if self._held is not None:          # samples waiting for a run go first
            held_stamps, held_arrays = self._held
            held = held_stamps.size
            self._held = None
            stamps = np.concatenate((held_stamps, stamps))
            arrays = [np.concatenate((h, a)) for h, a in zip(held_arrays, arrays)]
        screened = self.screen.screen(stamps)
        outputs, snapshots = self._run_steps(screened.steps, stamps, arrays,
                                             [int(m) + held for m in marks], held)
        if screened.held.size:
            self._held = (stamps[screened.held], [a[screened.held] for a in arrays])
        if rejected_at:                     # messages rejected after a mark are not in it
            snapshots = [snap.without_messages([reason for position, reason in rejected_at
                                                if position >= snap.position])
                         for snap in snapshots]
        return outputs, snapshots

    def _checked_batch(self, stamp_ns: np.ndarray, columns: Sequence[np.ndarray],
                       marks: Sequence[int]) -> tuple[np.ndarray, list[np.ndarray]]:
        """Return the stamps and the four value arrays, the efforts with the README's signs.

        Raises ValueError for arrays of different shapes or marks out of order.
        """
        stamps = np.asarray(stamp_ns, dtype=np.int64)
        c = self.config
        arrays = [np.asarray(a, dtype=float) for a in columns]
        if c.motor_effort_sign != 1:        # the README's conventions (parameters)
            arrays[1] = -arrays[1]
        if c.load_effort_sign != 1:
            arrays[3] = -arrays[3]
        if any(a.shape != stamps.shape for a in arrays) or stamps.ndim != 1:
            raise ValueError(f'batch arrays must be 1-D of equal length, got shapes '
                             f'{[stamps.shape] + [a.shape for a in arrays]}')
        if list(marks) != sorted(marks) or any(not 0 <= m <= stamps.size for m in marks):
            raise ValueError(f'marks must ascend within 0..{stamps.size}, got {list(marks)}')
        return stamps, arrays

    def _run_steps(self, steps: Sequence[Segment | tuple[str, int]], stamps: np.ndarray,
                   arrays: list[np.ndarray], pending: list[int], held: int
                   ) -> tuple[list[FrictionEstimate], list[StatusSnapshot]]:
        """Run the screen's steps: accepted segments, and drops (reason, count) between them.

        ``pending``: the marks, as positions in ``stamps``, whose first ``held`` samples were
        held from the call before.
        """
        outputs: list[FrictionEstimate] = []
        snapshots: list[StatusSnapshot] = []
        last_stamp: int | None = None       # the newest accepted sample of this call [ns]
        for step in steps:
            if isinstance(step, Segment):
                index = step.index
                while pending and pending[0] <= index[0]:
                    snapshots.append(self._snapshot(pending.pop(0) - held, len(outputs),
                                                    last_stamp))
                inner = []
                while pending and pending[0] <= index[-1]:
                    inner.append(pending.pop(0))
                local = np.searchsorted(index, inner).tolist() if inner else []
                segment_outputs, inner_snapshots = self._process_segment(
                    step, stamps, arrays, [(m - held, k) for m, k in zip(inner, local)])
                snapshots += [replace(snap, estimates=snap.estimates + len(outputs))
                              for snap in inner_snapshots]
                outputs += segment_outputs
                last_stamp = int(stamps[index[-1]])
            else:
                reason, count = step
                self.counts[reason] += count
                self.samples_rejected += count
                self.samples_seen += count
        snapshots += [self._snapshot(mark - held, len(outputs), last_stamp)
                      for mark in pending]
        return outputs, snapshots

    def _snapshot(self, position: int, estimates: int, last_stamp: int | None,
                  suffix: dict[str, int] | None = None) -> StatusSnapshot:
        """Return the status inputs now, less ``suffix``.

        ``suffix``: counters of samples after the mark; ``last_stamp``: the newest sample before
        the mark [ns] (None: none in this batch).
        """
        values = self.summary()
        period = self.screen.period_at(last_stamp)
        values['sample_period_s'] = math.nan if period is None else period * 1e-9
        values['consecutive_gated'] = self.filter.consecutive_gated
        if suffix:
            counts = values['counts']
            for key, count in suffix.items():
                if key in counts:
                    counts[key] -= count
                else:
                    values[key] -= count
        return StatusSnapshot(position, estimates, values)

    def _process_segment(self, segment: Segment, stamps: np.ndarray,
                         arrays: list[np.ndarray], marks: Sequence[tuple[int, int]] = ()
                         ) -> tuple[list[FrictionEstimate], list[StatusSnapshot]]:
        """Run the estimator over accepted samples, in sequence.

        It is restarted first after a confirmed run of earlier stamps; each estimate carries the
        missing count at its stamp. ``marks``: (mark, number of this segment's samples before it),
        see :meth:`on_batch_marked`. The duplicates the screen dropped between the segment's
        samples count as if each cut it: from the next sample on, and
        in the snapshot of a mark before that sample.
        """
        if segment.reset_before:
            self.counts['stamp_reset'] += 1
            self._reset_estimator()
        index = segment.index
        part = stamps[index]
        before = self.samples_missing
        missing = before + np.cumsum(segment.missing)
        self.samples_missing = int(missing[-1])
        prior = np.full(index.size, np.iinfo(np.int64).min)
        dropped: np.ndarray | None = None
        dropped_after: Sequence[int] = ()
        if segment.drops.size:          # duplicates between its samples (not a cut)
            dropped = np.bincount(np.searchsorted(index, segment.drops),
                                  minlength=index.size).astype(np.int64)
            dropped_after = [int(np.count_nonzero(segment.drops > index[k])) for _, k in marks]
        outputs, marked = self._process(part, [a[index] for a in arrays], prior, marks,
                                        dropped, dropped_after)
        snapshots = []
        for k, snap in marked:              # k samples of the segment before the mark
            snap.values['samples_missing'] = int(missing[k - 1])
            snapshots.append(snap)
        if not self.samples_missing:
            return outputs, snapshots
        at = np.searchsorted(part, [o.stamp_ns for o in outputs])
        found = [k < part.size and part[k] == o.stamp_ns for o, k in zip(outputs, at.tolist())]
        return [replace(o, samples_missing=int(missing[k]) if hit else before)
                for o, k, hit in zip(outputs, at.tolist(), found)], snapshots

    def on_silence(self, silence_s: float) -> list[FrictionEstimate]:
        """No sample has arrived for ``silence_s`` [s], measured by the caller's clock.

        The clock is e.g. the node clock since the last arrival. Past ``sensor_timeout`` the
        timeout is flagged (``timed_out``, WARN in the status) and counted once. Nothing is
        published: an output is always stamped with, and caused by, the newest sample it used, and
        the open window is closed by the next sample as offline (the gap rule), so live equals
        offline.
        Sample stamps and the caller's clock may be in different time bases (a replayed bag
        without use_sim_time), so they are never mixed. Returns an empty list.
        """
        if self.time.silence(silence_s, self.config.sensor_timeout):
            self.counts['timeout'] += 1
        return []

    def next_output_stamp(self) -> int | None:
        """Return the stamp [ns] from which the next sample crosses the publish_rate grid.

        That sample gives an output (None before the first sample or with publish_rate 0). A live
        node can process at once a sample that reaches it, for low latency.
        """
        return self.time.next_output_stamp(self.config.publish_rate)

    # --- core --------------------------------------------------------------------------------
    def _process(self, stamps: np.ndarray, arrays: list[np.ndarray], prior: np.ndarray,
                 marks: Sequence[tuple[int, int]] = (), dropped: np.ndarray | None = None,
                 dropped_after: Sequence[int] = ()
                 ) -> tuple[list[FrictionEstimate], list[tuple[int, StatusSnapshot]]]:
        """Run the estimator over samples in sequence.

        ``marks`` (mark, local position k), with 0 < k < n, get a snapshot of the state after
        samples 0..k-1.

        ``dropped``: duplicate stamps dropped just before each sample (the screen's, inside
        the segment), counted from that sample on; ``dropped_after``: of them, those after
        each mark's sample k (not in its snapshot).
        """
        n = stamps.size
        if n == 0:
            return [], []
        duplicate = stamps == prior
        backwards = stamps < prior
        timely = ~(duplicate | backwards)
        if self.time.origin_ns is None:
            first = np.flatnonzero(timely)
            if first.size == 0:
                return [], self._untimely(duplicate, backwards, marks)
            self.time.origin_ns = int(stamps[first[0]])
        t = (stamps - self.time.origin_ns) * 1e-9
        w_m, tau_m, w_l, tau_l = arrays
        s = self._classify(arrays, timely)
        self.quality.add_samples(w_m, w_l, s.p_m, s.p_l, s.ok & ~s.zero_speed,
                                 s.ok & (s.code != 0), s.impossible)
        n_gaps, gap_at = self.time.advance(stamps, t, timely, ~s.zero_speed & s.finite,
                                           self.config.sensor_timeout, bool(marks))
        self.counts['timeout'] += n_gaps
        with np.errstate(invalid='ignore', over='ignore'):
            windows = self.integrator.process(t, w_m, tau_m, w_l, tau_l, s.code, s.usable)
        self.counts['short_window'] += self.integrator.dropped_short
        short_at = self.integrator.take_dropped_short()
        used_cum, plain_cum, rejected_cum = self._tally(duplicate, backwards, s, dropped)
        masks = {'duplicate_stamp': duplicate, 'backwards': backwards,
                 'nonfinite': s.nonfinite, 'zero_speed': s.zero_speed,
                 'deadband': s.deadband, 'impossible': s.impossible}
        publish = self.time.publish_positions(t, timely, self.config.publish_rate)
        suffixes = mark_suffixes([k for _, k in marks], masks, used_cum, plain_cum, gap_at,
                                 short_at)
        for suffix, after in zip(suffixes, dropped_after):
            for key in ('duplicate_stamp', 'samples_seen', 'samples_rejected'):
                suffix[key] += after
        outputs, marked = self._emit(
            BatchCounts(stamps, s.code, used_cum, rejected_cum, self.time.operating_at), windows,
            publish, [(mark, k, suffix) for (mark, k), suffix in zip(marks, suffixes)])
        last_timely = np.flatnonzero(timely)
        if last_timely.size:
            self._last_code = int(s.code[last_timely[-1]])
        kept, keep = self.grouping.keep(outputs)
        if len(kept) < len(outputs):        # count only the estimates kept before each mark
            before = np.concatenate(([0], np.cumsum(keep)))
            marked = [(k, replace(snap, estimates=int(before[snap.estimates])))
                      for k, snap in marked]
        return kept, marked

    def _untimely(self, duplicate: np.ndarray, backwards: np.ndarray,
                  marks: Sequence[tuple[int, int]]) -> list[tuple[int, StatusSnapshot]]:
        """Count a batch of which no sample is timely, before any sample was; its snapshots."""
        n = duplicate.size
        self._count_samples(n, duplicate, backwards, None, None, None, None)
        return [(k, self._snapshot(mark, 0, None, {
            'samples_seen': n - k,
            'samples_rejected': int(np.count_nonzero((duplicate | backwards)[k:])),
            'duplicate_stamp': int(np.count_nonzero(duplicate[k:])),
            'backwards': int(np.count_nonzero(backwards[k:]))})) for mark, k in marks]

    def _classify(self, arrays: list[np.ndarray], timely: np.ndarray) -> _Samples:
        """Return the samples' powers, power flow and rejection masks."""
        c = self.config
        w_m, tau_m, w_l, tau_l = arrays
        with np.errstate(invalid='ignore', over='ignore'):
            p_m = tau_m * w_m
            p_l = -tau_l * w_l
            code = classify(p_m, p_l, w_m, c.power_threshold, c.speed_threshold)
            # finite values whose powers or kinetic energies overflow (1e300 rad/s) are no
            # measurement either: the windows square the speeds
            finite = np.isfinite(p_m) & np.isfinite(p_l) & np.isfinite(w_m * w_m) \
                & np.isfinite(w_l * w_l)
        code[~finite] = 0
        ok = timely & finite
        zero_speed = ok & ~(np.abs(w_m) > c.speed_threshold)
        return _Samples(p_m, p_l, code, finite, timely & ~finite, ok, zero_speed,
                        ok & (code == 0) & ~zero_speed, ok & (code == IMPOSSIBLE),
                        ok & (code > 0))

    def _tally(self, duplicate: np.ndarray, backwards: np.ndarray, samples: _Samples,
               dropped: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Count a batch's samples by reason; return the cumulative counts at each sample.

        The samples used, the samples rejected without and with the ``dropped`` duplicates.
        """
        rejected = self._count_samples(duplicate.size, duplicate, backwards, samples.nonfinite,
                                       samples.zero_speed, samples.deadband,
                                       samples.impossible)
        used_cum = self.samples_used + np.cumsum(samples.usable)
        plain_cum = self.samples_rejected + np.cumsum(rejected)    # the marks' suffixes
        rejected_cum = plain_cum
        if dropped is not None:
            total = int(dropped.sum())
            self.counts['duplicate_stamp'] += total
            self.samples_seen += total
            rejected_cum = plain_cum + np.cumsum(dropped)
        self.samples_used = int(used_cum[-1])
        self.samples_rejected = int(rejected_cum[-1])
        return used_cum, plain_cum, rejected_cum

    def _emit(self, batch: BatchCounts, windows: list[Window], publish: np.ndarray,
              pending: list[_Pending]
              ) -> tuple[list[FrictionEstimate], list[tuple[int, StatusSnapshot]]]:
        """Return a batch's estimates in stamp order, and the snapshots of its marks.

        Each window's update comes after the publishes before it, which are predictions of
        one posterior (:mod:`gear_phm.estimation.predictions`).
        """
        n = batch.stamps.size
        outputs: list[FrictionEstimate | None] = []
        marked: list[tuple[int, StatusSnapshot]] = []

        def take(before: int, run: np.ndarray | None = None) -> None:
            """Snapshot the marks at or before sample ``before`` (its events not yet run).

            ``run``: publish positions about to be output (those before a mark count).
            """
            while pending and pending[0][1] <= before:
                mark, k, suffix = pending.pop(0)
                count = len(outputs) + (0 if run is None else int(np.searchsorted(run, k)))
                values = self._snapshot(mark, count, int(batch.stamps[k - 1]), suffix)
                values.values['operating_time_s'] = float(batch.operating_at[k - 1])
                values.values['timed_out'] = False
                marked.append((k, values))

        closes = np.array([window.close_index for window in windows] + [n + 1], dtype=np.int64)
        runs = np.split(publish, np.searchsorted(publish, closes[:-1], side='left'))
        runs_at: list[tuple[int, np.ndarray, PredictionBase]] = []
        for window, run, close in zip([*windows, None], runs, closes.tolist()):
            if run.size:
                take(int(run[-1]), run)
                runs_at.append((len(outputs), run, self.fusion.prediction_base()))
                outputs += [None] * run.size
                self._last_code = int(batch.code[run[-1]])
            if window is not None:
                k = min(close, n - 1)
                take(close)
                outputs += self._apply_window(window, int(batch.code[k]),
                                              int(batch.used_cum[k]), int(batch.rejected_cum[k]))
        take(n)
        if runs_at:
            predicted = predicted_estimates([(run, base) for _, run, base in runs_at], batch,
                                            self.config.ratio)
            for (at, run, _), estimates in zip(runs_at, predicted):
                outputs[at:at + run.size] = estimates
        return [output for output in outputs if output is not None], marked

    def _count_samples(self, n: int, duplicate: np.ndarray, backwards: np.ndarray,
                       nonfinite: np.ndarray | None, zero_speed: np.ndarray | None,
                       deadband: np.ndarray | None, impossible: np.ndarray | None) -> np.ndarray:
        self.samples_seen += n
        rejected: np.ndarray = duplicate | backwards
        for name, mask in (('duplicate_stamp', duplicate), ('backwards', backwards),
                           ('nonfinite', nonfinite), ('zero_speed', zero_speed),
                           ('deadband', deadband), ('impossible', impossible)):
            if mask is not None:
                self.counts[name] += int(np.count_nonzero(mask))
                rejected = rejected | mask
        if nonfinite is None:
            self.samples_rejected += int(np.count_nonzero(rejected))
        return rejected

    def _apply_window(self, window: Window, code: int, used: int, rejected: int
                      ) -> list[FrictionEstimate]:
        """Fuse a closed window; return its estimate (none if it gave none).

        ``code``: the power flow of the sample that closed it; ``used``, ``rejected``: the
        sample counts there.
        """
        # the filter runs on operating time; a window is motion throughout, so its age
        # (half its duration) is the same in stamp and in operating time
        operating = self.time.operating_at_close(window.close_index)
        fused = self.fusion.fuse(window, operating, self.counts, self.quality,
                                 self.on_measurement)
        if fused is None:
            return []
        self.windows_used += 1
        self._last_code = code
        return [self.fusion.estimate(self.stamp_ns(window.t_end), used, rejected, code,
                                     operating, fused)]

    # --- reporting ---------------------------------------------------------------------------
    def summary(self) -> SummaryValues:
        """Return the final estimate and counters (JSON-friendly)."""
        x, p = self.filter.x, self.filter.P
        eta_d = efficiencies(float(x[0]) + self.filter.direction_bias(0), self.config.ratio)[0]
        eta_i = efficiencies(float(x[0]) + self.filter.direction_bias(1), self.config.ratio)[1]
        return {
            'u': float(x[0]), 'u_rate': float(x[1]), 'sigma_u': math.sqrt(max(p[0, 0], 0.0)),
            'eta_opposing': eta_d, 'eta_aiding': eta_i,
            'last_measured_efficiency': self.fusion.last_eta,
            'filter_updates': self.filter.updates, 'samples_seen': self.samples_seen,
            'process_noise': self.filter.process_noise,
            'mismatch_sigma_opposing': math.sqrt(self.filter.mismatch_variance(0)),
            'mismatch_sigma_aiding': math.sqrt(self.filter.mismatch_variance(1)),
            'direction_offset': self.filter.direction_offset,
            'direction_offset_sigma': self.filter.direction_offset_sigma,
            'direction_offset_drift_z': self.filter.offset_drift_z,
            'motor_inertia': self.inertia.inertia,
            'operating_time_s': self.operating_time,
            'samples_used': self.samples_used, 'samples_rejected': self.samples_rejected,
            'samples_missing': self.samples_missing,
            'sample_period_s': (math.nan if self.screen.period_ns is None
                                else self.screen.period_ns * 1e-9),
            'counts': (dict(self.counts) if self.config.no_load_model else {
                reason: count for reason, count in self.counts.items()
                if reason != 'not_identifiable'}),
            'timed_out': self.timed_out,
            'reversed_torque': self.reversed_torque(),
            'speed_ratio': self.speed_ratio(), 'ratio_check': self.ratio_check(),
            'windows_over_unity': self.quality.windows_over_unity,
            'over_unity': self.over_unity(),
            **(self.fusion.no_load_summary(eta_d) if self.config.no_load_model else {}),
        }

    @property
    def windows_measured(self) -> int:
        """Return how many windows gave a measurement (:mod:`gear_phm.estimation.quality`)."""
        return self.quality.windows_measured

    def reversed_torque(self) -> str:
        """Return which effort's sign looks reversed, as advice; '' when nothing does.

        See :meth:`~gear_phm.estimation.quality.DataQuality.reversed_torque`.
        """
        c = self.config
        return self.quality.reversed_torque(c.motor_effort_sign, c.load_effort_sign)

    def reversed_torque_fix(self) -> tuple[str, int] | None:
        """Return the parameter and value that :meth:`reversed_torque` advises, or None."""
        c = self.config
        return self.quality.reversed_torque_fix(c.motor_effort_sign, c.load_effort_sign)

    def over_unity(self) -> str:
        """Return why the windows' energies look wrong, or ''.

        See :meth:`~gear_phm.estimation.quality.DataQuality.over_unity`.
        """
        return self.quality.over_unity()

    def speed_ratio(self) -> float:
        """Return the ratio the speeds give, |sum w_m w_l / sum w_l^2| [-] (NaN before)."""
        return self.quality.speed_ratio()

    def ratio_check(self) -> str:
        """Return why the ``ratio`` parameter disagrees with the speeds; '' when it does not.

        See :meth:`~gear_phm.estimation.quality.DataQuality.ratio_check`.
        """
        return self.quality.ratio_check(self.config.ratio)

    def status(self, name: str, messages_received: int | None = None,
               snapshot: StatusSnapshot | None = None) -> StatusOut:
        """Return the DiagnosticStatus record: level, message, estimate and counters by reason.

        Each call closes a status period: ``loss_ratio`` is the share of samples missing since the
        previous call (WARN above ``loss_warn``). With ``snapshot`` (from :meth:`on_batch_marked`),
        the status as of that mark. The composition: :mod:`gear_phm.estimation.status`.
        """
        summary = self.summary() if snapshot is None else snapshot.values
        loss = self.loss.close(summary['samples_seen'], summary['samples_missing'])
        gated = (self.filter.consecutive_gated if snapshot is None
                 else summary['consecutive_gated'])
        return compose_status(summary, name, gated=gated, loss=loss,
                              loss_warn=self.config.loss_warn,
                              no_load_model=self.config.no_load_model,
                              messages_received=messages_received)
