"""The wear history: time bins of u and its precision, and the utilisation.

:class:`WearHistory`: every measurement of u the filter fused (t, z, R), or, from a stream
without measurements, every posterior (t, u, P_uu), goes into one of at most ``max_points``
bins of equal width in time. When a new point falls past the last bin, the bins are merged
pairwise and the width doubles, so memory is bounded for any length of input and the bins
always cover the whole history, evenly. A bin is summarised by its precision-weighted mean time
and u, and the summed precision of its measurements (independent windows), or the mean
precision of its posteriors (not the sum: neighbouring Kalman posteriors are strongly
correlated, so averaging them does not make u more certain). Measurements are preferred: a
posterior lags accelerating wear and then catches up, a kink that the fit extrapolates.

A measurement comes less its load direction's bias as the filter knew it then (h d, with h
-1/2 for an opposing window and +1/2 for an aiding one, d the offset between the directions).
A bin also sums each measurement's h and that bias, so that :meth:`WearHistory.arrays` gives
every bin with the offset learned since (:attr:`WearHistory.offset`): the windows before d
was learned read u plus or minus d/2, a step that the fit took for wear (random lives 26 and
98: WARN before the wear onset).

:class:`Utilisation`: operating time over elapsed time, the factor between the RUL's two time
bases (docs/prognostics.md).
"""
from __future__ import annotations

import bisect
import math
from typing import Any

import numpy as np

from gear_phm.persistence import decode_float, decode_floats, encode_float, encode_floats


#: Most (operating, elapsed) checkpoints :class:`Utilisation` keeps.
CHECKPOINTS = 1024


class Utilisation:
    """Operating time over elapsed (stamp) time [-], accumulated over a history of updates.

    Each :meth:`add` of (stamp time t, operating time s) [s] adds the increments since the
    previous one: elapsed t - t_prev and operating s - s_prev. An increment where either time
    went back is not counted. :attr:`fraction` is 1 until some time has elapsed (a RUL then
    means the same in both time bases), and at most 1.

    :meth:`elapsed_for` maps a time of operation ahead onto elapsed time at the *recent* duty:
    the utilisation over the newest ``max(q, window)`` seconds of operation, not over the
    whole history. A night's idle gap before today's run then stops counting once the run
    holds ``window`` of operation, while the weeks between a fleet's short recordings, which
    are its duty, still count. The newest updates are kept as checkpoints of (operating,
    elapsed) [s]; beyond :data:`CHECKPOINTS` the older half is thinned pairwise, so memory is
    bounded and the recent past stays dense.
    """

    def __init__(self, window: float = 60.0) -> None:
        #: operating time [s] over which the recent duty is measured at least
        self.window = float(window)
        self.reset()

    def reset(self) -> None:
        """Forget the accumulated times."""
        self.operating = 0.0
        self.elapsed = 0.0
        self._last: tuple[float, float] | None = None
        self._points: list[tuple[float, float]] = []     # (operating, elapsed) cumulative

    def add(self, t: float, s: float) -> None:
        """Add the update at stamp time ``t`` [s] with operating time ``s`` [s]."""
        if not (math.isfinite(t) and math.isfinite(s)):
            return
        if self._last is not None:
            dt, ds = t - self._last[0], s - self._last[1]
            if dt >= 0.0 and ds >= 0.0:
                self.elapsed += dt
                self.operating += ds
        self._last = (t, s)
        points = self._points
        if points and points[-1][0] == self.operating:
            points[-1] = (self.operating, self.elapsed)     # no operation: the idle grows
        else:
            points.append((self.operating, self.elapsed))
        if len(points) > CHECKPOINTS:
            half = len(points) // 2
            self._points = points[:half:2] + points[half:]

    @property
    def fraction(self) -> float:
        """Operating over elapsed time [-] (1 before any time elapsed)."""
        return min(self.operating / self.elapsed, 1.0) if self.elapsed > 0.0 else 1.0

    def recent_fraction(self, span: float) -> float:
        """Return the utilisation over the newest ``span`` seconds of operation [-].

        The whole history's (:attr:`fraction`) when it holds less operation than that.
        """
        if not (span < self.operating) or len(self._points) < 2:
            return self.fraction
        start = self.operating - span
        ops = [p[0] for p in self._points]
        if start <= ops[0]:
            return self.fraction
        i = bisect.bisect_right(ops, start)
        (s0, e0), (s1, e1) = self._points[i - 1], self._points[i]
        # the elapsed time at operating position ``start``, interpolated between the two
        # checkpoints around it: an idle gap between updates older than ``span`` is out whole
        e_start = e0 + (e1 - e0) * (start - s0) / (s1 - s0) if s1 > s0 else e1
        elapsed = self.elapsed - e_start
        return min(span / elapsed, 1.0) if elapsed > 0.0 else 1.0

    def elapsed_for(self, operating: float) -> float:
        """Return the elapsed time [s] that ``operating`` seconds of operation take.

        At the recent duty, :meth:`recent_fraction` over ``max(operating, window)``; 0 and NaN
        stay as they are, a positive time at utilisation 0 is inf.
        """
        if operating == 0.0 or operating != operating:
            return operating
        fraction = self.recent_fraction(max(operating, self.window))
        return operating / fraction if fraction > 0.0 else math.inf

    def to_state(self) -> dict[str, Any]:
        """Return the accumulated times, the last update and the checkpoints (JSON-safe)."""
        return {'operating': encode_float(self.operating), 'elapsed': encode_float(self.elapsed),
                'last': None if self._last is None else encode_floats(self._last),
                'points': encode_floats([v for point in self._points for v in point])}

    def from_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`to_state`; ValueError/KeyError/TypeError if malformed.

        A state without checkpoints (an older file) starts them at its totals.
        """
        last = None if state['last'] is None else decode_floats(state['last'])
        if last is not None and len(last) != 2:
            raise ValueError('utilisation: last needs 2 values')
        operating, elapsed = decode_float(state['operating']), decode_float(state['elapsed'])
        flat = decode_floats(state['points']) if 'points' in state else [operating, elapsed]
        if len(flat) % 2:
            raise ValueError('utilisation: points need pairs of values')
        self.operating, self.elapsed = operating, elapsed
        self._last = None if last is None else (last[0], last[1])
        self._points = list(zip(flat[::2], flat[1::2]))


class WearHistory:
    """At most ``max_points`` equal-width time bins of (t, u, 1/P_uu) (module docstring)."""

    def __init__(self, max_points: int = 256, initial_width: float = 0.01) -> None:
        if max_points < 8 or max_points % 2:
            raise ValueError(f'max_points must be even and >= 8, got {max_points!r}')
        if not initial_width > 0.0:
            raise ValueError(f'initial_width must be > 0 s, got {initial_width!r}')
        self.max_points = int(max_points)
        self.initial_width = float(initial_width)
        #: Points are independent measurements (a bin's precision is their sum), not
        #: correlated posteriors (their mean); set while the history is empty.
        self.independent = False
        self.reset()

    def reset(self) -> None:
        """Forget the history (e.g. after the filter re-initialised)."""
        m = self.max_points
        self.t_start = math.nan
        self.t_last = math.nan
        self.width = self.initial_width
        self._w = [0.0] * m          # sum of 1/P
        self._wt = [0.0] * m         # sum of (t - t_start)/P
        self._wu = [0.0] * m         # sum of u/P
        self._wh = [0.0] * m         # sum of h/P (h: the direction's share of the offset)
        self._wb = [0.0] * m         # sum of bias/P (the bias subtracted from u)
        self._n = [0] * m
        #: bins opened so far (counts up, also across merges: the refit clock)
        self.opened = 0
        self._occupied = 0
        #: the offset d between the load directions [-] that :meth:`arrays` corrects to
        self.offset = 0.0

    def __len__(self) -> int:
        return self._occupied

    def add(self, t: float, u: float, u_variance: float, direction: float = 0.0,
            bias: float = 0.0) -> None:
        """Record a posterior at time t [s]; a time before the last one restarts the history.

        ``direction`` h [-] and ``bias`` [-]: a measurement's share of the offset between the
        load directions and the bias h d subtracted from it (module docstring; 0 for none).
        """
        if not (math.isfinite(t) and math.isfinite(u) and math.isfinite(u_variance)
                and u_variance > 0.0):
            return
        if self.t_last == self.t_last and t < self.t_last:
            self.reset()
        if self.t_start != self.t_start:
            self.t_start = t
        self.t_last = t
        dt = t - self.t_start
        index = int(dt / self.width)
        while index >= self.max_points:
            self._merge()
            index = int(dt / self.width)
        w = 1.0 / u_variance
        if not self._n[index]:
            self.opened += 1
            self._occupied += 1
        self._w[index] += w
        self._wt[index] += w * dt
        self._wu[index] += w * u
        if math.isfinite(direction) and math.isfinite(bias):
            self._wh[index] += w * direction
            self._wb[index] += w * bias
        self._n[index] += 1

    def shift(self, offset: float) -> None:
        """Move the history by ``offset`` [s] in time (onto another time axis)."""
        self.t_start += offset
        self.t_last += offset

    def to_state(self) -> dict[str, Any]:
        """Return the bins and their clock (JSON-safe, see :mod:`gear_phm.persistence`)."""
        return {'max_points': self.max_points, 't_start': encode_float(self.t_start),
                't_last': encode_float(self.t_last), 'width': encode_float(self.width),
                'w': encode_floats(self._w), 'wt': encode_floats(self._wt),
                'wu': encode_floats(self._wu), 'n': list(self._n), 'opened': self.opened,
                'independent': self.independent, 'wh': encode_floats(self._wh),
                'wb': encode_floats(self._wb), 'offset': encode_float(self.offset)}

    def from_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`to_state` (same max_points); ValueError/KeyError/TypeError if bad."""
        m = self.max_points
        columns = [decode_floats(state[key]) for key in ('w', 'wt', 'wu')]
        # added within schema 2: an older history's bins are not re-corrected
        columns += [decode_floats(state[key]) if key in state else [0.0] * m
                    for key in ('wh', 'wb')]
        n = [int(v) for v in state['n']]
        if int(state['max_points']) != m or any(len(c) != m for c in columns) or len(n) != m:
            raise ValueError(f'history state must have {m} bins')
        width = decode_float(state['width'])
        if not width > 0.0:
            raise ValueError(f'history bin width must be > 0, got {width!r}')
        self.t_start, self.t_last = decode_float(state['t_start']), decode_float(state['t_last'])
        self.width = width
        self._w, self._wt, self._wu, self._wh, self._wb = columns
        self._n = n
        self.offset = decode_float(state.get('offset', 0.0))
        self.opened = int(state['opened'])
        self._occupied = sum(1 for k in n if k)
        self.independent = bool(state.get('independent', False))

    @property
    def spacing(self) -> float:
        """Mean time between the points added [s] (0 before two)."""
        added = sum(self._n)
        return (self.t_last - self.t_start) / (added - 1) if added > 1 else 0.0

    def _merge(self) -> None:
        half = self.max_points // 2
        for name in ('_w', '_wt', '_wu', '_wh', '_wb', '_n'):
            values = getattr(self, name)
            merged = [values[2 * i] + values[2 * i + 1] for i in range(half)]
            setattr(self, name, merged + [type(values[0])(0)] * half)
        self.width *= 2.0
        self._occupied = sum(1 for n in self._n if n)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Occupied bins: mean time since t_start [s], mean u [-], precision [1/-^2].

        The precision of a bin's u: the sum of independent measurements', the mean of
        posteriors'. Each bin's u is re-corrected to :attr:`offset` (module docstring).
        """
        n = np.asarray(self._n, dtype=float)
        keep = n > 0
        w = np.asarray(self._w)[keep]
        precision = w if self.independent else w / n[keep]
        wu = np.asarray(self._wu)[keep] + (
            np.asarray(self._wb)[keep] - self.offset * np.asarray(self._wh)[keep])
        return (np.asarray(self._wt)[keep] / w, wu / w, precision)
