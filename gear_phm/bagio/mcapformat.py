"""The MCAP format knowledge that gear_phm needs beyond mcap's own reader and writer.

Built on :mod:`mcap.opcode` (record types), :mod:`mcap.records` (record fields) and mcap's
constants (magic, footer size). What mcap does not offer, and the chunk reader
(:mod:`.chunks`), the recovery (:mod:`.recover_scan`, :mod:`.recover_rewrite`) and the
batch writer (:mod:`.batch_writer`) share, lives here once:

- the byte layouts that numpy reads and writes many records at a time (message record heads,
  message index records);
- the record walk over a buffer, and a strict parse of one record with mcap's record classes
  (a short field is an error, not fewer bytes);
- the footer probe (is the file finished?) and the summary and attachment CRC checks;
- chunk compression and decompression by compression name, with size and CRC checks.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator
import io
import os
import struct
from typing import Any, BinaryIO
import zlib

from mcap.data_stream import ReadDataStream, RecordBuilder
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.reader import FOOTER_SIZE
from mcap.records import (Attachment, Channel, Chunk, ChunkIndex, Footer, Header, McapRecord,
                          Message, MessageIndex, Metadata, Schema, Statistics)
from mcap.stream_reader import MAGIC_SIZE
from mcap.writer import CompressionType, MCAP0_MAGIC
import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from gear_phm.errors import GearPhmError

#: The 8 bytes at the start and at the end of every MCAP file.
MAGIC: bytes = MCAP0_MAGIC
#: Bytes of the Footer record (opcode, length, summary start, summary offset start, CRC).
FOOTER_BYTES: int = FOOTER_SIZE
#: Every record starts with its opcode (u8) and the length of its body (u64).
RECORD_HEAD = struct.Struct('<BQ')
#: A Message record up to its payload: opcode, length, channel id, sequence, log time and
#: publish time [ns]; as a struct (one record) and as a numpy dtype (many).
MESSAGE_HEAD = struct.Struct('<BQHIQQ')
_MESSAGE_HEAD_FIELDS = [('op', 'u1'), ('length', '<u8'), ('channel', '<u2'),
                        ('sequence', '<u4'), ('log_time', '<u8'), ('publish_time', '<u8')]
MESSAGE_HEAD_DTYPE = np.dtype(_MESSAGE_HEAD_FIELDS)
#: Bytes of a Message record's body before its payload.
MESSAGE_FIELDS = MESSAGE_HEAD.size - RECORD_HEAD.size
#: The fields of :data:`MESSAGE_HEAD_DTYPE` that readers check, up to the log time.
_HEAD_TO_LOG_TIME = np.dtype(_MESSAGE_HEAD_FIELDS[:-1])
#: A MessageIndex record up to its entries: opcode, length, channel id, entry bytes; each
#: entry is (log time [ns], record offset in the chunk), two u64.
MESSAGE_INDEX_HEAD = struct.Struct('<BQHI')
#: Records that only the summary section holds.
SUMMARY_OPCODES = frozenset({Opcode.CHUNK_INDEX, Opcode.ATTACHMENT_INDEX, Opcode.STATISTICS,
                             Opcode.METADATA_INDEX, Opcode.SUMMARY_OFFSET})
#: Chunk compression names and mcap's writer settings for them.
COMPRESSIONS = {'': CompressionType.NONE, 'zstd': CompressionType.ZSTD,
                'lz4': CompressionType.LZ4}

assert MESSAGE_HEAD.size == MESSAGE_HEAD_DTYPE.itemsize and MAGIC_SIZE == len(MAGIC)


class FormatError(GearPhmError):
    """Bytes that are not the MCAP record they should be (the message says which and why)."""


class NotMcap(FormatError):
    """The file does not start with the MCAP magic."""


def message_dtype(width: int) -> np.dtype:
    """Return the numpy dtype of Message records with ``width``-byte payloads."""
    return np.dtype([*_MESSAGE_HEAD_FIELDS, ('data', f'V{width}')])


def message_heads(data: np.ndarray, offsets: np.ndarray) -> Any:
    """Return the heads of the Message records at ``offsets`` in ``data`` (a uint8 array).

    The fields of :data:`MESSAGE_HEAD_DTYPE` up to the log time: op, length, channel,
    sequence, log_time. One copy of those bytes per record, no Python work per record.
    Raises FormatError when a record's head (to its payload) would run past ``data``.
    """
    if offsets.size and (offsets.min() < 0
                         or offsets.max() + MESSAGE_HEAD.size > data.size):
        msg = 'a message record offset is out of bounds'
        raise FormatError(msg)
    rows = sliding_window_view(data, _HEAD_TO_LOG_TIME.itemsize)[offsets]
    return rows.view(_HEAD_TO_LOG_TIME)[:, 0]


def message_index(buffer: bytes, at: int) -> tuple[int, np.ndarray]:
    """Return (channel id, entries) of the MessageIndex record at byte ``at`` of ``buffer``.

    The entries are an (N, 2) little-endian u64 array of (log time [ns], record offset).
    Raises FormatError when the entries do not fit the record.
    """
    _, length, channel, size = MESSAGE_INDEX_HEAD.unpack_from(buffer, at)
    if size % 16 or 6 + size > length:
        msg = 'malformed message index'
        raise FormatError(msg)
    entries = np.frombuffer(buffer, dtype='<u8', count=size // 8,
                            offset=at + MESSAGE_INDEX_HEAD.size)
    return channel, entries.reshape(size // 16, 2)


def records(data: bytes, start: int = 0, end: int | None = None
            ) -> Iterator[tuple[int, int, int]]:
    """Yield (opcode, offset, body length) of the records packed in ``data[start:end]``.

    Raises FormatError (at the first bad record) when a record runs past ``end``.
    """
    end = len(data) if end is None else end
    at = start
    while at < end:
        if at + RECORD_HEAD.size > end:
            msg = f'the record head at byte {at} is cut off'
            raise FormatError(msg)
        opcode, length = RECORD_HEAD.unpack_from(data, at)
        if at + RECORD_HEAD.size + length > end:
            msg = f'the record at byte {at} runs past the end'
            raise FormatError(msg)
        yield opcode, at, length
        at += RECORD_HEAD.size + length


class _StrictStream(ReadDataStream):
    """mcap's ReadDataStream, but a short read is an error (not silently fewer bytes)."""

    def read(self, length: int) -> bytes:
        try:
            data = super().read(length)
        except McapError:                       # EndOfFile
            data = b''
        if len(data) != length:
            msg = f'field of {length} bytes runs past the record'
            raise FormatError(msg)
        return data


_READERS: dict[int, Callable[[ReadDataStream], McapRecord]] = {
    Opcode.SCHEMA: Schema.read, Opcode.CHANNEL: Channel.read, Opcode.CHUNK: Chunk.read,
    Opcode.ATTACHMENT: Attachment.read, Opcode.METADATA: Metadata.read,
    Opcode.HEADER: Header.read, Opcode.FOOTER: Footer.read,
    Opcode.MESSAGE_INDEX: MessageIndex.read, Opcode.CHUNK_INDEX: ChunkIndex.read,
    Opcode.STATISTICS: Statistics.read}


def parse_record(opcode: int, body: bytes) -> McapRecord | None:
    """Return the record of ``opcode`` in ``body`` (its bytes after opcode and length).

    None for an opcode that gear_phm does not read (data end, summary offsets, indexes of
    attachments and metadata, unknown opcodes). Raises FormatError when the body does not
    parse.
    """
    stream = _StrictStream(io.BytesIO(body))
    try:
        if opcode == Opcode.MESSAGE:
            if len(body) < MESSAGE_FIELDS:
                msg = 'message record shorter than its header'
                raise FormatError(msg)
            message: McapRecord = Message.read(stream, len(body))
            return message
        reader = _READERS.get(opcode)
        return None if reader is None else reader(stream)
    except (FormatError, McapError, UnicodeDecodeError, struct.error, ValueError) as exc:
        msg = str(exc) or type(exc).__name__
        raise FormatError(msg) from None


def encode(record: McapRecord) -> bytes:
    """Return the bytes of ``record`` (opcode, length, body) as mcap's writer writes them."""
    builder = RecordBuilder()
    record.write(builder)
    return bytes(builder.end())  # type: ignore[no-untyped-call]


def compress(kind: CompressionType, data: bytes) -> tuple[str, bytes]:
    """Return (compression name, ``data`` compressed) for a chunk."""
    if kind == CompressionType.ZSTD:
        import zstandard
        return 'zstd', zstandard.compress(data)
    if kind == CompressionType.LZ4:
        import lz4.frame
        return 'lz4', lz4.frame.compress(data)
    return '', data


def decompress(chunk: Chunk) -> bytes:
    """Return the records of ``chunk``, checked against its size and its CRC (if written).

    Raises FormatError for an unknown compression, data that does not decompress, or a size
    or checksum mismatch.
    """
    compression = chunk.compression
    if compression not in COMPRESSIONS:
        msg = f'chunk compression {compression!r} is not supported'
        raise FormatError(msg)
    try:
        if compression == 'zstd':
            import zstandard
            data = zstandard.ZstdDecompressor().decompress(
                chunk.data, max_output_size=chunk.uncompressed_size)
        elif compression == 'lz4':
            import lz4.frame
            data = lz4.frame.decompress(chunk.data)
        else:
            data = chunk.data
    except Exception as exc:  # noqa: BLE001 (zstandard/lz4 raise their own error types)
        msg = f'{compression} data does not decompress ({exc})'
        raise FormatError(msg) from None
    if len(data) != chunk.uncompressed_size:
        msg = (f'size mismatch: {len(data)} bytes decompressed, the chunk says '
               f'{chunk.uncompressed_size}')
        raise FormatError(msg)
    if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
        msg = 'CRC mismatch (checksum of the decompressed records)'
        raise FormatError(msg)
    return bytes(data)


def chunk_records(chunk: Chunk) -> list[tuple[int, McapRecord]]:
    """Return (offset in the chunk, record) of the schemas, channels and messages of ``chunk``.

    Raises FormatError when the chunk does not decompress or check out, or a record of it
    does not parse.
    """
    data = decompress(chunk)
    out: list[tuple[int, McapRecord]] = []
    for opcode, at, length in records(data):
        if opcode in (Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE):
            start = at + RECORD_HEAD.size
            try:
                record = parse_record(opcode, data[start:start + length])
            except FormatError as exc:
                msg = f'record at byte {at} of the chunk: {exc}'
                raise FormatError(msg) from None
            assert record is not None
            out.append((at, record))
    return out


def read_footer(stream: BinaryIO) -> Footer | None:
    """Return the footer of the MCAP file open in ``stream``; None when it has none.

    No footer (or no end magic) means the writer did not finish. Reads only the first and
    last bytes. Raises NotMcap when the file does not start with the MCAP magic.
    """
    stream.seek(0)
    if stream.read(MAGIC_SIZE) != MAGIC:
        msg = 'not an MCAP file (no MCAP magic at its start)'
        raise NotMcap(msg)
    size = stream.seek(0, os.SEEK_END)
    if size < 2 * MAGIC_SIZE + FOOTER_BYTES:
        return None
    stream.seek(size - FOOTER_BYTES - MAGIC_SIZE)
    tail = stream.read(FOOTER_BYTES + MAGIC_SIZE)
    opcode, length = RECORD_HEAD.unpack_from(tail)
    if tail[-MAGIC_SIZE:] != MAGIC or opcode != Opcode.FOOTER \
            or length != FOOTER_BYTES - RECORD_HEAD.size:
        return None
    footer = parse_record(Opcode.FOOTER, tail[RECORD_HEAD.size:FOOTER_BYTES])
    assert isinstance(footer, Footer)
    return footer


def summary_crc_ok(stream: BinaryIO, footer: Footer, footer_end: int) -> bool:
    """Return whether the footer's summary CRC (if written, i.e. non-zero) matches.

    ``footer_end``: the byte offset just after the Footer record.
    """
    if footer.summary_crc == 0:
        return True
    start = footer.summary_start or (footer_end - FOOTER_BYTES)
    stream.seek(start)
    data = stream.read(footer_end - 4 - start)
    return zlib.crc32(data) == footer.summary_crc


def attachment_crc_ok(body: bytes) -> bool:
    """Return whether an Attachment record body's CRC (if written, i.e. non-zero) matches."""
    at = 16                                     # log time, create time
    for _ in range(2):                          # name, media type
        (length,) = struct.unpack_from('<I', body, at)
        at += 4 + length
    (size,) = struct.unpack_from('<Q', body, at)
    at += 8 + size
    (crc,) = struct.unpack_from('<I', body, at)
    return bool(crc == 0 or zlib.crc32(body[:at]) == crc)
