"""The load torque from a force/torque sensor, matched to the joint samples by stamp.

With the estimator's ``load_torque_topic`` (``geometry_msgs/WrenchStamped``) the load torque
of each JointState sample is the wrench's torque along ``load_torque_axis`` times
``load_torque_sign``, taken from the wrench whose stamp is nearest the sample's, within
``load_torque_tolerance`` (0: the same stamp only). The sample's own load effort is ignored
(the JointState still needs an effort array; its load value may be anything, NaN too).

:class:`LoadTorqueMatcher` holds the wrenches received and decides each sample once no
nearer wrench can come: a wrench stamped at or after the sample's stamp plus the tolerance has
arrived (each topic arrives in stamp order), or the exact stamp did. A sample with no wrench
within the tolerance is dropped (counted); one left undecided longer than ``max_wait`` of
sample time behind the newest sample is decided with what has arrived, and so is every sample
when the node sees no new wrench for a ``batch_period`` (the stream's end).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

#: A joint sample's row: motor speed, motor torque, load speed, load torque.
Row = tuple[float, float, float, float]


@dataclass(frozen=True)
class Matched:
    """What :meth:`LoadTorqueMatcher.match` decided, in the samples' order."""

    #: stamps [ns] and rows of the samples to process, the load torque the wrench's
    stamps: list[int]
    rows: list[Row]
    #: samples to offer again later (no nearer wrench can be excluded yet)
    pending_stamps: list[int]
    pending_rows: list[Row]
    #: samples without a wrench within the tolerance
    dropped: int


class LoadTorqueMatcher:
    """Nearest-stamp match of load torques to joint samples (module docstring).

    ``tolerance_ns``: the largest stamp difference [ns] (0: exact); ``max_wait_ns``: sample
    time [ns] after which an undecided sample is decided with the wrenches at hand.
    Raises ValueError for a negative tolerance or wait.
    """

    def __init__(self, tolerance_ns: int, max_wait_ns: int) -> None:
        if tolerance_ns < 0 or max_wait_ns < 0:
            msg = f'tolerance and wait must be >= 0, got {tolerance_ns} and {max_wait_ns} ns'
            raise ValueError(msg)
        self.tolerance_ns = int(tolerance_ns)
        self.max_wait_ns = int(max_wait_ns)
        self._stamps: list[int] = []
        self._torques: list[float] = []
        self.received = 0

    def add(self, stamp_ns: int, torque: float) -> None:
        """Keep one wrench's load torque [N m] at ``stamp_ns``; an older stamp is put in order."""
        self.received += 1
        if self._stamps and stamp_ns < self._stamps[-1]:
            at = int(np.searchsorted(self._stamps, stamp_ns))
            self._stamps.insert(at, int(stamp_ns))
            self._torques.insert(at, float(torque))
            return
        self._stamps.append(int(stamp_ns))
        self._torques.append(float(torque))

    def match(self, stamps: Sequence[int], rows: Sequence[Row], final: bool = False
              ) -> Matched:
        """Give each sample its load torque, keep the undecided ones, drop the unmatched.

        ``final``: decide every sample with the wrenches at hand (at shutdown).
        """
        if not stamps:
            return Matched([], [], [], [], 0)
        wrench = np.asarray(self._stamps, dtype=np.int64)
        torque = np.asarray(self._torques, dtype=float)
        t = np.asarray(stamps, dtype=np.int64)
        tol = self.tolerance_ns
        if wrench.size:
            right = np.searchsorted(wrench, t, side='left').clip(0, wrench.size - 1)
            left = (right - 1).clip(0, wrench.size - 1)
            d_right, d_left = np.abs(wrench[right] - t), np.abs(wrench[left] - t)
            nearest = np.where(d_left <= d_right, left, right)
            distance = np.minimum(d_left, d_right)
            newest = int(wrench[-1])
        else:
            nearest = np.zeros(t.size, dtype=np.int64)
            distance = np.full(t.size, np.iinfo(np.int64).max)
            newest = np.iinfo(np.int64).min
        exact = distance == 0
        decided = exact | (newest >= t + tol)
        if not final:
            decided |= t < int(t.max()) - self.max_wait_ns
        else:
            decided[:] = True
        ok = decided & (distance <= tol)
        out = Matched([], [], [], [], int(np.count_nonzero(decided & ~ok)))
        for i, row in enumerate(rows):
            if ok[i]:
                out.stamps.append(int(t[i]))
                out.rows.append((row[0], row[1], row[2], float(torque[nearest[i]])))
            elif not decided[i]:
                out.pending_stamps.append(int(t[i]))
                out.pending_rows.append(row)
        self._forget(int(t[~decided].min()) if not decided.all() else int(t.max()))
        return out

    def _forget(self, oldest_ns: int) -> None:
        """Drop wrenches that no sample at or after ``oldest_ns`` can match (one kept)."""
        cut = int(np.searchsorted(self._stamps, oldest_ns - self.tolerance_ns, side='left'))
        cut = min(cut, len(self._stamps) - 1)
        if cut > 0:
            del self._stamps[:cut], self._torques[:cut]
