"""Bounded histories (gear_phm.offline.decimate): bins keep the first, last and extremes."""
from __future__ import annotations

import numpy as np

from gear_phm.offline.decimate import Binned


def test_binned_keeps_first_last_and_extremes_in_bounded_bins() -> None:
    """Bins merge pairwise: limit..2 limit bins, each its first record, its min and max."""
    rng = np.random.default_rng(7)
    n = 1000
    values = rng.normal(size=n)
    values[::13] = np.nan                        # NaN ignored by the envelope
    stamps = np.arange(n, dtype=np.int64) * 10
    kept = Binned(8, ('stamp_ns', 'x'), ('x',), objects=True)
    done = 0
    for size in rng.integers(1, 90, size=100).tolist():
        part = slice(done, min(done + size, n))
        kept.extend({'stamp_ns': stamps[part], 'x': values[part]},
                    list(range(n))[part])
        done = part.stop
        if done == n:
            break
    assert kept.count == n and kept.stride == 64 and 8 <= kept.bins <= 16
    first = kept.first()
    expected = np.append(np.arange(0, n, 64), n - 1)          # first of each bin, the last
    assert np.array_equal(first['stamp_ns'], stamps[expected])
    assert kept.objects() == expected.tolist()
    envelope = kept.envelope()
    assert envelope.count.sum() == n
    for i, start in enumerate(range(0, n, 64)):
        assert envelope.low['x'][i] == np.nanmin(values[start:start + 64])
        assert envelope.high['x'][i] == np.nanmax(values[start:start + 64])
    everything = Binned(None, ('x',))
    everything.extend({'x': values[:500]})
    everything.extend({'x': values[500:]})
    assert np.array_equal(everything.first()['x'], values, equal_nan=True)
