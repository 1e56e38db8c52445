"""Statuses at marks (EstimatorPipeline.on_batch_marked) equal those of a stream cut there.

``gear-phm analyze`` stamps its /diagnostics so.

The stream is dirty on purpose: lost samples, non-finite values, duplicate and stray stamps,
a sensor timeout, and rejected messages, so that every counter of the status moves.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gear_phm.estimation import EstimatorConfig, EstimatorPipeline
from helpers.plant import lever_plant  # noqa: I100

CONFIG = EstimatorConfig(ratio=3.0, motor_torque_noise=0.05, load_torque_noise=0.05,
                         motor_inertia=0.01)


def _dirty_stream() -> list[np.ndarray]:
    run = lever_plant(7, 90.0, lambda t: 0.1 + 1e-3 * t)
    cols = [run.stamp_ns.copy(), run.motor_velocity.copy(), run.motor_effort.copy(),
            run.load_velocity.copy(), run.load_effort.copy()]
    cols[1][5000:5004] = np.nan                                   # non-finite speeds
    keep = np.ones(cols[0].size, dtype=bool)
    keep[20000:20040] = False                                     # 40 samples lost
    keep[50000:52500] = False                                     # a 2.5 s sensor timeout
    cols = [c[keep] for c in cols]
    for at, source in ((30000, 30000), (60000, 40000)):           # a duplicate, a stray
        cols = [np.insert(c, at, c[source]) for c in cols]
    return cols


def _values(status) -> dict[str, float | str]:
    values: dict[str, float | str] = {'level': status.level, 'message': status.message}
    for key, value in status.values:
        try:
            values[key] = float(value)
        except ValueError:
            values[key] = value
    return values


def _assert_same(got: dict, expected: dict, where: int) -> None:
    assert got.keys() == expected.keys(), where
    for key, value in expected.items():
        if isinstance(value, float) and not math.isnan(value):
            assert got[key] == pytest.approx(value, rel=1e-6, abs=1e-12), (where, key)
        else:
            assert str(got[key]) == str(value), (where, key)


def test_statuses_at_marks_equal_statuses_of_a_stream_cut_at_the_marks() -> None:
    cols = _dirty_stream()
    n = cols[0].size
    rng = np.random.default_rng(3)
    marks = sorted({*rng.integers(10, n - 10, size=40).tolist(), 100, 5002, 20000,
                    49990, 50001, 59000})
    rejected = [(1500, 'missing_joint'), (1500, 'short_arrays'), (45000, 'missing_joint')]

    cut = EstimatorPipeline(CONFIG)
    expected, estimates = [], []
    for begin, end in zip([0, *marks], [*marks, n]):
        for position, reason in rejected:
            if begin <= position < end or (position == n and end == n):
                cut.reject_message(reason)
        estimates += cut.on_batch(*(c[begin:end] for c in cols))
        if end < n:
            expected.append((len(estimates), _values(cut.status('e', end))))

    marked = EstimatorPipeline(CONFIG)
    got, snapshots = marked.on_batch_marked(*cols, marks=marks, rejected_at=rejected)
    assert [s.position for s in snapshots] == marks
    assert np.allclose([e.u for e in got], [e.u for e in estimates], rtol=1e-9)
    for mark, snapshot, (count, values) in zip(marks, snapshots, expected):
        assert snapshot.estimates == count, mark
        _assert_same(_values(marked.status('e', mark, snapshot)), values, mark)
    # the dirty parts moved the counters that the comparison covers
    final = _values(marked.status('e'))
    assert final['samples_missing'] >= 40 and final['dropped_nonfinite'] == 4
    assert final['events_timeout'] >= 1 and final['dropped_duplicate_stamp'] == 1
    assert final['dropped_missing_joint'] == 2 and final['dropped_short_arrays'] == 1
    assert final['samples_used'] == cut.samples_used


def test_marks_must_ascend_within_the_batch() -> None:
    cols = [c[:100] for c in _dirty_stream()]
    with pytest.raises(ValueError, match='marks must ascend'):
        EstimatorPipeline(CONFIG).on_batch_marked(*cols, marks=[50, 10])
    with pytest.raises(ValueError, match='marks must ascend'):
        EstimatorPipeline(CONFIG).on_batch_marked(*cols, marks=[101])


def test_format_values_is_format_value_of_each() -> None:
    """The fast path (str of plain floats, ints and strings) gives format_value's texts."""
    from gear_phm.status import format_value, format_values
    plain = [0.1, -0.0, 1e-300, 2.5e17, math.inf, -math.inf, math.nan, 7, -3, 'text']
    assert format_values(plain) == tuple(format_value(v) for v in plain)
    assert format_values(plain) == ('0.1', '-0.0', '1e-300', '2.5e+17', 'inf', '-inf', 'nan',
                                    '7', '-3', 'text')
    mixed = [*plain, True, np.float32(0.1), np.float64(0.2), np.int64(5)]
    assert format_values(mixed) == tuple(format_value(v) for v in mixed)
    assert format_values(mixed)[-4:] == ('1.0', '0.10000000149011612', '0.2', '5')
