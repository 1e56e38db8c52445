"""Scan an MCAP recording for what recover can use: intact records, dropped byte ranges.

The file is walked record by record with mcap's record classes (:mod:`mcap.records`), the
way :class:`mcap.stream_reader.StreamReader` does, but with the byte offset of every record
known, so that each problem can be reported with its place in the file:

- a chunk whose CRC, size or compression does not check out is dropped whole, with its byte
  range, its log-time range and (from the message indexes that follow it) its message count;
- an attachment whose CRC fails, and any record that does not parse, is dropped likewise;
- an incomplete record at the end (the writer was killed mid-write) is dropped, and with it
  anything after a record whose length runs past the end of the file;
- index, statistics and summary records are checked against the data section (a mismatch is
  a problem, not a loss: the rewrite rebuilds them).

:mod:`.recover_rewrite` writes what the scan keeps; :func:`unfinished` tells a reader that a
file needs recovering, from its first and last bytes alone.
"""
from __future__ import annotations

from dataclasses import dataclass, field
import io
from pathlib import Path

from mcap.opcode import Opcode
from mcap.records import (Attachment, Channel, Chunk, ChunkIndex, Footer, Header, McapRecord,
                          Message, MessageIndex, Metadata, Schema, Statistics)

from gear_phm.bagio.mcapformat import (attachment_crc_ok, chunk_records, FormatError, MAGIC,
                                       NotMcap, parse_record, read_footer, RECORD_HEAD,
                                       summary_crc_ok)
from gear_phm.errors import GearPhmError


class RecoverError(GearPhmError):
    """The input cannot be recovered (not MCAP, not ROS 2 where needed, output in the way).

    The message names the file and the problem on one line. Nothing was written.
    """


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
    #: the Header record was read
    header: bool = False
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
    """Walk ``path`` record by record (see the module docstring).

    Raises RecoverError when it cannot be read or is not an MCAP file.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
        stream = open(path, 'rb')  # noqa: SIM115 (closed below)
    except OSError as exc:
        raise RecoverError(f'cannot read {path}: {exc.strerror or exc}') from None
    with stream:
        if stream.read(len(MAGIC)) != MAGIC:
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
        result, position = self.result, len(MAGIC)
        while True:
            head = self.stream.read(RECORD_HEAD.size)
            if len(head) < RECORD_HEAD.size:
                self._settle()
                result.dropped.append(Dropped(
                    position, self.size, 'end of file',
                    'no footer (the writer did not finish)' if position == self.size
                    else 'incomplete record (the writer did not finish)'))
                return
            opcode, length = RECORD_HEAD.unpack(head)
            end = position + RECORD_HEAD.size + length
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
        """Close the previous chunk.

        Check that its message indexes were complete, or report it (when dropped) with the
        messages its indexes listed.
        """
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
            record = parse_record(opcode, body)
        except FormatError as exc:
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
            result.header = True
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
            if attachment_crc_ok(body):
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
            inner = chunk_records(chunk)
        except FormatError as exc:
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
        """Check that a MessageIndex after a good chunk lists exactly its messages."""
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
        # the end magic, and nothing after it
        result.complete = self.stream.read(len(MAGIC) + 1) == MAGIC \
            and summary_crc_ok(self.stream, footer, end)
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


def unfinished(path: str | Path) -> str | None:
    """Return why the MCAP file ``path`` needs ``gear-phm recover``, or None.

    The reasons are a missing footer or summary section; None when it has both, or is not
    MCAP at all, or cannot be read. Reads only its first and last bytes.
    """
    try:
        with open(path, 'rb') as stream:
            footer = read_footer(stream)
    except (OSError, NotMcap):
        return None
    if footer is None:
        return 'it has no footer (the writer did not finish)'
    if footer.summary_start == 0:
        return 'it has no summary section (no index)'
    return None
