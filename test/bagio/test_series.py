"""A bag's time series as arrays (gear_phm.bagio.series)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gear_phm.bagio import BagError, Rosbag2McapWriter
from gear_phm.bagio.series import bag_span, has_topic, read_vector_topic
from gear_phm.interfaces import HEALTH_RUL, TRUTH_FRICTION, Vector3Out


def _write(directory: Path, rows: list[tuple[float, float, float, float]],
           topic: str = HEALTH_RUL) -> Path:
    """Write Vector3Stamped rows (t [s], x, y, z) in the order given, log time = stamp."""
    with Rosbag2McapWriter(directory, compression=None) as writer:
        for t, x, y, z in rows:
            writer.write_output(Vector3Out(topic, int(round(t * 1e9)), x, y, z))
    return directory


def test_a_topic_is_read_as_arrays_sorted_by_stamp(tmp_path: Path) -> None:
    rows = [(2.0, 20.0, 16.0, 24.0), (0.5, 5.0, 4.0, 6.0), (1.0, 10.0, 8.0, 12.0)]
    bag = _write(tmp_path / 'bag', rows)
    times, values = read_vector_topic(bag, HEALTH_RUL)
    np.testing.assert_allclose(times, [0.5, 1.0, 2.0], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(values, [[5.0, 4.0, 6.0], [10.0, 8.0, 12.0],
                                           [20.0, 16.0, 24.0]])
    assert values.shape == (3, 3)


def test_topic_presence_and_span(tmp_path: Path) -> None:
    bag = _write(tmp_path / 'bag', [(1.0, 0.0, 0.0, 0.0), (3.5, 0.0, 0.0, 0.0)])
    assert has_topic(bag, HEALTH_RUL) and not has_topic(bag, TRUTH_FRICTION)
    span = bag_span(bag)
    assert span is not None and span == pytest.approx((1.0, 3.5), abs=2e-9)
    assert bag_span(tmp_path / 'missing') is None


def test_a_missing_topic_is_a_bag_error(tmp_path: Path) -> None:
    bag = _write(tmp_path / 'bag', [(1.0, 0.0, 0.0, 0.0)])
    with pytest.raises(BagError, match='truth/friction'):
        read_vector_topic(bag, TRUTH_FRICTION)
