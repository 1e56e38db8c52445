"""An MCAP writer that appends a block of fixed-size messages in one numpy operation.

Why: ``gear-phm analyze`` writes about 0.8 output messages per input sample at 100 Hz, and
mcap's :class:`mcap.writer.Writer` costs about 10 us per ``add_message`` (a record object,
its serializer and the chunk bookkeeping, all per message). That alone is as much as rosbags
needs to read and decode one input message, so analyze could not keep up with rosbags' own
decoding of the same bag (docs/benchmarks.md, "Offline analysis speed").

What: :class:`BatchWriter` has the methods of mcap's ``Writer`` that
:class:`gear_phm.bagio.Rosbag2McapWriter` uses (``start``, ``register_schema``,
``register_channel``, ``add_message``, ``flush``, ``finish``) plus :meth:`add_block`, which
packs N message records of equal payload size with one structured numpy array and indexes
them with two arrays. Every record but the messages and message indexes is written with
mcap's own record classes (:mod:`mcap.records`), and the file layout is the one mcap's
``Writer`` produces with its defaults (schemas and channels inside chunks, message indexes
after each chunk, summary with repeated schemas and channels, statistics, chunk indexes and
summary offsets, summary CRC), plus the data-section CRC. The tests write the same records
through both writers and check that mcap's reader, rosbags and the package's chunk reader
return the same messages and summary from both files.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any, BinaryIO
import zlib

from mcap.opcode import Opcode
from mcap.records import (Channel, Chunk, ChunkIndex, DataEnd, Footer, Header, Schema,
                          Statistics, SummaryOffset)
from mcap.writer import CompressionType, LIBRARY_IDENTIFIER
import numpy as np

from gear_phm.bagio.mcapformat import (compress, encode, MAGIC, message_dtype, MESSAGE_FIELDS,
                                       MESSAGE_HEAD, MESSAGE_INDEX_HEAD, RECORD_HEAD)


class BatchWriter:
    """MCAP writer with a vectorised :meth:`add_block` (module docstring)."""

    def __init__(self, stream: BinaryIO, chunk_size: int = 1 << 20,
                 compression: CompressionType = CompressionType.ZSTD) -> None:
        self._stream = stream
        self._chunk_size = chunk_size
        self._compression = compression
        self._schemas: dict[int, Schema] = {}
        self._channels: dict[int, Channel] = {}
        self._chunk_indexes: list[ChunkIndex] = []
        self._stats = Statistics(attachment_count=0, channel_count=0,
                                 channel_message_counts={}, chunk_count=0, message_count=0,
                                 message_end_time=0, message_start_time=0, metadata_count=0,
                                 schema_count=0)
        self._data_crc = 0
        self._written = 0
        # the open chunk: record bytes, their size, times and per-channel (times, offsets)
        self._parts: list[bytes] = []
        self._size = 0
        self._messages = 0
        self._start = 0
        self._end = 0
        #: The open chunk's (channels, log times, offsets) per write, indexed when it closes.
        self._index: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    # -- data section ---------------------------------------------------------------------
    def _write(self, data: bytes) -> None:
        self._stream.write(data)
        self._data_crc = zlib.crc32(data, self._data_crc)
        self._written += len(data)

    def start(self, profile: str = '', library: str = LIBRARY_IDENTIFIER) -> None:
        """Write the magic and the Header record."""
        self._write(MAGIC)
        self._write(encode(Header(profile=profile, library=library)))

    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        """Add a Schema (into the open chunk, as mcap's Writer does); returns its id."""
        schema_id = len(self._schemas) + 1
        schema = Schema(id=schema_id, data=data, encoding=encoding, name=name)
        self._schemas[schema_id] = schema
        self._stats.schema_count += 1
        self._append(encode(schema))
        return schema_id

    def register_channel(self, topic: str, message_encoding: str, schema_id: int,
                         metadata: dict[str, str] | None = None) -> int:
        """Add a Channel (into the open chunk, as mcap's Writer does); returns its id."""
        channel_id = len(self._channels) + 1
        channel = Channel(id=channel_id, topic=topic, message_encoding=message_encoding,
                          schema_id=schema_id, metadata=dict(metadata or {}))
        self._channels[channel_id] = channel
        self._stats.channel_count += 1
        self._append(encode(channel))
        return channel_id

    def add_message(self, channel_id: int, log_time: int, data: bytes, publish_time: int,
                    sequence: int = 0) -> None:
        """Append one message (any payload size)."""
        if log_time < 0:
            raise ValueError('MCAP log times are unsigned: got a negative time')
        record = MESSAGE_HEAD.pack(Opcode.MESSAGE, MESSAGE_FIELDS + len(data), channel_id,
                                   sequence, log_time, publish_time) + data
        self._index.append((np.array([channel_id]), np.array([log_time], dtype=np.int64),
                            np.array([self._size], dtype=np.uint64)))
        self._note(log_time, log_time, 1)
        self._append(record)

    def add_block(self, channel_ids: np.ndarray, log_times: np.ndarray, payloads: np.ndarray,
                  publish_times: np.ndarray | None = None,
                  sequences: np.ndarray | None = None) -> None:
        """Append N messages, in this order, with the rows of ``payloads`` as payloads.

        ``payloads`` is (N, L) uint8. Times [ns] are int64 >= 0; publish times default to the
        log times, sequences to 0.
        """
        if len(log_times):
            self.add_packed(*pack_block(channel_ids, log_times, payloads, publish_times,
                                        sequences))

    def add_packed(self, records: np.ndarray, channels: np.ndarray, log: np.ndarray) -> None:
        """Append the message records of :func:`pack_block` (or a slice of them), in order."""
        n = len(records)
        item = records.itemsize
        begin = 0
        while begin < n:                 # chunks end where mcap's Writer would end them
            room = max(1, (self._chunk_size - self._size) // item + 1)
            end = min(n, begin + room)
            self._add_records(records[begin:end], channels[begin:end], log[begin:end])
            begin = end

    def add_groups(self, parts: Sequence[tuple[int, np.ndarray, np.ndarray, np.ndarray]]
                   ) -> None:
        """Append N groups of messages; group g is part 0's messages g, then part 1's, ...

        A part is (channel id, log times (N, c) [ns] int64 >= 0, payloads (N, c, L) uint8,
        sequences (N, c)): c messages of one payload size L per group (c may differ between
        parts; (N,) and (N, L) mean c = 1). Publish times are the log times. The records are
        those :meth:`add_message` writes for the same messages in the same order, chunks
        ending where it ends them, packed with one structured array for all N groups.
        """
        shaped = []
        for channel, log_times, payloads, sequences in parts:
            payloads = np.asarray(payloads, dtype=np.uint8)
            if payloads.ndim == 2:
                payloads = payloads[:, None, :]
            n, count, width = payloads.shape
            log = np.asarray(log_times, dtype=np.int64).reshape(n, count)
            if count:
                shaped.append((channel, log, payloads, np.reshape(sequences, (n, count))))
        if not shaped or not len(shaped[0][1]):
            return
        if min(int(log.min()) for _, log, _, _ in shaped) < 0:
            raise ValueError('MCAP log times are unsigned: got a negative time')
        dtype = np.dtype([(f'm{i}', message_dtype(p.shape[2]), (p.shape[1],))
                          for i, (_, _, p, _) in enumerate(shaped)])
        groups = np.empty(len(shaped[0][1]), dtype=dtype)
        for i, (channel, log, payloads, sequences) in enumerate(shaped):
            records = groups[f'm{i}']
            width = payloads.shape[2]
            records['op'] = Opcode.MESSAGE
            records['length'] = MESSAGE_FIELDS + width
            records['channel'] = channel
            records['sequence'] = sequences
            records['log_time'] = log
            records['publish_time'] = log
            records['data'] = np.ascontiguousarray(payloads).view(f'V{width}')[..., 0]
        # every message's channel, log time and byte range in the packed groups, in order
        n = len(groups)
        sizes = np.concatenate([np.full(p.shape[1], MESSAGE_HEAD.size + p.shape[2])
                                for _, _, p, _ in shaped])
        ends = (np.arange(n)[:, None] * dtype.itemsize + np.cumsum(sizes)).ravel()
        starts = ends - np.tile(sizes, n)
        channels = np.tile(np.concatenate([np.full(p.shape[1], c) for c, _, p, _ in shaped]), n)
        log_times = np.concatenate([lg for _, lg, _, _ in shaped], axis=1).ravel()
        data = groups.view(np.uint8).ravel()
        begin, total = 0, len(ends)
        while begin < total:             # chunks end where mcap's Writer would end them
            limit = int(starts[begin]) + self._chunk_size - self._size
            end = min(total, max(begin, int(np.searchsorted(ends, limit, side='right'))) + 1)
            first = int(starts[begin])
            where = (self._size + starts[begin:end] - first).astype(np.uint64)
            self._index.append((channels[begin:end], log_times[begin:end], where))
            self._note(int(log_times[begin:end].min()), int(log_times[begin:end].max()),
                       end - begin)
            self._append(data[first:int(ends[end - 1])].tobytes())
            begin = end

    def _add_records(self, records: np.ndarray, channels: np.ndarray, log: np.ndarray) -> None:
        n = len(records)
        offsets = self._size + np.arange(n, dtype=np.uint64) * np.uint64(records.itemsize)
        self._index.append((channels, log, offsets))
        self._note(int(log.min()), int(log.max()), n)
        self._append(records.tobytes())

    def _note(self, first: int, last: int, n: int) -> None:
        """Count ``n`` messages logged between ``first`` and ``last`` [ns] (file, chunk)."""
        stats = self._stats
        stats.message_start_time = first if stats.message_count == 0 \
            else min(stats.message_start_time, first)
        stats.message_end_time = max(stats.message_end_time, last)
        stats.message_count += n
        self._start = first if self._messages == 0 else min(self._start, first)
        self._end = max(self._end, last)
        self._messages += n

    def _append(self, data: bytes) -> None:
        self._parts.append(data)
        self._size += len(data)
        if self._size > self._chunk_size:
            self._finish_chunk()

    def _finish_chunk(self) -> None:
        """Write the open chunk and its message indexes (nothing if it holds no message)."""
        if self._messages == 0:
            return
        data = b''.join(self._parts)
        compression, packed = compress(self._compression, data)
        chunk = encode(Chunk(compression=compression, data=packed,
                             message_start_time=self._start, message_end_time=self._end,
                             uncompressed_crc=zlib.crc32(data), uncompressed_size=len(data)))
        chunk_start = self._written
        self._write(chunk)
        index_start = self._written
        offsets: dict[int, int] = {}
        indexes: list[bytes] = []
        channels = np.concatenate([c for c, _, _ in self._index])
        all_times = np.concatenate([t for _, t, _ in self._index]).astype('<u8')
        all_where = np.concatenate([o for _, _, o in self._index]).astype('<u8')
        counts = self._stats.channel_message_counts
        _, first = np.unique(channels, return_index=True)
        for channel in channels[np.sort(first)].tolist():     # in order of first message
            mine = channels == channel
            times, where = all_times[mine], all_where[mine]
            counts[int(channel)] = counts.get(int(channel), 0) + times.size
            order = np.argsort(times, kind='stable')
            pairs = np.column_stack((times[order], where[order])).astype('<u8').tobytes()
            offsets[channel] = index_start + sum(len(i) for i in indexes)
            indexes.append(MESSAGE_INDEX_HEAD.pack(
                Opcode.MESSAGE_INDEX, MESSAGE_INDEX_HEAD.size - RECORD_HEAD.size + len(pairs),
                channel, len(pairs)) + pairs)
        index_bytes = b''.join(indexes)
        self._write(index_bytes)
        self._chunk_indexes.append(ChunkIndex(
            message_start_time=self._start, message_end_time=self._end,
            chunk_start_offset=chunk_start, chunk_length=len(chunk),
            message_index_offsets=offsets, message_index_length=len(index_bytes),
            compression=compression, compressed_size=len(packed),
            uncompressed_size=len(data)))
        self._stats.chunk_count += 1
        self._parts, self._size, self._messages, self._index = [], 0, 0, []

    def flush(self) -> None:
        """Close the open chunk (if it holds a message) and flush the stream."""
        self._finish_chunk()
        self._stream.flush()

    # -- summary --------------------------------------------------------------------------
    def finish(self) -> None:
        """Write the last chunk, DataEnd, the summary, the footer and the closing magic."""
        self._finish_chunk()
        self._write(encode(DataEnd(data_section_crc=self._data_crc)))
        summary_start = self._written
        groups: list[tuple[int, Sequence[Any]]] = [
            (Opcode.SCHEMA, list(self._schemas.values())),
            (Opcode.CHANNEL, list(self._channels.values())),
            (Opcode.STATISTICS, [self._stats]),
            (Opcode.CHUNK_INDEX, self._chunk_indexes),
            (Opcode.ATTACHMENT_INDEX, []),
            (Opcode.METADATA_INDEX, [])]
        summary = bytearray()
        offsets = []
        for opcode, records in groups:
            group_start = len(summary)
            for record in records:
                summary += encode(record)
            offsets.append(SummaryOffset(group_opcode=opcode,
                                         group_start=summary_start + group_start,
                                         group_length=len(summary) - group_start))
        summary_offset_start = summary_start + len(summary)
        for offset in offsets:
            summary += encode(offset)
        # the summary CRC covers the footer up to its CRC field
        footer = encode(Footer(summary_start=summary_start,
                               summary_offset_start=summary_offset_start, summary_crc=0))
        crc = zlib.crc32(footer[:-4], zlib.crc32(bytes(summary)))
        self._stream.write(bytes(summary))
        self._stream.write(encode(Footer(summary_start=summary_start,
                                         summary_offset_start=summary_offset_start,
                                         summary_crc=crc)))
        self._stream.write(MAGIC)


def pack_block(channel_ids: np.ndarray, log_times: np.ndarray, payloads: np.ndarray,
               publish_times: np.ndarray | None = None, sequences: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return (message records, channels, log times [ns]) of ``add_block``'s arguments.

    For :meth:`BatchWriter.add_packed`, whole or in slices. Raises ValueError for a negative time.
    """
    width = payloads.shape[1]
    log = np.asarray(log_times, dtype=np.int64)
    if len(log) and log.min() < 0:
        raise ValueError('MCAP log times are unsigned: got a negative time')
    records = np.empty(len(log), dtype=message_dtype(width))
    records['op'] = Opcode.MESSAGE
    records['length'] = MESSAGE_FIELDS + width
    records['channel'] = channel_ids
    records['sequence'] = 0 if sequences is None else sequences
    records['log_time'] = log
    records['publish_time'] = log if publish_times is None else publish_times
    records['data'] = np.ascontiguousarray(payloads, dtype=np.uint8).view(f'V{width}')[:, 0]
    return records, np.asarray(channel_ids), log


def vector3_stamped_rows(stamps_ns: np.ndarray, xyz: np.ndarray,
                         frame_id: str = '') -> np.ndarray:
    """Return the little-endian CDR payloads of N geometry_msgs/Vector3Stamped.

    An (N, L) uint8 array: row by row, the bytes of
    :func:`gear_phm.interfaces.vector3_stamped_cdr`.
    """
    return stamped_float64_rows(stamps_ns, xyz, frame_id)


def stamped_float64_rows(stamps_ns: np.ndarray, values: np.ndarray,
                         frame_id: str = '') -> np.ndarray:
    """Return the little-endian CDR payloads of N messages of a header and K float64.

    ``values`` (N, K): geometry_msgs/Vector3Stamped (x, y, z) or sensor_msgs/Temperature
    (temperature, variance). An (N, L) uint8 array.
    """
    values = np.asarray(values, dtype=float)
    frame = frame_id.encode() + b'\0'
    padding = (-(12 + len(frame))) % 8               # float64 alignment from the CDR origin
    dtype = np.dtype([('encapsulation', 'V4'), ('sec', '<i4'), ('nanosec', '<u4'),
                      ('frame_length', '<u4'), ('frame', f'V{len(frame) + padding}'),
                      ('values', '<f8', (values.shape[1],))])
    stamps = np.asarray(stamps_ns, dtype=np.int64)
    sec, nanosec = np.divmod(stamps, 1_000_000_000)
    if len(sec) and (sec.min() < -2**31 or sec.max() >= 2**31):
        raise ValueError('a stamp is outside the int32 seconds of builtin_interfaces/Time')
    rows = np.empty(len(stamps), dtype=dtype)
    rows['encapsulation'] = np.void(b'\x00\x01\x00\x00')
    rows['sec'] = sec
    rows['nanosec'] = nanosec
    rows['frame_length'] = len(frame)
    rows['frame'] = np.void(frame + b'\0' * padding)
    rows['values'] = values
    return rows.view(np.uint8).reshape(len(stamps), dtype.itemsize)
