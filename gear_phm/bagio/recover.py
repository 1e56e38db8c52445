"""Recover MCAP recordings whose writer died (``kill -9``) or whose bytes were damaged.

The file is walked record by record with mcap's record classes (:mod:`mcap.records`), the
way :class:`mcap.stream_reader.StreamReader` does, but with the byte offset of every record
known, so that each problem can be reported with its place in the file:

- a chunk whose CRC, size or compression does not check out is dropped whole, with its byte
  range, its log-time range and (from the message indexes that follow it) its message count.
  No byte of it is re-checksummed into the output;
- an attachment whose CRC fails, and any record that does not parse, is dropped likewise;
- an incomplete record at the end (the writer was killed mid-write) is dropped, and with it
  anything after a record whose length runs past the end of the file;
- index, statistics and summary records are not copied: mcap's ``Writer`` rebuilds them.

Schemas, channels (with or without schema), messages outside chunks, attachments and
metadata records are kept, in their order. A complete file (footer, magic, valid summary
CRC) in which nothing had to be dropped is left as it is. The output names what was dropped
in an MCAP metadata record ``gear_phm.recover`` (and in metadata.yaml ``custom_data``), so a
recovered file never looks like a clean recording.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
import io
import os
from pathlib import Path
import re
import shutil
import struct
import zlib

from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.records import (Attachment, Channel, Chunk, ChunkIndex, Footer, Header, McapRecord,
                          Message, MessageIndex, Metadata, Schema, Statistics)
from mcap.writer import CompressionType, Writer
import yaml

from gear_phm.bagio.writer import qos_list, TopicInfo, write_metadata
from gear_phm.errors import GearPhmError

MAGIC = b'\x89MCAP0\r\n'
_RECORD_HEAD = struct.Struct('<BQ')             # opcode, record length
_FOOTER_BYTES = 1 + 8 + 20                      # Footer record: opcode, length, fields
_COMPRESSION = {'': CompressionType.NONE, 'zstd': CompressionType.ZSTD,
                'lz4': CompressionType.LZ4}
_ROS_SCHEMA_ENCODINGS = ('ros2msg', 'ros2idl')
#: Name of the MCAP metadata record (and metadata.yaml custom_data key prefix) of a recovery.
RECOVER_METADATA = 'gear_phm.recover'


class RecoverError(GearPhmError):
    """The input cannot be recovered (not MCAP, not ROS 2 where needed, output in the way);
    the message names the file and the problem on one line. Nothing was written."""


class _Unreadable(GearPhmError):
    """A record's bytes do not parse (a damaged length or string)."""


class _StrictStream(ReadDataStream):
    """mcap's ReadDataStream, but a short read is an error (not silently fewer bytes)."""

    def read(self, length: int) -> bytes:
        try:
            data = super().read(length)
        except McapError:                       # EndOfFile
            data = b''
        if len(data) != length:
            raise _Unreadable(f'field of {length} bytes runs past the record')
        return data


_READERS: dict[int, Callable[[ReadDataStream], McapRecord]] = {
    Opcode.SCHEMA: Schema.read, Opcode.CHANNEL: Channel.read, Opcode.CHUNK: Chunk.read,
    Opcode.ATTACHMENT: Attachment.read, Opcode.METADATA: Metadata.read,
    Opcode.HEADER: Header.read, Opcode.FOOTER: Footer.read,
    Opcode.MESSAGE_INDEX: MessageIndex.read, Opcode.CHUNK_INDEX: ChunkIndex.read,
    Opcode.STATISTICS: Statistics.read}


def _parse(opcode: int, body: bytes) -> McapRecord | None:
    """The record of ``opcode`` in ``body`` (its bytes after opcode and length), or None for
    an opcode recover does not copy. Raises _Unreadable."""
    stream = _StrictStream(io.BytesIO(body))
    try:
        if opcode == Opcode.MESSAGE:
            if len(body) < 22:
                raise _Unreadable('message record shorter than its header')
            message: McapRecord = Message.read(stream, len(body))
            return message
        reader = _READERS.get(opcode)
        return None if reader is None else reader(stream)
    except (_Unreadable, McapError, UnicodeDecodeError, struct.error, ValueError) as exc:
        raise _Unreadable(str(exc) or type(exc).__name__) from None


def _records(data: bytes) -> Iterator[tuple[int, int, bytes]]:
    """(offset, opcode, body) of the records packed in ``data`` (a chunk's content)."""
    position = 0
    while position < len(data):
        if position + 9 > len(data):
            raise _Unreadable(f'record header at byte {position} of the chunk is cut off')
        opcode, length = _RECORD_HEAD.unpack_from(data, position)
        end = position + 9 + length
        if end > len(data):
            raise _Unreadable(f'record at byte {position} of the chunk runs past it')
        yield position, opcode, data[position + 9:end]
        position = end


def _decompress(chunk: Chunk) -> bytes:
    """The chunk's records, checked against its size and CRC. Raises _Unreadable."""
    try:
        if chunk.compression == 'zstd':
            import zstandard
            data = zstandard.ZstdDecompressor().decompress(
                chunk.data, max_output_size=chunk.uncompressed_size)
        elif chunk.compression == 'lz4':
            import lz4.frame
            data = lz4.frame.decompress(chunk.data)
        elif chunk.compression == '':
            data = chunk.data
        else:
            raise _Unreadable(f'unknown compression {chunk.compression!r}')
    except _Unreadable:
        raise
    except Exception as exc:  # noqa: BLE001 (zstandard/lz4 raise their own error types)
        raise _Unreadable(f'{chunk.compression} data does not decompress ({exc})') from None
    if len(data) != chunk.uncompressed_size:
        raise _Unreadable(f'{len(data)} bytes decompressed, the chunk says '
                          f'{chunk.uncompressed_size}')
    if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
        raise _Unreadable('CRC mismatch')
    return data


def _attachment_crc_ok(body: bytes) -> bool:
    """Whether an Attachment record body's CRC (if written, i.e. non-zero) matches."""
    at = 16
    for _ in range(2):                          # name, media type
        (length,) = struct.unpack_from('<I', body, at)
        at += 4 + length
    (size,) = struct.unpack_from('<Q', body, at)
    at += 8 + size
    (crc,) = struct.unpack_from('<I', body, at)
    return bool(crc == 0 or zlib.crc32(body[:at]) == crc)


@dataclass(frozen=True)
class Dropped:
    """A byte range [``start``, ``end``) of the source that recover did not use."""

    start: int
    end: int
    what: str                                   # 'chunk', 'attachment', 'tail', ...
    reason: str
    log_start_ns: int | None = None
    log_end_ns: int | None = None
    #: messages lost, from the chunk's message indexes (None: not known)
    messages: int | None = None

    def describe(self) -> str:
        """One line: what, where, which log times, how many messages, why."""
        if self.what == 'messages':             # no byte range: their definition was lost
            return self.reason
        text = f'{self.what} at bytes {self.start}-{self.end}'
        if self.log_start_ns is not None and self.log_end_ns is not None:
            text += (f', log time {self.log_start_ns * 1e-9:.3f}-'
                     f'{self.log_end_ns * 1e-9:.3f} s')
        if self.messages is not None:
            text += f', {self.messages} messages'
        return f'{text}: {self.reason}'


@dataclass(eq=False)
class Scan:
    """What one MCAP file holds that recover can use, and what it cannot."""

    path: Path
    profile: str = ''
    library: str = ''
    #: footer and end magic read, summary CRC valid
    complete: bool = False
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    #: (offset, opcode) of usable records, in file order: chunks, messages, attachments,
    #: metadata
    usable: list[tuple[int, int]] = field(default_factory=list)
    dropped: list[Dropped] = field(default_factory=list)
    counts: dict[int, int] = field(default_factory=dict)    # channel id -> messages
    start_ns: int | None = None
    end_ns: int | None = None
    compression: str | None = None
    attachments: int = 0
    metadata: int = 0
    #: chunks written without a CRC (their content could not be checked)
    unchecked_chunks: int = 0
    #: indexes or statistics that disagree with the data (nothing lost; they are rebuilt)
    problems: list[str] = field(default_factory=list)

    @property
    def messages(self) -> int:
        return sum(self.counts.values())

    @property
    def intact(self) -> bool:
        """Complete, nothing had to be dropped and the indexes agree: no rewrite needed."""
        return self.complete and not self.dropped and not self.problems

    def _message(self, message: Message) -> None:
        self.counts[message.channel_id] = self.counts.get(message.channel_id, 0) + 1
        t = message.log_time
        self.start_ns = t if self.start_ns is None else min(self.start_ns, t)
        self.end_ns = t if self.end_ns is None else max(self.end_ns, t)

    def _define(self, record: McapRecord, into: Scan | None = None) -> None:
        target = into or self
        if isinstance(record, Schema) and record.id != 0:
            target.schemas.setdefault(record.id, record)
        elif isinstance(record, Channel):
            target.channels.setdefault(record.id, record)


def scan(path: str | Path) -> Scan:
    """Walk ``path`` record by record; see the module docstring. Raises RecoverError when it
    is not an MCAP file."""
    path = Path(path)
    try:
        size = path.stat().st_size
        stream = open(path, 'rb')  # noqa: SIM115 (closed below)
    except OSError as exc:
        raise RecoverError(f'cannot read {path}: {exc.strerror or exc}') from None
    with stream:
        if stream.read(8) != MAGIC:
            raise RecoverError(f'{path}: not an MCAP file (no MCAP magic at its start)')
        walk = _Walk(Scan(path), stream, size)
        walk.run()
    return walk.result


class _Walk:
    """The record loop of :func:`scan`."""

    def __init__(self, result: Scan, stream: io.BufferedReader, size: int) -> None:
        self.result, self.stream, self.size = result, stream, size
        self.pending: Dropped | None = None     # a dropped chunk, counting its indexes
        self.pending_count = 0
        self.summary: Scan | None = None        # definitions repeated after DataEnd
        #: the last good chunk's message index, channel -> sorted (log time, offset)
        self.expected: dict[int, list[tuple[int, int]]] | None = None
        self.indexed: dict[int, int] = {}       # channel -> file offset of its MessageIndex
        self.chunk_at = (0, 0, 0)               # (offset, length, end of its indexes)
        self.chunk_times = (0, 0)               # its (message start, end time) [ns]
        #: chunk offset -> (length, channel -> MessageIndex offset, indexes length, times)
        self.chunks: dict[int, tuple[int, dict[int, int], int, tuple[int, int]]] = {}
        self.chunk_indexes = 0

    def run(self) -> None:
        result, position = self.result, 8
        while True:
            head = self.stream.read(9)
            if len(head) < 9:
                self._settle()
                result.dropped.append(Dropped(
                    position, self.size, 'end of file',
                    'no footer (the writer did not finish)' if position == self.size
                    else 'incomplete record (the writer did not finish)'))
                return
            opcode, length = _RECORD_HEAD.unpack(head)
            end = position + 9 + length
            if end > self.size:
                self._settle()
                result.dropped.append(Dropped(
                    position, self.size, 'tail', f'a record of {length} bytes runs past the '
                    f'end of the file (the writer was stopped, or its length is damaged)'))
                return
            body = self.stream.read(length)
            if opcode != Opcode.MESSAGE_INDEX:
                self._settle()
            if self._record(position, end, opcode, body):
                return
            position = end

    def _settle(self) -> None:
        """Close the previous chunk: check that its message indexes were complete, or report
        it (when dropped) with the messages its indexes listed."""
        if self.expected is not None:
            offset, length, end = self.chunk_at
            if self.indexed and set(self.indexed) != set(self.expected):
                self._problem(f'chunk at byte {offset}: message indexes missing for '
                              f'channels {sorted(set(self.expected) - set(self.indexed))}')
            self.chunks[offset] = (length, dict(self.indexed),
                                   end - offset - length if self.indexed else 0,
                                   self.chunk_times)
            self.expected = None
        if self.pending is not None:
            dropped, count = self.pending, self.pending_count
            self.result.dropped.append(Dropped(
                dropped.start, dropped.end, dropped.what, dropped.reason, dropped.log_start_ns,
                dropped.log_end_ns, count if count else None))
            self.pending = None

    def _record(self, position: int, end: int, opcode: int, body: bytes) -> bool:
        """Handle one record; True at the footer."""
        result = self.result
        try:
            record = _parse(opcode, body)
        except _Unreadable as exc:
            if opcode in (Opcode.CHUNK, Opcode.MESSAGE, Opcode.ATTACHMENT, Opcode.METADATA,
                          Opcode.SCHEMA, Opcode.CHANNEL, Opcode.FOOTER):
                result.dropped.append(Dropped(position, end, Opcode(opcode).name.lower(),
                                              f'unreadable record ({exc})'))
            return opcode == Opcode.FOOTER
        if isinstance(record, Footer):
            self._footer(position, end, record)
            return True
        if isinstance(record, Header):
            result.profile, result.library = record.profile, record.library
        elif isinstance(record, (Schema, Channel)):
            result._define(record, self.summary)
        elif opcode == Opcode.DATA_END:
            self.summary = Scan(result.path)
        elif self.summary is not None:
            self._summary_record(record)
        elif isinstance(record, Message):
            result._message(record)
            result.usable.append((position, opcode))
        elif isinstance(record, Chunk):
            self._chunk(position, end, record)
        elif isinstance(record, MessageIndex):
            if self.expected is not None:
                self._check_index(position, end, record)
            if self.pending is not None:
                self.pending_count += len(record.records)
                self.pending = Dropped(self.pending.start, end, self.pending.what,
                                       self.pending.reason, self.pending.log_start_ns,
                                       self.pending.log_end_ns)
        elif isinstance(record, Attachment):
            if _attachment_crc_ok(body):
                result.attachments += 1
                result.usable.append((position, opcode))
            else:
                result.dropped.append(Dropped(position, end, 'attachment',
                                              f'{record.name!r}: CRC mismatch'))
        elif isinstance(record, Metadata):
            result.metadata += 1
            result.usable.append((position, opcode))
        return False

    def _chunk(self, position: int, end: int, chunk: Chunk) -> None:
        result = self.result
        try:
            inner = _chunk_records(chunk)
        except _Unreadable as exc:
            self.pending, self.pending_count = Dropped(
                position, end, 'chunk', str(exc), chunk.message_start_time,
                chunk.message_end_time), 0
            return
        result.unchecked_chunks += chunk.uncompressed_crc == 0
        if result.compression is None:
            result.compression = chunk.compression
        self.expected, self.indexed, self.chunk_at = {}, {}, (position, end - position, end)
        for offset, item in inner:
            if isinstance(item, Message):
                result._message(item)
                self.expected.setdefault(item.channel_id, []).append((item.log_time, offset))
            else:
                result._define(item)
        for entries in self.expected.values():
            entries.sort()
        times = [t for entries in self.expected.values() for t, _ in entries]
        self.chunk_times = (chunk.message_start_time, chunk.message_end_time)
        if times and self.chunk_times != (min(times), max(times)):
            self._problem(f'chunk at byte {position}: its log-time range does not match '
                          f'its messages')
        result.usable.append((position, Opcode.CHUNK))

    def _problem(self, text: str) -> None:
        self.result.problems.append(text)

    def _check_index(self, position: int, end: int, index: MessageIndex) -> None:
        """A MessageIndex after a good chunk must list exactly that chunk's messages."""
        assert self.expected is not None
        offset = self.chunk_at[0]
        if sorted(index.records) != self.expected.get(index.channel_id, []) \
                or index.channel_id in self.indexed:
            self._problem(f'chunk at byte {offset}: the message index of channel '
                          f'{index.channel_id} (bytes {position}-{end}) does not match it')
        self.indexed[index.channel_id] = position
        self.chunk_at = (offset, self.chunk_at[1], end)

    def _summary_record(self, record: McapRecord | None) -> None:
        """Check the summary's chunk indexes and statistics against the data section."""
        if isinstance(record, ChunkIndex):
            self.chunk_indexes += 1
            known = self.chunks.get(record.chunk_start_offset)
            if known is None or known != (record.chunk_length,
                                          dict(record.message_index_offsets),
                                          record.message_index_length,
                                          (record.message_start_time,
                                           record.message_end_time)):
                self._problem(f"the summary's index of the chunk at byte "
                              f'{record.chunk_start_offset} does not match it')
        elif isinstance(record, Statistics):
            counts = {c: n for c, n in record.channel_message_counts.items() if n}
            if record.message_count != self.result.messages \
                    or (counts and counts != self.result.counts):
                self._problem(f'the statistics count {record.message_count} messages, the '
                              f'data section holds {self.result.messages}')

    def _footer(self, position: int, end: int, footer: Footer) -> None:
        result = self.result
        result.complete = self.stream.read(9) == MAGIC \
            and _summary_crc_ok(self.stream, footer, end)
        if not result.complete:
            result.dropped.append(Dropped(
                position, self.size, 'footer', 'summary CRC mismatch or no end magic (the '
                'summary is not used; recover rebuilds it)'))
            return
        if self.chunk_indexes and self.chunk_indexes != len(self.chunks):
            self._problem(f'the summary indexes {self.chunk_indexes} chunks, the data '
                          f'section holds {len(self.chunks)} good ones')
        if self.summary is not None:            # a checked summary may define what a
            for record in (*self.summary.schemas.values(),      # dropped chunk defined
                           *self.summary.channels.values()):
                result._define(record)


def _chunk_records(chunk: Chunk) -> list[tuple[int, McapRecord]]:
    """(offset in the chunk, record) of the schemas, channels and messages of a chunk whose
    CRC and size check out."""
    out = []
    for offset, opcode, body in _records(_decompress(chunk)):
        if opcode in (Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE):
            try:
                out.append((offset, _parse(opcode, body)))
            except _Unreadable as exc:
                raise _Unreadable(f'record at byte {offset} of the chunk: {exc}') from None
    return out  # type: ignore[return-value]


def _summary_crc_ok(stream: io.BufferedReader, footer: Footer, footer_end: int) -> bool:
    """Whether the footer's summary CRC (if written) matches the summary section."""
    if footer.summary_crc == 0:
        return True
    start = footer.summary_start or (footer_end - _FOOTER_BYTES)
    stream.seek(start)
    data = stream.read(footer_end - 4 - start)
    return zlib.crc32(data) == footer.summary_crc


def unfinished(path: str | Path) -> str | None:
    """Why the MCAP file ``path`` needs ``gear-phm recover`` (no footer, no summary), or None
    when it has both (or is not MCAP at all). Reads only its first and last bytes."""
    try:
        with open(path, 'rb') as stream:
            if stream.read(8) != MAGIC:
                return None
            size = stream.seek(0, os.SEEK_END)
            if size < 8 + _FOOTER_BYTES + 8:
                return 'it has no footer (the writer did not finish)'
            stream.seek(size - _FOOTER_BYTES - 8)
            tail = stream.read(_FOOTER_BYTES + 8)
    except OSError:
        return None
    opcode, length = _RECORD_HEAD.unpack_from(tail)
    if tail[-8:] != MAGIC or opcode != Opcode.FOOTER or length != 20:
        return 'it has no footer (the writer did not finish)'
    summary_start, = struct.unpack_from('<Q', tail, 9)
    if summary_start == 0:
        return 'it has no summary section (no index)'
    return None


# --- writing -------------------------------------------------------------------------------

def _write(source: Scan, out: Path) -> tuple[int, list[Dropped]]:
    """Write the usable records of ``source`` to the new file ``out`` with mcap's Writer.

    Returns (messages written, further drops: messages whose channel or schema was lost).
    """
    schema_ids: dict[int, int] = {}
    channel_ids: dict[int, int] = {}
    lost: dict[str, int] = {}
    written = 0
    with open(source.path, 'rb') as stream, open(out, 'xb') as sink:
        writer = Writer(sink, compression=_COMPRESSION.get(source.compression or 'zstd',
                                                           CompressionType.ZSTD))
        writer.start(profile=source.profile, library=source.library)
        for old, schema in sorted(source.schemas.items()):
            schema_ids[old] = writer.register_schema(schema.name, schema.encoding,
                                                     schema.data)
        for old, channel in sorted(source.channels.items()):
            if channel.schema_id != 0 and channel.schema_id not in schema_ids:
                continue                        # its messages are counted as lost below
            channel_ids[old] = writer.register_channel(
                channel.topic, channel.message_encoding, schema_ids.get(channel.schema_id, 0),
                dict(channel.metadata))

        def add(message: Message) -> None:
            nonlocal written
            new = channel_ids.get(message.channel_id)
            if new is None:
                channel = source.channels.get(message.channel_id)
                key = (f'channel {message.channel_id} (undefined)' if channel is None else
                       f'channel {channel.topic!r} (its schema {channel.schema_id} was lost)')
                lost[key] = lost.get(key, 0) + 1
                return
            writer.add_message(new, message.log_time, message.data, message.publish_time,
                               message.sequence)
            written += 1

        for offset, opcode in source.usable:
            stream.seek(offset)
            _, length = _RECORD_HEAD.unpack(stream.read(9))
            record = _parse(opcode, stream.read(length))
            if isinstance(record, Chunk):
                for _, item in _chunk_records(record):
                    if isinstance(item, Message):
                        add(item)
            elif isinstance(record, Message):
                add(record)
            elif isinstance(record, Attachment):
                writer.add_attachment(record.create_time, record.log_time, record.name,
                                      record.media_type, record.data)
            elif isinstance(record, Metadata):
                writer.add_metadata(record.name, dict(record.metadata))
        extra = [Dropped(0, 0, 'messages', f'{count} messages of {key}', messages=count)
                 for key, count in lost.items()]
        writer.add_metadata(RECOVER_METADATA, provenance(source, extra))
        writer.finish()  # type: ignore[no-untyped-call]  # mcap's Writer is unannotated
        sink.flush()
        os.fsync(sink.fileno())
    return written, extra


def provenance(source: Scan, extra: Sequence[Dropped] = ()) -> dict[str, str]:
    """Key-value record of a recovery: the source and every dropped range."""
    drops = [*source.dropped, *extra]
    values = {'source': source.path.name, 'dropped_ranges': str(len(drops)),
              'dropped_messages_known': str(sum(d.messages or 0 for d in drops))}
    for number, dropped in enumerate(drops):
        values[f'dropped_{number}'] = dropped.describe()
    return values


# --- rosbag2 directories -------------------------------------------------------------------

def _natural(path: Path) -> list[object]:
    return [int(part) if part.isdigit() else part for part in re.split(r'(\d+)', path.name)]


def _bag_files(directory: Path) -> list[Path]:
    """The .mcap files of a rosbag2 directory: as metadata.yaml lists them, else all."""
    meta = directory / 'metadata.yaml'
    if meta.is_file():
        try:
            info = yaml.safe_load(meta.read_text())['rosbag2_bagfile_information']
            listed = [directory / name for name in info['relative_file_paths']]
        except (yaml.YAMLError, KeyError, TypeError, OSError):
            listed = []
        if listed and all(p.is_file() for p in listed):
            for path in listed:
                if path.suffix != '.mcap':
                    raise RecoverError(f'{path}: recover handles MCAP storage only')
            return listed
    return sorted(directory.glob('*.mcap'), key=_natural)


def _check_ros2(source: Scan) -> None:
    """RecoverError unless every channel with messages is CDR with a ROS 2 schema."""
    for channel_id in source.counts:
        channel = source.channels.get(channel_id)
        if channel is None:
            continue                            # counted as lost when written
        schema = source.schemas.get(channel.schema_id)
        if channel.message_encoding != 'cdr' or schema is None \
                or schema.encoding not in _ROS_SCHEMA_ENCODINGS:
            kind = 'no schema' if schema is None else f'schema encoding {schema.encoding!r}'
            raise RecoverError(
                f'{source.path}: not a ROS 2 recording (channel {channel.topic!r} has '
                f'message encoding {channel.message_encoding!r}, {kind}); recover the '
                f'file alone: gear-phm recover {source.path} --out NEW.mcap')


def _topics(scans: Sequence[Scan]) -> list[TopicInfo]:
    """metadata.yaml topics (one per topic and type) of the messages that ``scans`` keep."""
    topics: dict[tuple[str, str], TopicInfo] = {}
    for source in scans:
        for channel_id, count in sorted(source.counts.items()):
            channel = source.channels.get(channel_id)
            schema = None if channel is None else source.schemas.get(channel.schema_id)
            if channel is None or schema is None:
                continue
            key = (channel.topic, schema.name)
            entry = topics.get(key)
            if entry is None:
                entry = topics[key] = TopicInfo(
                    channel.topic, schema.name, channel_id,
                    channel.metadata.get('topic_type_hash', ''),
                    qos=qos_list(channel.metadata.get('offered_qos_profiles', '')))
            entry.count += count
    return list(topics.values())


def metadata_from_files(directory: Path, sources: Sequence[Path],
                        custom_data: dict[str, str] | None = None) -> None:
    """Write ``directory/metadata.yaml`` for the ROS 2 MCAP files ``sources`` (in it)."""
    scans = [scan(p) for p in sources]
    for source in scans:
        _check_ros2(source)
    _write_bag_metadata(directory, scans, custom_data)


def _write_bag_metadata(directory: Path, scans: Sequence[Scan],
                        custom_data: dict[str, str] | None) -> None:
    files = [(s.path.name, s.start_ns or 0, s.end_ns or 0, s.messages) for s in scans]
    write_metadata(directory, files, _topics(scans), custom_data)


@dataclass
class Recovery:
    """What :func:`recover` did."""

    source: Path
    output: Path
    scans: list[Scan]
    #: files written (recovered MCAP, metadata.yaml), and originals kept as backups
    written: list[Path] = field(default_factory=list)
    backups: list[Path] = field(default_factory=list)
    #: messages in the output (all files)
    messages: int = 0
    topics: int = 0
    #: messages of channels whose definition or schema was lost
    lost: list[Dropped] = field(default_factory=list)

    @property
    def dropped(self) -> list[tuple[Path, Dropped]]:
        return [(s.path, d) for s in self.scans for d in s.dropped] + \
            [(self.source, d) for d in self.lost]

    @property
    def nothing_to_do(self) -> bool:
        return not self.written


def recover(path: str | Path, out: str | Path | None = None) -> Recovery:
    """Recover the rosbag2 MCAP directory or the MCAP file ``path``.

    Directory: every ``.mcap`` that lacks its footer or holds damaged records is rewritten
    from its usable records, and ``metadata.yaml`` is written. With ``out`` None this
    happens in place, each replaced file kept beside it as ``<name>.orig``; otherwise a new
    rosbag2 directory ``out`` receives the recovered and the intact files. A directory whose
    files are intact and that has metadata.yaml is left alone.

    File: written to ``out`` (default ``<stem>.recovered.mcap`` beside it) unless intact; an
    ``out`` without the ``.mcap`` suffix becomes a rosbag2 directory with metadata.yaml.

    Raises RecoverError (nothing written) for non-MCAP input, non-ROS 2 content where a
    rosbag2 directory is made, or an output that exists.
    """
    path = Path(path)
    if not path.exists():
        raise RecoverError(f'not found: {path}')
    if path.is_dir():
        files = _bag_files(path)
        if not files:
            raise RecoverError(f'{path}: no .mcap file in this directory')
        return _recover_directory(path, files, None if out is None else Path(out))
    if out is not None and Path(out).suffix != '.mcap':
        return _recover_directory(path.parent, [path], Path(out))
    target = Path(out) if out is not None else path.with_name(f'{path.stem}.recovered.mcap')
    source = scan(path)
    result = Recovery(path, target, [source], messages=source.messages)
    if source.intact:
        return result
    if target.exists():
        raise RecoverError(f'{target} exists; give another --out')
    result.messages, result.lost = _write_atomic(source, target)
    result.written.append(target)
    result.topics = len({c.topic for i, c in source.channels.items() if i in source.counts})
    return result


def _write_atomic(source: Scan, target: Path) -> tuple[int, list[Dropped]]:
    tmp = target.with_name(target.name + '.recovering')
    tmp.unlink(missing_ok=True)
    try:
        outcome = _write(source, tmp)
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return outcome


def _recover_directory(directory: Path, files: list[Path], out: Path | None) -> Recovery:
    scans = [scan(p) for p in files]
    for source in scans:
        _check_ros2(source)
    meta = directory / 'metadata.yaml'
    result = Recovery(directory, out or directory, scans)
    broken = [s for s in scans if not s.intact]
    result.topics = len(_topics(scans))
    result.messages = sum(s.messages for s in scans)
    if out is None and not broken and meta.is_file():
        return result
    if out is not None:
        if out.exists() and (not out.is_dir() or any(out.iterdir())):
            raise RecoverError(f'--out {out} exists and is not an empty directory')
    else:
        backups = [s.path.with_name(s.path.name + '.orig') for s in broken]
        if broken and meta.is_file():
            backups.append(meta.with_name('metadata.yaml.orig'))
        for backup in backups:
            if backup.exists():
                raise RecoverError(f'{backup} exists (recovered before?); move it away or '
                                   f'give --out')
    created = out is not None and not out.exists()
    try:
        if out is not None:
            out.mkdir(parents=True, exist_ok=True)
        counts = _write_files(scans, broken, out, result)
        custom: dict[str, str] = {}
        for source, dropped in ((s, d) for s in broken for d in s.dropped):
            custom[f'{RECOVER_METADATA}.{source.path.name}.{len(custom)}'] = dropped.describe()
        for number, dropped in enumerate(result.lost):
            custom[f'{RECOVER_METADATA}.lost.{number}'] = dropped.describe()
        target = out or directory
        if out is None and meta.is_file():
            os.replace(meta, meta.with_name('metadata.yaml.orig'))
            result.backups.append(meta.with_name('metadata.yaml.orig'))
        written = [scan(target / s.path.name) if s in broken else s for s in scans]
        _write_bag_metadata(target, written, custom)
        result.written.append(target / 'metadata.yaml')
        result.messages = counts
        result.topics = len(_topics(written))
    except BaseException:
        if created and out is not None:
            shutil.rmtree(out, ignore_errors=True)
        raise
    return result


def _write_files(scans: list[Scan], broken: list[Scan], out: Path | None,
                 result: Recovery) -> int:
    """Write the recovered files (and copy intact ones to ``out``); returns messages kept."""
    total = 0
    for source in scans:
        if source not in broken:
            total += source.messages
            if out is not None:
                shutil.copyfile(source.path, out / source.path.name)
                result.written.append(out / source.path.name)
            continue
        target = (out or source.path.parent) / source.path.name
        if out is None:
            tmp = source.path.with_name(source.path.name + '.recovering')
            tmp.unlink(missing_ok=True)
            try:
                count, lost = _write(source, tmp)
                backup = source.path.with_name(source.path.name + '.orig')
                os.replace(source.path, backup)
                os.replace(tmp, target)
            except BaseException:
                tmp.unlink(missing_ok=True)
                raise
            result.backups.append(backup)
        else:
            count, lost = _write_atomic(source, target)
        result.written.append(target)
        result.lost += lost
        total += count
    return total
