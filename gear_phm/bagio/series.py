"""A bag's time series as arrays: a Vector3Stamped topic, the bag's span of log time."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gear_phm.bagio.reader import BagError, BagReader
from gear_phm.codec import decode_vector3_stamped_buffer
from gear_phm.interfaces import stamp_to_ns, VECTOR3_STAMPED_TYPE


def read_vector_topic(path: Path, topic: str) -> tuple[np.ndarray, np.ndarray]:
    """Return (stamps [s], N x 3 values) of a Vector3Stamped topic, sorted by stamp.

    Decoded in batches (:func:`~gear_phm.codec.decode_vector3_stamped_buffer`); a topic with
    a payload that decoder refuses is read again message by message with rosbags. Raises
    :class:`~gear_phm.bagio.BagError` if the bag cannot be read, does not hold the topic
    with that type, or holds no message of it.
    """
    with BagReader(path) as bag:
        name = bag.require_topic(topic, VECTOR3_STAMPED_TYPE)
        parts = [decode_vector3_stamped_buffer(batch.buffer, batch.offsets, batch.lengths)
                 for batch in bag.raw_batches([name])]
        if all(part is not None for part in parts):
            decoded = [part for part in parts if part is not None]
            stamps = np.concatenate([s for s, _ in decoded]) if decoded else np.zeros(0)
            values = np.concatenate([v for _, v in decoded]) if decoded \
                else np.zeros((0, 3))
        else:
            rows = [(stamp_to_ns(m.header.stamp), m.vector.x, m.vector.y, m.vector.z)
                    for _, _, m in bag.messages([name])]
            stamps = np.array([r[0] for r in rows], dtype=np.int64)
            values = np.array([r[1:] for r in rows], dtype=float).reshape(-1, 3)
    if not stamps.size:
        msg = f'topic {topic} in {path} has no messages'
        raise BagError(msg) from None
    order = np.argsort(stamps, kind='stable')
    return stamps[order] * 1e-9, values[order]


def has_topic(path: Path, topic: str) -> bool:
    """Return whether the bag ``path`` holds ``topic`` (BagError if it cannot be read)."""
    with BagReader(path) as bag:
        return bag.resolve_topic(topic) in bag.topics


def bag_span(path: Path) -> tuple[float, float] | None:
    """Return the first and last log time [s] of the bag ``path``, or None if unreadable."""
    try:
        with BagReader(path) as bag:
            return bag.start_ns * 1e-9, bag.end_ns * 1e-9
    except BagError:
        return None
