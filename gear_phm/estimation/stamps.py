"""Stamp screening and loss counting for a stream of samples (no ROS, no clock).

:class:`StampScreen` decides, sample by sample and in arrival order, which stamps extend the
stream's timeline, and counts the samples the timeline shows missing:

- **In sequence**: a stamp ``s`` with ``0 < s - last <= jump`` is accepted (``last`` is the
  newest accepted stamp; ``jump`` is :data:`JUMP_PERIODS` expected sample periods, at most
  ``max_gap``, the estimator's sensor_timeout).
- **Equal** to ``last``: dropped as ``duplicate_stamp``; the open segment goes on after it
  (:attr:`Segment.drops`), counted as if it cut it.
- **Slightly earlier** (within ``jump`` before ``last``): dropped as ``backwards`` (out of
  order, or a small clock step back: the samples resume once their stamps pass ``last``).
- **Far earlier** (more than ``jump`` before ``last``, e.g. a zero stamp) or **far later**
  (more than ``jump`` after it): held. If the next stamps continue the held one (increasing,
  and for a run far back still far back), ``run_length`` of them in a row make a *run*: a
  run of earlier stamps is a bag loop or a rig restart and resets the estimator (``reset``
  policy; with ``skip`` far earlier stamps are dropped at once), a run of later stamps is a
  real jump (a pause, a lost burst) and is accepted. A stamp that brings the stream back in
  sequence with ``last`` first drops the held stamps as ``backwards`` or ``future``: a lone
  stray stamp never moves the timeline. The very first stamps need ``run_length`` of them
  within ``jump`` of each other to start the timeline.

**Expected sample period and loss.** Differences between consecutive accepted stamps
(timeline gaps longer than ``max_gap`` excluded: those are sensor timeouts, not losses) are
collected in blocks of :data:`BLOCK` and each block's median is taken. The expected period
is the smallest block median of the last ``hold`` seconds of stamps (the newest block if
none is that recent). A gap ``d > 1.5 T`` counts ``round(d / T) - 1`` missing samples.
A rig that raises its rate is followed within one block. A rig that lowers its rate is
reported as losing samples until the slower rate has lasted ``hold`` seconds, then taken as
its new rate: stamps alone cannot tell a slower rig from a node that keeps missing the same
share of samples. Before the first block is complete the gaps wait, and are judged with its
median when it completes.

Decisions depend only on the sequence of stamps, never on how it is split into batches.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

#: Differences per block of the period estimate.
BLOCK = 100
#: A jump of more than this many expected periods is held until confirmed by a run.
JUMP_PERIODS = 100
#: A difference above this many expected periods is a gap with missing samples.
GAP_FACTOR = 1.5
#: Samples screened per vectorised step.
FAST_SPAN = 4096


@dataclass
class Segment:
    """Accepted samples to process in order.

    Positions in the screened array, the missing samples counted just before each, and whether
    the estimator restarts before them.
    """

    index: np.ndarray
    missing: np.ndarray
    reset_before: bool = False
    #: positions of the duplicate stamps dropped between the segment's samples (each of them
    #: counts as ``duplicate_stamp`` from the next sample on); a segment is not cut at them
    drops: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))


@dataclass
class Screened:
    """What :meth:`StampScreen.screen` made of an array of stamps.

    ``steps`` in order, each a :class:`Segment` or a drop ``(reason, count)``; ``held``:
    positions of the trailing samples held for a run (to be screened again in front of the next
    stamps).
    """

    steps: list[Segment | tuple[str, int]] = field(default_factory=list)
    held: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))


class StampScreen:
    """See the module docstring. ``run_length`` >= 1; times in integer nanoseconds."""

    def __init__(self, run_length: int, max_gap_ns: int, hold_ns: int,
                 allow_reset: bool = True) -> None:
        self.run_length = int(run_length)
        self.max_gap_ns = int(max_gap_ns)
        self.hold_ns = int(hold_ns)
        self.allow_reset = allow_reset
        self.last: int | None = None              # newest accepted stamp [ns]
        self.period_ns: float | None = None       # expected sample period [ns]
        self._block: list[np.ndarray] = []        # differences of the open block
        self._block_size = 0
        self._blocks: deque[tuple[int, float]] = deque()   # (stamp at completion, median)
        self._waiting: list[np.ndarray] = []      # differences before the first block
        self._stamp0 = 0                          # stamp before the differences being fed
        self.missing = 0                          # samples counted missing so far
        #: (stamp [ns], new period [ns]) of each period change in the last :meth:`screen`
        self.period_changes: list[tuple[int, float]] = []
        self._period_before: float | None = None  # the period before that call

    def configure(self, run_length: int, max_gap_ns: int, hold_ns: int,
                  allow_reset: bool) -> None:
        """Set new parameters; the timeline and the period estimate are kept."""
        self.run_length, self.max_gap_ns = int(run_length), int(max_gap_ns)
        self.hold_ns, self.allow_reset = int(hold_ns), allow_reset

    @property
    def jump_ns(self) -> int:
        """Largest step accepted without a confirming run [ns]."""
        if self.period_ns is None:
            return self.max_gap_ns
        return int(min(self.max_gap_ns, JUMP_PERIODS * self.period_ns))

    def period_at(self, stamp_ns: int | None) -> float | None:
        """Return the period [ns] learnt up to ``stamp_ns``.

        Learnt from the samples of the last :meth:`screen` call up to ``stamp_ns`` (None: before
        any of them).
        """
        period = self._period_before
        if stamp_ns is not None:
            for at, value in self.period_changes:
                if at > stamp_ns:
                    break
                period = value
        return period

    # --- period and loss -----------------------------------------------------------------
    def _missing(self, diffs: np.ndarray, period: float) -> np.ndarray:
        lost = np.rint(diffs / period).astype(np.int64) - 1
        return np.where(diffs > GAP_FACTOR * period, np.maximum(lost, 0), 0)

    def _add_diffs(self, diffs: np.ndarray, stop_on_change: bool) -> tuple[int, np.ndarray]:
        """Feed timeline differences [ns] (each <= max_gap) to the period estimate.

        Return how many were consumed and the missing samples counted at each. With
        ``stop_on_change`` it stops right after a block that changes the period (the jump limit
        changes too). Blocks are handled together with numpy; only block completions loop in
        Python.
        """
        n = diffs.size
        first = BLOCK - self._block_size             # differences that complete the open block
        ends = np.arange(first - 1, n, BLOCK)         # positions completing a block
        consumed = n
        period = self.period_ns
        if ends.size:
            head = np.concatenate(self._block + [diffs[:first]])
            rest = diffs[first:first + BLOCK * (ends.size - 1)].reshape(-1, BLOCK)
            medians = np.concatenate(([np.median(head)], np.median(rest, axis=1)))
            stamps_at = self._stamp0 + np.cumsum(diffs)[ends]
            for end, median, now in zip(ends.tolist(), medians.tolist(), stamps_at.tolist()):
                self._blocks.append((now, median))
                while len(self._blocks) > 1 and self._blocks[0][0] < now - self.hold_ns:
                    self._blocks.popleft()
                new = min(m for _, m in self._blocks)
                changed = new != self.period_ns
                self.period_ns = new
                if changed:
                    self.period_changes.append((int(now), new))
                if changed and (stop_on_change or period is None):
                    consumed = end + 1
                    break
            tail_start = first + BLOCK * (ends.size - 1) if consumed == n else consumed
            tail = diffs[tail_start:consumed] if consumed == n else diffs[:0]
            self._block = [tail] if tail.size else []
            self._block_size = tail.size
        else:
            self._block.append(diffs)
            self._block_size += n
        used = diffs[:consumed]
        out = np.zeros(consumed, dtype=np.int64)
        if period is not None:
            out[:] = self._missing(used, period)
        elif ends.size and ends[0] < consumed:        # the first block: judge what waited
            assert self.period_ns is not None         # that block set it
            waited = np.concatenate(self._waiting + [used])
            out[-1] = int(self._missing(waited, self.period_ns).sum())
            self._waiting = []
        else:
            self._waiting.append(used)
        self._stamp0 += int(used.sum())
        return consumed, out

    def _count(self, stamps: np.ndarray, prev: int | None) -> np.ndarray:
        """Return the missing samples before each of the accepted ``stamps``.

        ``prev``: the accepted stamp before them, None after a restart. Updates the period
        estimate.
        """
        n = stamps.size
        out = np.zeros(n, dtype=np.int64)
        if prev is None:
            diffs, where = np.diff(stamps), np.arange(1, n)
        else:
            diffs = np.diff(stamps, prepend=np.int64(prev))
            where = np.arange(n)
        keep = diffs <= self.max_gap_ns               # longer: a sensor timeout, no loss
        for chunk_start, chunk_end in _runs(keep):
            self._stamp0 = int(stamps[where[chunk_start]] - diffs[chunk_start])
            pos = chunk_start
            while pos < chunk_end:
                used, missing = self._add_diffs(diffs[pos:chunk_end], False)
                out[where[pos:pos + used]] = missing
                pos += used
        self.missing += int(out.sum())
        return out

    def _restart_period(self) -> None:
        """Stamps restarted: block times are void; the last period stays until a new one."""
        self._blocks.clear()
        self._block, self._block_size, self._waiting = [], 0, []
        self._stamp0 = 0
        if self.period_ns is not None:
            self._blocks.append((np.iinfo(np.int64).min, self.period_ns))

    # --- screening -----------------------------------------------------------------------
    def screen(self, stamps: np.ndarray) -> Screened:
        """Screen ``stamps`` (int64 [ns], arrival order); see :class:`Screened`."""
        self.period_changes, self._period_before = [], self.period_ns
        stamps = np.asarray(stamps, dtype=np.int64)
        n = stamps.size
        steps: list[Segment | tuple[str, int]] = []
        index_chunks: list[np.ndarray] = []       # the open segment
        missing_chunks: list[np.ndarray] = []
        inner_drops: list[int] = []               # duplicates inside it
        reset = [False]

        def accept(index: np.ndarray, prev: int | None) -> None:
            index_chunks.append(index)
            missing_chunks.append(self._count(stamps[index], prev))
            self.last = int(stamps[index[-1]])

        def close_segment() -> None:
            trailing = 0                          # duplicates after its last sample
            if index_chunks:
                index = np.concatenate(index_chunks)
                drops = np.asarray(inner_drops, dtype=np.int64)
                trailing = int(np.count_nonzero(drops > index[-1]))
                steps.append(Segment(index, np.concatenate(missing_chunks), reset[0],
                                     drops[drops < index[-1]]))
                index_chunks.clear()
                missing_chunks.clear()
            inner_drops.clear()
            reset[0] = False
            if trailing:
                steps.append(('duplicate_stamp', trailing))

        def drop(reason: str, count: int = 1) -> None:
            close_segment()
            if steps and isinstance(steps[-1], tuple) and steps[-1][0] == reason:
                steps[-1] = (reason, steps[-1][1] + count)
            else:
                steps.append((reason, count))

        held: list[int] = []
        kind = ''

        def accept_run() -> None:
            prev = self.last
            if kind in ('backwards', 'start'):      # a new timeline
                close_segment()
                self._restart_period()
                reset[0] = kind == 'backwards'
                prev = None
            accept(np.asarray(held, dtype=np.int64), prev)
            held.clear()

        i = 0
        while i < n:
            last = self.last
            if not held and last is not None:
                # fast path: the longest stretch in sequence from i, up to a block that
                # changes the period (hence the jump limit)
                part = stamps[i:i + FAST_SPAN]
                step = np.diff(part, prepend=np.int64(last))
                bad = np.flatnonzero((step <= 0) | (step > self.jump_ns))
                k = int(bad[0]) if bad.size else part.size
                if k:
                    self._stamp0 = last
                    used, missing = self._add_diffs(step[:k], True)
                    index_chunks.append(np.arange(i, i + used))
                    missing_chunks.append(missing)
                    self.missing += int(missing.sum())
                    self.last = int(part[used - 1])
                    i += used
                    continue
            s = int(stamps[i])
            jump = self.jump_ns
            if held:
                p = int(stamps[held[-1]])
                reason = kind if kind != 'start' else ('backwards' if s > p else 'future')
                if last is not None and last < s <= last + jump:
                    drop(reason, len(held))       # lone stray stamp(s): back in line
                    held.clear()
                    continue
                if s == p or s == last:
                    drop('duplicate_stamp')
                    i += 1
                    continue
                if kind == 'future':
                    follows = s > p                   # losses may leave any gap
                elif kind == 'backwards':
                    assert last is not None           # 'backwards' follows an accepted stamp
                    follows = p < s < last - jump     # still far behind the timeline
                else:
                    follows = p < s <= p + jump       # the first stamps: in sequence
                if follows:
                    held.append(i)
                    i += 1
                    if len(held) >= self.run_length:
                        accept_run()
                    continue
                drop(reason, len(held))           # broken run: judge s afresh
                held.clear()
                continue
            if last is None:
                kind = 'start'
            elif s == last:
                if index_chunks:            # the segment goes on after it (not cut)
                    inner_drops.append(i)
                else:
                    drop('duplicate_stamp')
                i += 1
                continue
            elif s > last:
                kind = 'future'
            elif s >= last - jump or not self.allow_reset:
                drop('backwards')
                i += 1
                continue
            else:
                kind = 'backwards'
            held.append(i)
            i += 1
            if len(held) >= self.run_length:
                accept_run()
        close_segment()
        return Screened(steps, np.asarray(held, dtype=np.int64))


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, end) of each stretch of True in ``mask``."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], mask.view(np.int8), [0]))))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist()))
