"""The estimator's time axes, from the sample stamps only (no clock, no ROS).

Three axes: stamp time t [s] from the first timely sample's stamp (``origin_ns``), on which
energy windows run; the ``publish_rate`` grid on it, whose cells each give one published
estimate; and operating time [s], the time with motion, on which the Kalman filter runs:
the sum of the sample intervals (up to ``sensor_timeout``) that end at a moving, finite
sample. Idle time and the gap between two recordings add no operating time, so wear, and the
rate du/dt [1/s of operation], accrue only while the gearbox moves. A gap between two timely
samples longer than ``sensor_timeout`` is a sensor timeout.
"""
from __future__ import annotations

import math

import numpy as np


class Timeline:
    """The time axes of one estimator; see the module docstring.

    ``origin_ns``: the stamp of stamp time 0 [ns]; ``grid``: the newest publish cell;
    ``last_stamp``: the newest timely sample's stamp [ns] (each None before the first);
    ``timed_out``: no sample for ``sensor_timeout`` (flagged by :meth:`silence`, cleared by
    the next sample); ``operating_time`` [s]; ``max_stamp``: the newest stamp screened [ns].
    """

    def __init__(self) -> None:
        self.operating_time = 0.0
        #: the current batch's operating time before its first sample and at each sample [s]
        self.operating_before = 0.0
        self.operating_at = np.zeros(0)
        self.max_stamp: int | None = None
        self.restart()

    def restart(self) -> None:
        """Start stamp time and its grid afresh from the next sample (operating time goes on)."""
        self.origin_ns: int | None = None
        self.grid: int | None = None
        self.last_stamp: int | None = None
        self.timed_out = False

    def t(self, stamp_ns: int) -> float:
        """Return the stamp time [s] of ``stamp_ns`` (after the origin is set)."""
        assert self.origin_ns is not None       # the first timely sample sets it
        return (stamp_ns - self.origin_ns) * 1e-9

    def stamp_ns(self, t: float) -> int:
        """Return the stamp [ns] of stamp time ``t`` [s]; ValueError before the first sample."""
        if self.origin_ns is None:
            raise ValueError('no sample yet: pipeline time has no origin')
        return self.origin_ns + int(round(t * 1e9))

    def advance(self, stamps: np.ndarray, t: np.ndarray, timely: np.ndarray,
                moving: np.ndarray, sensor_timeout: float, marked: bool
                ) -> tuple[int, np.ndarray]:
        """Add a batch's operating time and find its sensor timeouts.

        ``stamps`` [ns] and their stamp times ``t`` [s]; ``timely``: the samples in order;
        ``moving``: those moving and finite. Returns the number of new timeouts and, when
        ``marked``, the positions of the samples after one.
        """
        t_ok = t[timely]
        gap_at = np.empty(0, dtype=np.int64)
        operating = np.zeros(stamps.size)   # each sample's operating-time contribution [s]
        n_gaps = 0
        if t_ok.size:                       # timeouts: gaps between consecutive timely samples
            last = self.t(self.last_stamp) if self.last_stamp is not None else t_ok[0]
            steps = np.diff(np.concatenate(([last], t_ok)))
            gaps = steps > sensor_timeout
            # operating time: sample intervals that end in motion, not across a gap
            operating[timely] = np.where(~gaps & moving[timely], steps, 0.0)
            n_gaps = int(np.count_nonzero(gaps))
            if self.timed_out and gaps[0]:
                n_gaps -= 1         # already counted by silence()
                gaps[0] = False
            if marked:
                gap_at = np.flatnonzero(timely)[gaps]
            self.timed_out = False
            self.last_stamp = int(stamps[timely][-1])
        # the filter's time axis: cumulative operating time at each sample [s]
        self.operating_before = self.operating_time
        self.operating_at = self.operating_time + np.cumsum(operating)
        self.operating_time = float(self.operating_at[-1])
        self.max_stamp = int(max(stamps.max(), self.max_stamp or stamps.max()))
        return n_gaps, gap_at

    def operating_at_close(self, close_index: int) -> float:
        """Operating time [s] at the sample before ``close_index`` of the current batch.

        At 0, the previous batch's last sample.
        """
        if close_index <= 0:
            return self.operating_before
        return float(self.operating_at[close_index - 1])

    def publish_positions(self, t: np.ndarray, timely: np.ndarray, rate: float) -> np.ndarray:
        """Return the samples that cross the grid of ``rate`` [Hz] in stamp time (none at 0)."""
        if not rate > 0.0:
            return np.empty(0, dtype=np.int64)
        cell = np.where(timely, np.floor(t * rate), -np.inf)
        cell = np.maximum.accumulate(cell)
        prev = np.concatenate(([self.grid if self.grid is not None else -np.inf], cell[:-1]))
        publish = np.flatnonzero(timely & (cell > prev))
        if np.isfinite(cell[-1]):
            self.grid = int(cell[-1])
        return publish

    def regrid(self, rate: float) -> None:
        """Continue the publish grid at a new ``rate`` [Hz] from the newest sample."""
        if rate > 0.0 and self.last_stamp is not None and self.origin_ns is not None:
            self.grid = math.floor(self.t(self.last_stamp) * rate)

    def next_output_stamp(self, rate: float) -> int | None:
        """Return the stamp [ns] from which the next sample crosses the grid of ``rate``."""
        if rate <= 0.0 or self.origin_ns is None or self.grid is None:
            return None
        return self.origin_ns + math.ceil((self.grid + 1) / rate * 1e9)

    def silence(self, silence_s: float, sensor_timeout: float) -> bool:
        """Return True when a silence of ``silence_s`` [s] is a new timeout (then flagged)."""
        if self.last_stamp is None or self.origin_ns is None:
            return False
        if silence_s <= sensor_timeout or self.timed_out:
            return False
        self.timed_out = True
        return True
