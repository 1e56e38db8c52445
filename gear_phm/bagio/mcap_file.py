"""A chunked MCAP writer with the per-message cost of one struct pack (MCAP spec, version 0).

mcap's own ``Writer`` builds a record object and a message-index entry object for every
message, about 20 us each in this package's profile; ``gear-phm analyze`` writes around 80
messages per second of 1 kHz input, so that was a third of its time. This writer appends
each Message record to a ``bytearray`` with one ``struct.pack`` and keeps the message index
as flat integer arrays. The file layout is the one mcap's writer produces:

    magic, Header, Chunk (Schema/Channel/Message records) + MessageIndex per channel, ...,
    DataEnd, summary (Schema, Channel, ChunkIndex, Statistics, SummaryOffset), Footer, magic

The tests read every file it writes with mcap's reader, with rosbags, and through the chunk
indexes (:mod:`gear_phm.bagio.chunks`).
"""
from __future__ import annotations

from array import array
from collections.abc import Callable
import struct
from typing import BinaryIO
import zlib

MAGIC = b'\x89MCAP0\r\n'
_OP_HEADER, _OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE = 0x01, 0x02, 0x03, 0x04, 0x05
_OP_CHUNK, _OP_MESSAGE_INDEX, _OP_CHUNK_INDEX, _OP_STATISTICS = 0x06, 0x07, 0x08, 0x0B
_OP_SUMMARY_OFFSET, _OP_DATA_END = 0x0E, 0x0F
_MESSAGE = struct.Struct('<BQHIQQ')       # opcode, record length, channel, sequence, times
_U64_MAX = 2**64 - 1


def _string(text: str) -> bytes:
    data = text.encode()
    return struct.pack('<I', len(data)) + data


def _record(opcode: int, body: bytes) -> bytes:
    return struct.pack('<BQ', opcode, len(body)) + body


def _compressor(compression: str) -> Callable[[bytes], bytes] | None:
    if compression == 'zstd':
        import zstandard
        return zstandard.ZstdCompressor().compress
    if compression == 'lz4':
        import lz4.frame
        compress: Callable[[bytes], bytes] = lz4.frame.compress
        return compress
    if compression == '':
        return None
    raise ValueError(f"compression must be '', 'zstd' or 'lz4', got {compression!r}")


class McapFileWriter:
    """Write one MCAP file to ``stream``: register schemas and channels, add messages (any
    log-time order), :meth:`flush` to close the open chunk, :meth:`finish` for the summary.

    ``chunk_size`` [bytes of records] closes a chunk when reached; ``compression`` is '',
    'zstd' or 'lz4'. Output is a pure function of the calls (no clock is read).
    """

    def __init__(self, stream: BinaryIO, chunk_size: int = 1 << 20, compression: str = 'zstd',
                 profile: str = 'ros2', library: str = 'gear_phm') -> None:
        self._stream = stream
        self._chunk_size = int(chunk_size)
        self._compression = compression
        self._compress = _compressor(compression)
        self._position = 0
        self._write(MAGIC + _record(_OP_HEADER, _string(profile) + _string(library)))
        self._schemas: list[bytes] = []           # summary copies of the records
        self._channels: list[bytes] = []
        self._chunk_indexes: list[bytes] = []
        self._channel_counts: dict[int, int] = {}
        self._start = _U64_MAX
        self._end = 0
        self._chunk = bytearray()
        self._index: dict[int, array[int]] = {}       # channel -> [log time, offset, ...] of chunk
        self._finished = False

    def _write(self, data: bytes) -> None:
        self._stream.write(data)
        self._position += len(data)

    # -- definitions -----------------------------------------------------------------------
    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        """Add a schema; returns its id (1, 2, ...)."""
        schema_id = len(self._schemas) + 1
        body = struct.pack('<H', schema_id) + _string(name) + _string(encoding) \
            + struct.pack('<I', len(data)) + data
        record = _record(_OP_SCHEMA, body)
        self._schemas.append(record)
        self._chunk += record
        return schema_id

    def register_channel(self, topic: str, message_encoding: str, schema_id: int,
                         metadata: dict[str, str]) -> int:
        """Add a channel; returns its id (1, 2, ...)."""
        channel_id = len(self._channels) + 1
        pairs = b''.join(_string(k) + _string(v) for k, v in sorted(metadata.items()))
        body = struct.pack('<HH', channel_id, schema_id) + _string(topic) \
            + _string(message_encoding) + struct.pack('<I', len(pairs)) + pairs
        record = _record(_OP_CHANNEL, body)
        self._channels.append(record)
        self._channel_counts[channel_id] = 0
        self._chunk += record
        return channel_id

    # -- messages --------------------------------------------------------------------------
    def add_message(self, channel_id: int, log_time: int, data: bytes, publish_time: int,
                    sequence: int = 0) -> None:
        """Append one message (times [ns]) to the open chunk."""
        chunk = self._chunk
        index = self._index.get(channel_id)
        if index is None:
            if channel_id not in self._channel_counts:
                raise KeyError(f'channel {channel_id} is not registered')
            index = self._index[channel_id] = array('Q')
        index.append(log_time)
        index.append(len(chunk))
        chunk += _MESSAGE.pack(_OP_MESSAGE, 22 + len(data), channel_id, sequence, log_time,
                               publish_time)
        chunk += data
        self._channel_counts[channel_id] += 1
        if len(chunk) >= self._chunk_size:
            self._write_chunk()

    def flush(self) -> None:
        """Write the open chunk and push everything to the stream (``stream.flush()``)."""
        self._write_chunk()
        self._stream.flush()

    def _write_chunk(self) -> None:
        """Write the open chunk and its message indexes. A chunk without messages is not
        written: its schema/channel records wait for the first message (every chunk then
        has a message index, and the summary lists all definitions anyway)."""
        if not self._index:
            return
        records = bytes(self._chunk)
        start = min(min(entries[0::2]) for entries in self._index.values())
        end = max(max(entries[0::2]) for entries in self._index.values())
        payload = self._compress(records) if self._compress else records
        body = struct.pack('<QQQI', start, end, len(records), zlib.crc32(records)) \
            + _string(self._compression) + struct.pack('<Q', len(payload))
        chunk_offset = self._position
        self._write(_record(_OP_CHUNK, body + payload))
        chunk_length = self._position - chunk_offset
        index_offsets = []
        index_start = self._position
        for channel_id in sorted(self._index):
            entries = self._index[channel_id].tobytes()
            index_offsets.append((channel_id, self._position))
            self._write(_record(_OP_MESSAGE_INDEX, struct.pack('<HI', channel_id, len(entries))
                                + entries))
        offsets = b''.join(struct.pack('<HQ', c, o) for c, o in index_offsets)
        self._chunk_indexes.append(_record(_OP_CHUNK_INDEX, struct.pack(
            '<QQQQI', start, end, chunk_offset, chunk_length, len(offsets)) + offsets
            + struct.pack('<Q', self._position - index_start) + _string(self._compression)
            + struct.pack('<QQ', len(payload), len(records))))
        self._start = min(self._start, start)
        self._end = max(self._end, end)
        self._chunk = bytearray()
        self._index = {}

    @property
    def message_count(self) -> int:
        return sum(self._channel_counts.values())

    # -- closing ---------------------------------------------------------------------------
    def finish(self) -> None:
        """Flush, then write DataEnd, the summary section and the footer."""
        if self._finished:
            return
        self.flush()
        self._finished = True
        self._write(_record(_OP_DATA_END, struct.pack('<I', 0)))
        summary_start = self._position
        groups = []
        counts = b''.join(struct.pack('<HQ', c, n) for c, n in sorted(
            self._channel_counts.items()))
        statistics = _record(_OP_STATISTICS, struct.pack(
            '<QHIIIIQQI', self.message_count, len(self._schemas), len(self._channels), 0, 0,
            len(self._chunk_indexes), self._start if self.message_count else 0,
            self._end, len(counts)) + counts)
        summary = bytearray()
        for opcode, records in ((_OP_SCHEMA, self._schemas), (_OP_CHANNEL, self._channels),
                                (_OP_CHUNK_INDEX, self._chunk_indexes),
                                (_OP_STATISTICS, [statistics])):
            if records:
                groups.append((opcode, summary_start + len(summary),
                               sum(len(r) for r in records)))
                for record in records:
                    summary += record
        offset_start = summary_start + len(summary)
        for opcode, start, length in groups:
            summary += _record(_OP_SUMMARY_OFFSET, struct.pack('<BQQ', opcode, start, length))
        footer_head = struct.pack('<BQQQ', _OP_FOOTER, 20, summary_start, offset_start)
        crc = zlib.crc32(bytes(summary) + footer_head)
        self._write(bytes(summary) + footer_head + struct.pack('<I', crc) + MAGIC)
