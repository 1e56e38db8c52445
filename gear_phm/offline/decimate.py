"""Histories in bounded memory: consecutive records in bins that merge pairwise when full.

:class:`Binned` takes records batch by batch as numpy columns (and, optionally, one Python
object per record). Bin ``k`` holds records ``k * stride`` to ``(k + 1) * stride - 1``; once
``2 * limit`` bins are full, neighbours merge and ``stride`` doubles, so between ``limit`` and
``2 * limit`` bins are kept whatever the number of records. Per bin it keeps the first record
(evenly spaced samples, as a plot or a notebook reads them) and, for the ``envelope`` columns,
the least and greatest value (NaN ignored), so that a decimated plot still shows every
excursion. ``limit`` None keeps every record. The work is per batch, not per record.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from gear_phm.offline.records import Envelope

#: Bins of the plot's envelopes: between this and twice as many (analysis.png is ~1000 px
#: wide).
ENVELOPE_BINS = 1024
#: Chunks of bins kept before they are joined: each holds an array per column, a few bins long
#: once a bin spans a batch (about 100 bytes each: unjoined, they grew with the bag).
CHUNKS = 16


def _joined(chunks: list[np.ndarray]) -> np.ndarray:
    """Join the chunks into one array, kept as the only chunk, and return it."""
    if len(chunks) != 1:
        chunks[:] = [np.concatenate(chunks)]
    return chunks[0]


class Binned:
    """Bounded history of a series: first record and min/max of columns per bin (module doc).

    ``columns``: the names kept as the first record of each bin; ``envelope``: the names whose
    least and greatest value per bin are kept; ``objects``: keep one object per record too.
    """

    def __init__(self, limit: int | None, columns: Sequence[str],
                 envelope: Sequence[str] = (), objects: bool = False) -> None:
        if limit is not None and limit < 1:
            raise ValueError(f'limit must be >= 1, got {limit}')
        self.limit = limit
        self.names, self.envelope_names = tuple(columns), tuple(envelope)
        self.count = 0                           # records seen
        self.stride = 1                          # records per bin
        self.bins = 0
        self._first: dict[str, list[np.ndarray]] = {n: [] for n in self.names}
        self._low: dict[str, list[np.ndarray]] = {n: [] for n in self.envelope_names}
        self._high: dict[str, list[np.ndarray]] = {n: [] for n in self.envelope_names}
        self._counts: list[np.ndarray] = []
        self._objects: list[Any] | None = [] if objects else None
        self._last: dict[str, Any] = {}
        self._last_object: Any = None

    def extend(self, columns: Mapping[str, np.ndarray],
               objects: Sequence[Any] | None = None) -> None:
        """Add a batch of records.

        ``columns``: equal-length arrays of all the names given; ``objects``: one per record.
        """
        size = len(columns[self.names[0]]) if self.names else len(columns[self.envelope_names[0]])
        done = 0
        while done < size:
            if self.limit is not None and self.count == 2 * self.limit * self.stride:
                self._merge()
            take = size - done
            if self.limit is not None:
                take = min(take, 2 * self.limit * self.stride - self.count)
            self._add({name: np.asarray(columns[name])[done:done + take]
                       for name in {*self.names, *self.envelope_names}},
                      None if objects is None else objects[done:done + take])
            done += take

    def _add(self, columns: dict[str, np.ndarray], objects: Sequence[Any] | None) -> None:
        """Add records that fit in the bins (no merge needed)."""
        size = len(next(iter(columns.values())))
        bins = (self.count + np.arange(size)) // self.stride
        starts = np.concatenate(([0], np.flatnonzero(np.diff(bins)) + 1))
        counts = np.diff(np.append(starts, size))
        joins = self.count % self.stride != 0    # the first records fill the last bin
        new = starts[1:] if joins else starts
        grows = new.size > 0                     # no empty chunks: the last bin is [-1][-1]
        for name in self.names:
            if grows:
                self._first[name].append(columns[name][new])
        for name in self.envelope_names:
            low = np.fmin.reduceat(columns[name], starts)
            high = np.fmax.reduceat(columns[name], starts)
            if joins:
                last_low, last_high = self._low[name][-1], self._high[name][-1]
                last_low[-1] = np.fmin(last_low[-1], low[0])
                last_high[-1] = np.fmax(last_high[-1], high[0])
                low, high = low[1:], high[1:]
            if grows:
                self._low[name].append(low)
                self._high[name].append(high)
        if joins:
            self._counts[-1][-1] += counts[0]
            counts = counts[1:]
        if grows:
            self._counts.append(counts)
        if self._objects is not None and objects is not None:
            self._objects.extend(objects[i] for i in new.tolist())
            self._last_object = objects[-1]
        self._last = {name: values[-1] for name, values in columns.items()}
        self.bins += new.size
        self.count += size
        if len(self._counts) > CHUNKS:
            for chunks in (*self._first.values(), *self._low.values(), *self._high.values(),
                           self._counts):
                _joined(chunks)

    def _merge(self) -> None:
        """Neighbouring bins merge: half as many, each twice as long."""
        for name in self.names:
            self._first[name][:] = [_joined(self._first[name])[0::2]]
        for name in self.envelope_names:
            low, high = _joined(self._low[name]), _joined(self._high[name])
            self._low[name][:] = [np.fmin(low[0::2], low[1::2])]
            self._high[name][:] = [np.fmax(high[0::2], high[1::2])]
        counts = _joined(self._counts)
        self._counts[:] = [counts[0::2] + counts[1::2]]
        if self._objects is not None:
            del self._objects[1::2]
        self.bins //= 2
        self.stride *= 2

    def _with_last(self) -> bool:
        """Whether the last record is kept in addition to the first of each bin."""
        return (self.count - 1) % self.stride != 0

    def first(self) -> dict[str, np.ndarray]:
        """Return the first record of each bin, then the last record if not one of those."""
        out = {}
        for name in self.names:
            values = _joined(self._first[name]) if self._first[name] else np.zeros(0)
            if self._with_last():
                values = np.append(values, np.asarray(self._last[name], dtype=values.dtype))
            out[name] = values
        return out

    def objects(self) -> list[Any]:
        """Return the objects of :meth:`first`'s records."""
        kept = list(self._objects or ())
        if self._with_last():
            kept.append(self._last_object)
        return kept

    def envelope(self, stamp: str = 'stamp_ns') -> Envelope:
        """Return the bins as an :class:`Envelope`, stamped with column ``stamp`` [ns]."""
        stamps = _joined(self._first[stamp]) if self._first[stamp] else np.zeros(0, np.int64)
        counts = _joined(self._counts) if self._counts else np.zeros(0, np.int64)
        return Envelope(stamps, counts,
                        {name: _joined(self._first[name]) if self._first[name] else
                         np.zeros(0) for name in self.envelope_names if name in self.names},
                        {name: _joined(values) if values else np.zeros(0)
                         for name, values in self._low.items()},
                        {name: _joined(values) if values else np.zeros(0)
                         for name, values in self._high.items()})
