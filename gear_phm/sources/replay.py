"""Replay source: the JointState topic of a bag (and its truth topics), read with gear_phm.bagio.

Building the source reads the whole bag once and keeps only what pacing needs: the log time
of every JointState message and which of them lack the two joints. So a missing topic, a
truncated or corrupt bag or absent joint names fail at start, never half-way, and memory does
not grow with the bag. :meth:`ReplaySource.items` then reads the bag again, lazily, on every
pass and yields the recorded CDR bytes unchanged.
"""
from __future__ import annotations

from collections.abc import Generator, Sequence
from itertools import count
from pathlib import Path
from typing import Any

import numpy as np

from gear_phm.bagio import BagError, BagReader
from gear_phm.codec import decode_joint_state_buffer
from gear_phm.interfaces import (JOINT_STATE_TYPE, JOINT_STATES, TRUTH_EFFICIENCY,
                                 TRUTH_FRICTION, VECTOR3_STAMPED_TYPE)
from gear_phm.sources import Channel, Item, one_line, PASS_END, Recorded, SourceError

#: JointState messages decoded together while checking a bag (bounds the memory of the check).
CHECK_BATCH = 10_000


class ReplaySource:
    """The messages of ``bag_path`` from ``start_offset`` [s] on, paced by their log times.

    ``elapsed_ns`` is log time - first log time (plus one pass length per completed pass when
    ``loop`` is set; a pass lasts from the first to the last message plus the median
    JointState period). JointState messages without both joints are left out and counted in
    :attr:`dropped` by reason; the truth topics come along when ``replay_truth`` is set and
    the bag has them as Vector3Stamped.
    """

    mode = 'replay'

    def __init__(self, bag_path: str, *, motor_joint: str, load_joint: str, topic: str = '',
                 rate_factor: float = 1.0, start_offset: float = 0.0, loop: bool = False,
                 replay_truth: bool = True) -> None:
        if not bag_path:
            raise SourceError('parameter bag_path is empty: replay needs a bag')
        self.bag_path = bag_path
        self.path = Path(bag_path).expanduser()
        self.speed = float(rate_factor)
        self.loop = loop
        self.dropped: dict[str, int] = {}
        self._joints = (motor_joint, load_joint)
        try:
            with BagReader(self.path) as bag:
                self.topic = _pick_topic(bag, topic)
                self._channels: dict[str, Channel] = {self.topic: 'joints'}
                if replay_truth:
                    truths: tuple[tuple[str, Channel], ...] = (
                        (TRUTH_FRICTION, 'truth_friction'), (TRUTH_EFFICIENCY, 'truth_efficiency'))
                    for truth, channel in truths:
                        name = bag.resolve_topic(truth)
                        if bag.topics.get(name) == VECTOR3_STAMPED_TYPE:
                            self._channels[name] = channel
                self._start_ns = bag.start_ns + int(round(start_offset * 1e9))
                if start_offset > 0 and self._start_ns > bag.end_ns:
                    raise SourceError(
                        f'parameter start_offset {start_offset:g} s is beyond the end of bag '
                        f'{self.path} ({(bag.end_ns - bag.start_ns) * 1e-9:.3f} s long)')
                self._check(bag, start_offset)
        except BagError as exc:
            raise SourceError(one_line(exc)) from None

    def _check(self, bag: BagReader, start_offset: float) -> None:
        """Read the bag once, keeping only what pacing needs.

        That is the positions of unusable JointState messages, the first and last log time of
        everything replayed, and the median JointState period, counted per distinct period
        (so memory grows with the spread of the periods, not with the bag). Read in batches
        (:meth:`BagReader.raw_batches`: each topic in log-time order, as :meth:`items` meets
        its messages), decoded in place.
        """
        rejected: list[int] = []
        truth_ns: list[int] = []                    # log times of the first and last truth
        periods: dict[int, int] = {}                # period [ns] between kept -> how often
        kept_ns: list[int] = []                     # first and last kept log time
        joints = 0                                  # JointState messages so far
        first_raw: bytes | None = None
        for batch in bag.raw_batches(list(self._channels), CHECK_BATCH):
            after = np.flatnonzero(batch.log_time_ns >= self._start_ns)
            if not after.size:
                continue
            times = batch.log_time_ns[after]
            if self._channels[batch.topic] != 'joints':
                truth_ns = [min([*truth_ns[:1], int(times.min())]),
                            max([*truth_ns[1:], int(times.max())])]
                continue
            offsets, lengths = batch.offsets[after], batch.lengths[after]
            if first_raw is None:
                first_raw = bytes(batch.buffer[int(offsets[0]):int(offsets[0] + lengths[0])])
            decoded = decode_joint_state_buffer(batch.buffer, offsets, lengths, *self._joints)
            for position, reason in decoded.rejected_at:
                rejected.append(joints + position)
                self.dropped[reason] = self.dropped.get(reason, 0) + 1
            joints += after.size
            times = times[decoded.message_index]
            if times.size:
                steps = np.diff(times, prepend=kept_ns[1]) if kept_ns else np.diff(times)
                for step, times_seen in zip(*np.unique(steps, return_counts=True)):
                    periods[int(step)] = periods.get(int(step), 0) + int(times_seen)
                kept_ns[:] = [kept_ns[0] if kept_ns else int(times[0]), int(times[-1])]
        if first_raw is None:
            raise SourceError(f'topic {self.topic} of bag {self.path} has no message after '
                              f'start_offset {start_offset:g} s')
        if len(rejected) == joints:
            raise SourceError(
                f'joints {self._joints[0]!r} and {self._joints[1]!r} (parameters motor_joint, '
                f'load_joint) are not in the messages of {self.topic} in bag {self.path}: '
                f'names are {_joint_names(first_raw)} ({", ".join(sorted(self.dropped))})')
        self._rejected = frozenset(rejected)
        self._first_ns = min([kept_ns[0], *truth_ns])
        last_ns = max([kept_ns[-1], *truth_ns])
        self._pass_ns = last_ns - self._first_ns + _median(periods)

    def items(self) -> Generator[tuple[int, Item], None, None]:
        """Read the bag again for every pass: one Recorded per message kept, then PASS_END."""
        for passes in count():
            offset_ns = passes * self._pass_ns
            with BagReader(self.path) as bag:
                index = -1                          # position among the JointState messages
                for topic, t_ns, raw in bag.raw_messages(list(self._channels),
                                                         start_ns=self._start_ns):
                    channel = self._channels[topic]
                    if channel == 'joints':
                        index += 1
                        if index in self._rejected:
                            continue
                    yield t_ns - self._first_ns + offset_ns, Recorded(channel, t_ns, raw)
            yield offset_ns + self._pass_ns, PASS_END
            if not self.loop:
                return

    def describe(self) -> Sequence[tuple[str, Any]]:
        return [('bag', self.bag_path), ('topic', self.topic), ('rate_factor', self.speed)]


def _median(counts: dict[int, int]) -> int:
    """Return ``int(numpy.median(values))`` of the values counted in ``counts``.

    ``counts``: value -> how often; 0 when there are none.
    """
    total = sum(counts.values())
    if not total:
        return 0
    values = sorted(counts)
    ends = np.cumsum([counts[value] for value in values])
    middle = sorted({(total - 1) // 2, total // 2})
    picks = [values[int(np.searchsorted(ends, k, side='right'))] for k in middle]
    return int(np.mean(np.array(picks, dtype=np.int64)))


def _pick_topic(bag: BagReader, topic: str) -> str:
    """``topic`` checked, or the bag's only JointState topic, or its /joint_states."""
    if topic:
        return bag.require_topic(topic, JOINT_STATE_TYPE)
    candidates = bag.topics_of_type(JOINT_STATE_TYPE)
    if not candidates:
        raise BagError(f'bag {bag.path} has no {JOINT_STATE_TYPE} topic (topics: '
                       f'{", ".join(f"{t} [{k}]" for t, k in sorted(bag.topics.items()))})')
    if len(candidates) == 1:
        return candidates[0]
    for preferred in ('/' + JOINT_STATES, JOINT_STATES):
        if preferred in candidates:
            return preferred
    raise BagError(f'bag {bag.path} has several {JOINT_STATE_TYPE} topics '
                   f'({", ".join(candidates)}): set parameter topic')


def _joint_names(raw: bytes) -> str:
    """Return the joint names of a JointState CDR payload, for an error message."""
    from rosbags.typesys import Stores, get_typestore
    try:
        msg: Any = get_typestore(Stores.ROS2_JAZZY).deserialize_cdr(raw, JOINT_STATE_TYPE)
    except Exception as exc:  # noqa: BLE001 only to describe an already rejected message
        return f'unreadable ({one_line(exc)})'
    return str(list(msg.name))
