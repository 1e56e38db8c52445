"""Batches of raw messages, and a fast reader for indexed MCAP files.

:class:`RawBatch` holds many serialized messages of one topic as one buffer plus spans, so a
decoder can gather fields of all of them with numpy. :class:`McapChunkReader` builds such
batches straight from MCAP chunks: it reads each chunk with one ``read``, decompresses it
once, and locates the wanted topic's messages through the chunk's message index records
(arrays of (log time, offset) pairs, read with ``numpy.frombuffer``). There is no Python work
per message, and chunks holding only other topics are never read.

It takes MCAP files that have a summary section with chunk indexes and message indexes,
as rosbag2's MCAP storage plugin and :class:`~gear_phm.bagio.Rosbag2McapWriter` write them.
Anything else raises :class:`NotIndexed`, and the caller reads the file through rosbags.
Messages come out in log-time order per topic, also when chunks overlap in time.
"""
from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO
import zlib

import numpy as np

from gear_phm.interfaces import gather_values

_CHUNK_OP, _MESSAGE_OP, _MESSAGE_INDEX_OP = 0x06, 0x05, 0x07
_COMPRESSIONS = ('', 'zstd', 'lz4')
_MESSAGE_HEADER = 22               # channel id u16, sequence u32, log time u64, publish u64


class NotIndexed(Exception):
    """The file has no usable chunk/message index: read it another way."""


class CorruptChunk(Exception):
    """A chunk or its index is inconsistent (checksum, bounds, record types)."""


@dataclass(frozen=True)
class RawBatch:
    """Messages of one topic: payload ``i`` is ``buffer[offsets[i]:offsets[i] + lengths[i]]``,
    logged at ``log_time_ns[i]`` [ns]. Ordered by log time."""

    topic: str
    log_time_ns: np.ndarray
    buffer: bytes
    offsets: np.ndarray
    lengths: np.ndarray

    def __len__(self) -> int:
        return int(self.log_time_ns.size)

    def payloads(self) -> list[bytes]:
        """Each payload as its own ``bytes`` (for slow topics)."""
        view = memoryview(self.buffer)
        return [bytes(view[o:o + n]) for o, n in zip(self.offsets.tolist(),
                                                     self.lengths.tolist())]

    @classmethod
    def from_messages(cls, topic: str, messages: list[tuple[int, bytes]]) -> RawBatch:
        """Pack (log time [ns], payload) pairs into one batch (kept in the given order)."""
        lengths = np.fromiter((len(raw) for _, raw in messages), dtype=np.int64,
                              count=len(messages))
        offsets = np.zeros(len(messages), dtype=np.int64)
        np.cumsum(lengths[:-1], out=offsets[1:])
        times = np.fromiter((t for t, _ in messages), dtype=np.int64, count=len(messages))
        return cls(topic, times, b''.join(raw for _, raw in messages), offsets, lengths)

    def take(self, index: np.ndarray) -> RawBatch:
        """The messages at ``index``, copied into a compact buffer of their own."""
        offsets, lengths = self.offsets[index], self.lengths[index]
        starts = np.zeros(index.size, dtype=np.int64)
        np.cumsum(lengths[:-1], out=starts[1:])
        source = np.repeat(offsets - starts, lengths) + np.arange(int(lengths.sum()))
        buffer = np.frombuffer(self.buffer, dtype=np.uint8)[source].tobytes()
        return RawBatch(self.topic, self.log_time_ns[index], buffer, starts, lengths)


def concatenate(first: RawBatch, second: RawBatch) -> RawBatch:
    """``first`` then ``second`` as one batch (same topic)."""
    shift = len(first.buffer)
    return RawBatch(first.topic, np.concatenate((first.log_time_ns, second.log_time_ns)),
                    first.buffer + second.buffer,
                    np.concatenate((first.offsets, second.offsets + shift)),
                    np.concatenate((first.lengths, second.lengths)))


@dataclass(frozen=True)
class _Chunk:
    stream: BinaryIO
    start_offset: int
    length: int
    index_length: int
    compression: str
    uncompressed_size: int
    start_ns: int
    index_offsets: dict[int, int]       # channel id -> file offset of its MessageIndex


def _decompress(data: bytes, compression: str, size: int) -> bytes:
    if compression == '':
        return data
    if compression == 'zstd':
        import zstandard
        return zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
    if compression == 'lz4':
        import lz4.frame
        decompressed: bytes = lz4.frame.decompress(data)
        return decompressed
    raise CorruptChunk(f'chunk compression {compression!r} is not supported')


class McapChunkReader:
    """Reads the chunks of one or more MCAP files (the parts of one rosbag2 bag)."""

    def __init__(self, paths: Iterable[str | Path]) -> None:
        from mcap.exceptions import McapError
        from mcap.reader import make_reader

        self._streams: list[BinaryIO] = []
        self.topics: dict[int, dict[int, str]] = {}     # stream index -> channel id -> topic
        self._chunks: list[tuple[int, _Chunk]] = []
        try:
            for number, path in enumerate(paths):
                stream = open(path, 'rb')  # noqa: SIM115 (closed in close())
                self._streams.append(stream)
                try:
                    summary = make_reader(stream).get_summary()
                except (McapError, EOFError, ValueError) as exc:
                    raise NotIndexed(f'{path}: no readable summary ({exc})') from exc
                if summary is None or (not summary.chunk_indexes and summary.statistics
                                       and summary.statistics.message_count):
                    raise NotIndexed(f'{path}: no chunk index')
                self.topics[number] = {cid: ch.topic for cid, ch in summary.channels.items()}
                for index in summary.chunk_indexes:
                    if index.compression not in _COMPRESSIONS:
                        raise NotIndexed(f'{path}: chunk compression {index.compression!r}')
                    chunk = _Chunk(stream, index.chunk_start_offset, index.chunk_length,
                                   index.message_index_length, index.compression,
                                   index.uncompressed_size, index.message_start_time,
                                   dict(index.message_index_offsets))
                    if not chunk.index_offsets:     # unindexed (or definitions only)
                        raise NotIndexed(f'{path}: a chunk has no message index')
                    self._chunks.append((number, chunk))
        except BaseException:
            self.close()
            raise
        self._chunks.sort(key=lambda item: (item[1].start_ns, item[0], item[1].start_offset))

    def close(self) -> None:
        for stream in self._streams:
            stream.close()
        self._streams.clear()

    def __enter__(self) -> McapChunkReader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def batches(self, topics: Iterable[str]) -> Iterator[RawBatch]:
        """RawBatch per topic and chunk, in log-time order per topic (a message that a later
        chunk could precede is held back and merged into that chunk's batch)."""
        wanted = set(topics)
        plan = []
        for number, chunk in self._chunks:
            channels = {cid: topic for cid, topic in self.topics[number].items()
                        if topic in wanted and cid in chunk.index_offsets}
            if channels:
                plan.append((chunk, channels))
        carry: dict[str, RawBatch] = {}
        for position, (chunk, channels) in enumerate(plan):
            next_start = plan[position + 1][0].start_ns if position + 1 < len(plan) else None
            for batch in self._read(chunk, channels):
                if batch.topic in carry:
                    batch = concatenate(carry.pop(batch.topic), batch)
                    order = np.argsort(batch.log_time_ns, kind='stable')
                    batch = batch.take(order)
                if next_start is not None and len(batch) \
                        and batch.log_time_ns[-1] > next_start:
                    later = batch.log_time_ns > next_start
                    carry[batch.topic] = batch.take(np.flatnonzero(later))
                    batch = batch.take(np.flatnonzero(~later))
                if len(batch):
                    yield batch
        for batch in carry.values():
            yield batch

    def _read(self, chunk: _Chunk, channels: dict[int, str]) -> list[RawBatch]:
        """Batches of ``channels`` in one chunk, each sorted by log time."""
        block, data = self._decompressed(chunk)
        raw = np.frombuffer(data, dtype=np.uint8)
        batches = []
        for cid, topic in channels.items():
            at = chunk.index_offsets[cid] - chunk.start_offset
            if block[at] != _MESSAGE_INDEX_OP or \
                    int.from_bytes(block[at + 9:at + 11], 'little') != cid:
                raise CorruptChunk(f'chunk at byte {chunk.start_offset}: bad message index')
            count = int.from_bytes(block[at + 11:at + 15], 'little') // 16
            entries = np.frombuffer(block, dtype='<u8', count=2 * count,
                                    offset=at + 15).reshape(count, 2)
            times = entries[:, 0].astype(np.int64)
            records = entries[:, 1].astype(np.int64)
            if count and (records.max() + 9 + _MESSAGE_HEADER > len(data)):
                raise CorruptChunk(f'chunk at byte {chunk.start_offset}: index out of bounds')
            lengths = _integers(raw, records + 1, '<u8') - _MESSAGE_HEADER
            offsets = records + 9 + _MESSAGE_HEADER
            if count and ((raw[records] != _MESSAGE_OP).any()
                          or (_integers(raw, records + 9, '<u2') != cid).any()
                          or (_integers(raw, records + 15, '<u8') != times).any()
                          or (lengths < 0).any() or (offsets + lengths > len(data)).any()):
                raise CorruptChunk(f'chunk at byte {chunk.start_offset}: message index does '
                                   f'not match the messages')
            if count > 1 and (np.diff(times) < 0).any():
                order = np.argsort(times, kind='stable')
                times, offsets, lengths = times[order], offsets[order], lengths[order]
            batches.append(RawBatch(topic, times, data, offsets, lengths))
        return batches

    def _decompressed(self, chunk: _Chunk) -> tuple[bytes, bytes]:
        """(chunk record + its message indexes as read, decompressed records)."""
        stream = chunk.stream
        stream.seek(chunk.start_offset)
        block = stream.read(chunk.length + chunk.index_length)
        if len(block) < chunk.length + chunk.index_length or block[0] != _CHUNK_OP:
            raise CorruptChunk(f'chunk at byte {chunk.start_offset} is truncated or not a '
                               f'chunk record')
        # chunk: op, u64 len, u64 start, u64 end, u64 uncompressed size, u32 crc,
        # string compression, u64 records length, records
        crc = int.from_bytes(block[33:37], 'little')
        name_length = int.from_bytes(block[37:41], 'little')
        body = 41 + name_length + 8
        size = int.from_bytes(block[body - 8:body], 'little')
        if body + size > chunk.length:
            raise CorruptChunk(f'chunk at byte {chunk.start_offset}: records overrun the chunk')
        data = _decompress(block[body:body + size], chunk.compression, chunk.uncompressed_size)
        if len(data) != chunk.uncompressed_size or (crc and zlib.crc32(data) != crc):
            raise CorruptChunk(f'chunk at byte {chunk.start_offset}: checksum or size mismatch')
        return block, data


def _integers(raw: np.ndarray, starts: np.ndarray, dtype: str) -> np.ndarray:
    """Little-endian integers of type ``dtype`` at byte offsets ``starts`` (int64 out)."""
    return gather_values(raw, starts, dtype).astype(np.int64)
