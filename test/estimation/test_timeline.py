"""Timeline: stamp time, the publish grid, operating time and sensor timeouts."""
from __future__ import annotations

import numpy as np
import pytest

from gear_phm.estimation.timeline import Timeline


def _batch(time: Timeline, stamps_s: list[float], moving: list[bool],
           timeout: float = 0.5) -> tuple[int, np.ndarray]:
    stamps = np.round(np.array(stamps_s) * 1e9).astype(np.int64)
    if time.origin_ns is None:
        time.origin_ns = int(stamps[0])
    t = (stamps - time.origin_ns) * 1e-9
    return time.advance(stamps, t, np.ones(stamps.size, dtype=bool), np.array(moving), timeout,
                        True)


def test_operating_time_adds_the_moving_intervals_not_the_gaps() -> None:
    time = Timeline()
    n_gaps, gap_at = _batch(time, [10.0, 10.1, 10.2, 10.3], [True, True, False, True])
    assert (n_gaps, gap_at.tolist()) == (0, [])
    assert time.operating_time == pytest.approx(0.2)        # 10.1 and 10.3 end in motion
    n_gaps, gap_at = _batch(time, [12.0, 12.1], [True, True])      # after a 1.7 s gap
    assert (n_gaps, gap_at.tolist()) == (1, [0])
    assert time.operating_time == pytest.approx(0.3)
    assert time.operating_at.tolist() == pytest.approx([0.2, 0.3])
    assert time.operating_before == pytest.approx(0.2)
    assert time.operating_at_close(0) == time.operating_before
    assert time.operating_at_close(2) == time.operating_at[1]
    assert (time.last_stamp, time.max_stamp) == (12_100_000_000, 12_100_000_000)


def test_a_silence_times_out_once_and_its_gap_is_not_counted_again() -> None:
    time = Timeline()
    assert not time.silence(5.0, 0.5)                       # no sample yet
    _batch(time, [1.0, 1.1], [True, True])
    assert not time.silence(0.4, 0.5)
    assert time.silence(0.6, 0.5) and time.timed_out
    assert not time.silence(9.0, 0.5)                       # counted once
    n_gaps, _ = _batch(time, [3.0], [True])
    assert n_gaps == 0 and not time.timed_out


def test_the_publish_grid_gives_one_sample_a_cell_and_continues() -> None:
    time = Timeline()
    time.origin_ns = 0
    t = np.array([0.05, 0.1, 0.15, 0.31, 0.32])
    timely = np.ones(t.size, dtype=bool)
    assert time.publish_positions(t, timely, 10.0).tolist() == [0, 1, 3]
    assert time.grid == 3
    assert time.publish_positions(np.array([0.33, 0.41]), timely[:2], 10.0).tolist() == [1]
    assert time.publish_positions(t, timely, 0.0).tolist() == []
    assert time.next_output_stamp(10.0) == 500_000_000
    assert time.next_output_stamp(0.0) is None
    time.last_stamp = 410_000_000
    time.regrid(2.0)
    assert time.grid == 0 and time.next_output_stamp(2.0) == 500_000_000


def test_restart_starts_stamp_time_anew_and_keeps_operating_time() -> None:
    time = Timeline()
    _batch(time, [1.0, 1.1], [True, True])
    time.restart()
    assert (time.origin_ns, time.grid, time.last_stamp, time.timed_out) == (None,) * 3 + (False,)
    assert time.operating_time == pytest.approx(0.1)
    with pytest.raises(ValueError, match='no origin'):
        time.stamp_ns(1.0)
