"""Message -> batch -> estimator -> output records, free of ROS (shared by node and analyze).

:class:`EstimatorPipeline` is the whole estimator: the live node feeds it one JointState at a
time (:meth:`on_joint_state`) and turns the returned :class:`~gear_phm.interfaces.Vector3Out`
records into rclpy messages; ``gear-phm analyze`` feeds it large decoded batches
(:meth:`on_batch`) and writes the same records to a bag. Results do not depend on how the
samples are split into batches.
"""
from __future__ import annotations

from collections.abc import Callable
import math
from typing import Any

import numpy as np

from gear_phm import interfaces
from gear_phm.estimation.config import EstimatorConfig
from gear_phm.estimation.kalman import FrictionFilter
from gear_phm.estimation.powerflow import classify, IMPOSSIBLE
from gear_phm.estimation.windows import EnergyIntegrator, Measurement, to_measurement, Window
from gear_phm.interfaces import format_value, OK, StatusOut, Vector3Out, WARN

#: Per-sample rejection reasons (each counts into "samples rejected").
SAMPLE_REASONS = ('nonfinite', 'zero_speed', 'deadband', 'impossible', 'backwards',
                  'duplicate_stamp')
#: Message-level reasons (a message that gives no sample at all).
MESSAGE_REASONS = ('missing_joint', 'short_arrays', 'truncated', 'bad_encoding', 'bad_message')
#: Window / measurement reasons and events (do not count as rejected samples).
WINDOW_REASONS = ('short_window', 'low_energy', 'wrong_energy_sign', 'out_of_domain', 'gated')
EVENTS = ('timeout', 'stamp_reset', 'reinitialised')


def _eta_d(u: float, ratio: float) -> float:
    return (ratio - u) / (ratio * (1.0 + u)) if u > -1.0 else math.nan


def _eta_i(u: float, ratio: float) -> float:
    return ratio * (1.0 - u) / (ratio + u) if u > -ratio else math.nan


class EstimatorPipeline:
    """Friction estimator over a stream of samples; see the module docstring.

    ``on_measurement`` (optional) is called with each :class:`Measurement` and whether the
    filter accepted it (used by ``gear-phm analyze`` for its plot).
    """

    def __init__(self, config: EstimatorConfig, motor_joint: str = 'motor',
                 load_joint: str = 'load', frame_id: str = '',
                 on_measurement: Callable[[Measurement, bool], None] | None = None) -> None:
        if not motor_joint or not load_joint or motor_joint == load_joint:
            raise ValueError(f'motor_joint and load_joint must be distinct non-empty names, got '
                             f'{motor_joint!r} and {load_joint!r}')
        self.config = config
        self.motor_joint = motor_joint
        self.load_joint = load_joint
        self.frame_id = frame_id
        self.on_measurement = on_measurement
        self.counts: dict[str, int] = dict.fromkeys(
            SAMPLE_REASONS + MESSAGE_REASONS + WINDOW_REASONS + EVENTS, 0)
        self.samples_seen = 0
        self.samples_used = 0
        self.samples_rejected = 0
        self.windows_used = 0
        self._max_stamp: int | None = None
        self._last_group_stamp: int | None = None     # stamp of the newest output group [ns]
        self._group_topics: set[str] = set()
        self._reset_estimator()

    # --- state -------------------------------------------------------------------------------
    def _reset_estimator(self) -> None:
        c = self.config
        self.filter = FrictionFilter(c.initial_u, c.initial_u_sigma, c.initial_rate_sigma,
                                     c.process_noise, c.gate_threshold,
                                     c.max_consecutive_gated)
        self.integrator = EnergyIntegrator(
            c.window, c.sensor_timeout, c.motor_inertia, c.load_inertia,
            (c.motor_torque_noise, c.motor_speed_noise, c.load_torque_noise,
             c.load_speed_noise), min_duration=c.min_window)
        self._origin_ns: int | None = None
        self._grid: int | None = None
        self._last_code = 0
        self._last_eta = math.nan
        self._last_stamp: int | None = None
        self.timed_out = False

    def reconfigure(self, config: EstimatorConfig) -> None:
        """Apply new parameters; the filter and the open window restart, counters stay."""
        self.config = config
        self._reset_estimator()
        self._max_stamp = None

    def _t(self, stamp_ns: int) -> float:
        return (stamp_ns - self._origin_ns) * 1e-9

    def _stamp(self, t: float) -> int:
        return self._origin_ns + int(round(t * 1e9))

    # --- inputs ------------------------------------------------------------------------------
    def reject_message(self, reason: str, count: int = 1) -> None:
        """Count messages that gave no sample (e.g. ``missing_joint``)."""
        key = reason if reason in self.counts else 'bad_message'
        self.counts[key] += count
        self.samples_rejected += count

    def sample_from_message(self, msg: Any) -> interfaces.JointSample | None:
        """The sample of one JointState, or None (counted by reason) if it has none."""
        try:
            return interfaces.joint_state_to_sample(msg, self.motor_joint, self.load_joint)
        except interfaces.BadMessage as exc:
            self.reject_message(exc.reason)
        except (AttributeError, TypeError, ValueError, OverflowError):
            self.reject_message('bad_message')
        return None

    def on_samples(self, samples: list[interfaces.JointSample]) -> list[Vector3Out]:
        """A buffer of samples (e.g. collected by the live node between timer ticks)."""
        if not samples:
            return []
        columns = np.array([(s.motor_velocity, s.motor_effort, s.load_velocity, s.load_effort)
                            for s in samples], dtype=float).reshape(-1, 4)
        stamps = np.array([s.stamp_ns for s in samples], dtype=np.int64)
        return self.on_batch(stamps, *columns.T)

    def on_joint_state(self, msg: Any) -> list[Vector3Out]:
        """One sensor_msgs/JointState (rclpy or rosbags object); never raises on bad content."""
        sample = self.sample_from_message(msg)
        return [] if sample is None else self.on_samples([sample])

    def on_batch(self, stamp_ns: np.ndarray, motor_velocity: np.ndarray,
                 motor_effort: np.ndarray, load_velocity: np.ndarray,
                 load_effort: np.ndarray) -> list[Vector3Out]:
        """Samples in arrival order: stamps [ns] (int64), speeds [rad/s], torques [N m]."""
        stamps = np.asarray(stamp_ns, dtype=np.int64)
        arrays = [np.asarray(a, dtype=float) for a in
                  (motor_velocity, motor_effort, load_velocity, load_effort)]
        if any(a.shape != stamps.shape for a in arrays) or stamps.ndim != 1:
            raise ValueError(f'batch arrays must be 1-D of equal length, got shapes '
                             f'{[stamps.shape] + [a.shape for a in arrays]}')
        outputs: list[Vector3Out] = []
        start = 0
        n = stamps.size
        while start < n:
            part = stamps[start:]
            prior = np.maximum.accumulate(part)
            prior = np.concatenate(([np.iinfo(np.int64).min], prior[:-1]))
            if self._max_stamp is not None:
                prior = np.maximum(prior, self._max_stamp)
            end = n
            if self.config.backwards_policy == 'reset':
                back = np.flatnonzero(part < prior)
                if back.size:
                    end = start + int(back[0])
            outputs += self._process(stamps[start:end], [a[start:end] for a in arrays],
                                     prior[:end - start])
            if end < n:
                self.counts['stamp_reset'] += 1
                self._reset_estimator()
                self._max_stamp = None
            start = end
        return outputs

    def on_silence(self, silence_s: float) -> list[Vector3Out]:
        """No sample has arrived for ``silence_s`` [s] (measured by the caller's clock, e.g. the
        node clock since the last arrival). Past ``sensor_timeout``: close the open window,
        predict only, flag the timeout and publish once, stamped with the newest sample (the
        estimate still uses no newer data). Sample stamps and the caller's clock may be in
        different time bases (a replayed bag without use_sim_time), so they are never mixed.
        """
        if self._last_stamp is None or self._origin_ns is None:
            return []
        if silence_s <= self.config.sensor_timeout or self.timed_out:
            return []
        self.timed_out = True
        self.counts['timeout'] += 1
        outputs: list[Vector3Out] = []
        for window in self.integrator.flush():
            outputs += self._apply_window(window)
        x, p = self.filter.predicted(self._t(self._last_stamp))
        outputs += self._records(int(self._last_stamp), x, p)
        return outputs

    # --- core --------------------------------------------------------------------------------
    def _process(self, stamps: np.ndarray, arrays: list[np.ndarray],
                 prior: np.ndarray) -> list[Vector3Out]:
        n = stamps.size
        if n == 0:
            return []
        c = self.config
        w_m, tau_m, w_l, tau_l = arrays
        duplicate = stamps == prior
        backwards = stamps < prior
        timely = ~(duplicate | backwards)
        if self._origin_ns is None:
            first = np.flatnonzero(timely)
            if first.size == 0:
                self._count_samples(n, duplicate, backwards, None, None, None, None)
                return []
            self._origin_ns = int(stamps[first[0]])
        t = (stamps - self._origin_ns) * 1e-9
        finite = np.isfinite(w_m) & np.isfinite(tau_m) & np.isfinite(w_l) & np.isfinite(tau_l)
        with np.errstate(invalid='ignore', over='ignore'):
            p_m = tau_m * w_m
            p_l = -tau_l * w_l
            code = classify(p_m, p_l, w_m, c.power_threshold, c.speed_threshold)
        code[~finite] = 0
        nonfinite = timely & ~finite
        ok = timely & finite
        zero_speed = ok & ~(np.abs(w_m) > c.speed_threshold)
        deadband = ok & (code == 0) & ~zero_speed
        impossible = ok & (code == IMPOSSIBLE)
        usable = ok & (code > 0)
        # sensor timeouts: gaps between consecutive timely samples
        t_ok = t[timely]
        if t_ok.size:
            last = self._t(self._last_stamp) if self._last_stamp is not None else t_ok[0]
            gaps = np.diff(np.concatenate(([last], t_ok))) > c.sensor_timeout
            n_gaps = int(np.count_nonzero(gaps))
            if self.timed_out and gaps[0]:
                n_gaps -= 1         # already counted by on_silence
            self.counts['timeout'] += n_gaps
            self.timed_out = False
            self._last_stamp = int(stamps[timely][-1])
        self._max_stamp = int(max(stamps.max(), self._max_stamp or stamps.max()))
        with np.errstate(invalid='ignore', over='ignore'):
            windows = self.integrator.process(t, w_m, tau_m, w_l, tau_l, code, usable)
        self.counts['short_window'] += self.integrator.dropped_short
        self.integrator.dropped_short = 0
        rejected = self._count_samples(n, duplicate, backwards, nonfinite, zero_speed,
                                       deadband, impossible)
        used_cum = self.samples_used + np.cumsum(usable)
        rejected_cum = self.samples_rejected + np.cumsum(rejected)
        self.samples_used = int(used_cum[-1])
        self.samples_rejected = int(rejected_cum[-1])
        # periodic outputs on the grid of publish_rate in sample time
        if c.publish_rate > 0.0:
            cell = np.where(timely, np.floor(t * c.publish_rate), -np.inf)
            cell = np.maximum.accumulate(cell)
            prev = np.concatenate(([self._grid if self._grid is not None else -np.inf],
                                   cell[:-1]))
            publish = np.flatnonzero(timely & (cell > prev))
            if np.isfinite(cell[-1]):
                self._grid = int(cell[-1])
        else:
            publish = np.empty(0, dtype=np.int64)
        outputs: list[Vector3Out] = []
        w_i = 0
        for k in publish.tolist():
            while w_i < len(windows) and windows[w_i].close_index <= k:
                c_k = windows[w_i].close_index
                outputs += self._apply_window(windows[w_i], int(code[c_k]),
                                              int(used_cum[c_k]), int(rejected_cum[c_k]))
                w_i += 1
            self._last_code = int(code[k])
            x, p = self.filter.predicted(t[k])
            outputs += self._records(int(stamps[k]), x, p, int(used_cum[k]),
                                     int(rejected_cum[k]))
        for window in windows[w_i:]:
            k = min(window.close_index, n - 1)
            outputs += self._apply_window(window, int(code[k]), int(used_cum[k]),
                                          int(rejected_cum[k]))
        last_timely = np.flatnonzero(timely)
        if last_timely.size:
            self._last_code = int(code[last_timely[-1]])
        return self._one_group_per_stamp(outputs)

    def _one_group_per_stamp(self, outputs: list[Vector3Out]) -> list[Vector3Out]:
        """At most one output group per stamp, whatever the batch split: a group whose stamp
        equals the previous group's is dropped (the filter state it carries is in the next)."""
        kept = []
        for output in outputs:
            if output.stamp_ns == self._last_group_stamp and output.topic in self._group_topics:
                continue
            if output.stamp_ns != self._last_group_stamp:
                self._last_group_stamp = output.stamp_ns
                self._group_topics = set()
            self._group_topics.add(output.topic)
            kept.append(output)
        return kept

    def _count_samples(self, n: int, duplicate: np.ndarray, backwards: np.ndarray,
                       nonfinite: np.ndarray | None, zero_speed: np.ndarray | None,
                       deadband: np.ndarray | None, impossible: np.ndarray | None) -> np.ndarray:
        self.samples_seen += n
        rejected = duplicate | backwards
        for name, mask in (('duplicate_stamp', duplicate), ('backwards', backwards),
                           ('nonfinite', nonfinite), ('zero_speed', zero_speed),
                           ('deadband', deadband), ('impossible', impossible)):
            if mask is not None:
                self.counts[name] += int(np.count_nonzero(mask))
                rejected = rejected | mask
        if nonfinite is None:
            self.samples_rejected += int(np.count_nonzero(rejected))
        return rejected

    def _apply_window(self, window: Window, code: int | None = None, used: int | None = None,
                      rejected: int | None = None) -> list[Vector3Out]:
        c = self.config
        result = to_measurement(window, c.ratio, c.min_window, c.min_energy, c.model_sigma)
        if isinstance(result, str):
            self.counts[result] += 1
            return []
        update = self.filter.update(result.u, result.u_variance, result.t)
        self._last_eta = result.eta
        if self.on_measurement is not None:
            self.on_measurement(result, update.accepted)
        if not update.accepted:
            self.counts['gated'] += 1
            return []
        if update.reinitialised:
            self.counts['gated'] += 1
            self.counts['reinitialised'] += 1
        self.windows_used += 1
        if code is not None:
            self._last_code = code
        return self._records(self._stamp(window.t_end), self.filter.x, self.filter.P,
                             used, rejected)

    def _records(self, stamp_ns: int, x: np.ndarray, p: np.ndarray, used: int | None = None,
                 rejected: int | None = None) -> list[Vector3Out]:
        r = self.config.ratio
        u, rate = float(x[0]), float(x[1])
        last = self.filter.last
        frame = self.frame_id
        used = self.samples_used if used is None else used
        rejected = self.samples_rejected if rejected is None else rejected
        return [
            Vector3Out(interfaces.FRICTION, stamp_ns, u, rate, math.sqrt(max(p[0, 0], 0.0)),
                       frame),
            Vector3Out(interfaces.FRICTION_COVARIANCE, stamp_ns, float(p[0, 0]),
                       float(p[0, 1]), float(p[1, 1]), frame),
            Vector3Out(interfaces.EFFICIENCY, stamp_ns, _eta_d(u, r), _eta_i(u, r),
                       self._last_eta, frame),
            Vector3Out(interfaces.INNOVATION, stamp_ns, last.innovation,
                       last.innovation_variance, last.nis, frame),
            Vector3Out(interfaces.COUNTS, stamp_ns, float(used), float(rejected),
                       float(self._last_code), frame),
        ]

    # --- reporting ---------------------------------------------------------------------------
    def summary(self) -> dict[str, Any]:
        """Final estimate and counters (JSON-friendly)."""
        x, p = self.filter.x, self.filter.P
        r = self.config.ratio
        return {
            'u': float(x[0]), 'u_rate': float(x[1]), 'sigma_u': math.sqrt(max(p[0, 0], 0.0)),
            'eta_opposing': _eta_d(float(x[0]), r), 'eta_aiding': _eta_i(float(x[0]), r),
            'last_measured_efficiency': self._last_eta,
            'filter_updates': self.filter.updates, 'samples_seen': self.samples_seen,
            'samples_used': self.samples_used, 'samples_rejected': self.samples_rejected,
            'counts': dict(self.counts), 'timed_out': self.timed_out,
        }

    def status(self, name: str, messages_received: int | None = None) -> StatusOut:
        """DiagnosticStatus record: level, message, estimate and counters by reason."""
        summary = self.summary()
        if self.timed_out:
            level, message = WARN, 'sensor timeout: predicting only'
        elif self.filter.updates == 0:
            level, message = WARN, 'no efficiency measurement yet'
        elif self.filter.consecutive_gated:
            level, message = WARN, f'{self.filter.consecutive_gated} measurement(s) gated'
        else:
            level, message = OK, 'estimating'
        values: list[tuple[str, Any]] = []
        if messages_received is not None:
            values.append(('messages_received', messages_received))
        values += [(key, summary[key]) for key in (
            'u', 'sigma_u', 'eta_opposing', 'eta_aiding', 'filter_updates', 'samples_used',
            'samples_rejected')]
        for reason, count in sorted(summary['counts'].items()):
            if reason in WINDOW_REASONS:
                values.append((f'windows_rejected_{reason}', count))
            elif reason in EVENTS:
                values.append((f'events_{reason}', count))
            else:
                values.append((f'dropped_{reason}', count))
        return StatusOut(level, name, message, 'gear_phm',
                         tuple((key, format_value(value)) for key, value in values))
