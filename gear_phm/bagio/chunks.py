"""Batches of raw messages, and a fast reader for indexed MCAP files that declines the rest.

:class:`RawBatch` holds many serialized messages of one topic as one buffer plus spans, so a
decoder can gather fields of all of them with numpy. :class:`McapChunkReader` builds such
batches straight from MCAP chunks: it reads each chunk with one ``read``, decompresses it
once, and locates the messages through the chunk's message index records (arrays of
(log time, offset) pairs, read with ``numpy.frombuffer``). There is no Python work per
message, and chunks holding only other topics are skipped when the file's statistics prove
that they hold none of the wanted channels.

The fast reader only answers when it can prove its answer complete. Before yielding anything
it checks the file's own structure: a footer and a summary with chunk indexes and channels,
no message or chunk outside the indexed chunks, message index records that match the chunk
indexes, and statistics (when present) that count what the indexes list. Each chunk is then
checked against its content as it is read: checksum, every indexed record is the message the
index says, and the indexed records and the schema/channel records between them tile the
chunk (a message the index missed is read from the chunk itself). Whatever it cannot prove
raises :class:`NotIndexed` (:class:`IndexMismatch` when the file contradicts itself), and
:class:`McapBatchReader` then reads the files linearly with mcap's own reader.

Messages come out per topic in log-time order, several channels of one topic merged, equal
log times in file order (as mcap's reader orders them); also when chunks overlap in time.
"""
from __future__ import annotations

from array import array
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, ChunkIndex, Footer, Statistics
import numpy as np

from gear_phm.bagio.mcapformat import (COMPRESSIONS, decompress, FOOTER_BYTES, FormatError, MAGIC,
                                       MESSAGE_FIELDS, MESSAGE_HEAD, message_heads,
                                       message_index, NotMcap, parse_record, read_footer,
                                       RECORD_HEAD, records, SUMMARY_OPCODES)
from gear_phm.errors import GearPhmError

_KEY_SHIFT = 40                    # sort key: chunk number << 40 | record offset in the chunk


class NotIndexed(GearPhmError):
    """The fast reader cannot prove a complete answer for this file: read it another way."""


class IndexMismatch(NotIndexed):
    """The file's index (chunk/message indexes, statistics) disagrees with its content."""


class CorruptChunk(GearPhmError):
    """A chunk or record is damaged (checksum, bounds, record types).

    No reader should trust its bytes.
    """


@dataclass(frozen=True)
class RawBatch:
    """Messages of one topic, ordered by log time.

    Payload ``i`` is ``buffer[offsets[i]:offsets[i] + lengths[i]]``, logged at
    ``log_time_ns[i]`` [ns].
    """

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
        """Return the messages at ``index``, copied into a compact buffer of their own."""
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


@dataclass
class _Part:
    """A batch plus each message's file-order key (ties in log time keep file order)."""

    batch: RawBatch
    keys: np.ndarray

    def take(self, index: np.ndarray) -> _Part:
        return _Part(self.batch.take(index), self.keys[index])

    def in_order(self) -> _Part:
        """Sorted by (log time, file order)."""
        times = self.batch.log_time_ns
        step = np.diff(times)
        if (step < 0).any() or ((step == 0) & (np.diff(self.keys) < 0)).any():
            order = np.lexsort((self.keys, times))
            batch = self.batch
            return _Part(RawBatch(batch.topic, times[order], batch.buffer,
                                  batch.offsets[order], batch.lengths[order]),
                         self.keys[order])
        return self


@dataclass
class _Chunk:
    """One chunk of the index, made from a row of :class:`_ChunkTable` while it is used."""

    stream: BinaryIO
    path: Path
    number: int                          # position in file order over all files
    start_offset: int
    length: int
    index_length: int
    compression: str
    compressed_size: int
    uncompressed_size: int
    start_ns: int
    end_ns: int
    index_offsets: dict[int, int]        # channel id -> file offset of its MessageIndex
    counts: dict[int, int] = field(default_factory=dict)    # channel id -> indexed messages
    topics: dict[int, str] = field(default_factory=dict)    # channel id -> topic (its file)

    @property
    def where(self) -> str:
        return f'{self.path.name}: chunk at byte {self.start_offset}'


#: The columns of :class:`_ChunkTable` (u64 each): the chunk index's fields, and where the
#: chunk's channels start among the entries.
_COLUMNS = ('start_offset', 'length', 'index_length', 'compression', 'compressed_size',
            'uncompressed_size', 'start_ns', 'end_ns', 'first_entry')
_COMPRESSION_NAMES = tuple(COMPRESSIONS)


class _ChunkTable:
    """The chunk indexes of one file as numpy columns, about 100 bytes a chunk.

    Filled record by record from the summary, so no Python object per chunk stays alive
    (mcap's and rosbags' index objects take about 2 KB a chunk). Rows are the chunks in
    offset order; the entries of a row are its channels: id, file offset of the message
    index, indexed messages (:attr:`counts`, filled when the message indexes are checked).
    """

    def __init__(self, stream: BinaryIO, path: Path, first_number: int) -> None:
        self.stream, self.path, self.first_number = stream, path, first_number
        self.topics: dict[int, str] = {}
        self._rows: dict[str, array[int]] | None = {name: array('Q') for name in _COLUMNS}
        self._cids, self._offsets = array('H'), array('Q')
        self.columns: dict[str, np.ndarray] = {}
        empty: np.ndarray = np.zeros(0, dtype=np.int64)
        self.cids, self.offsets, self.counts = empty, empty, empty
        #: Chunks whose compression gear_phm cannot read.
        self.unknown_compressions: set[str] = set()

    def __len__(self) -> int:
        return int(self.columns['start_offset'].size)

    def add(self, index: ChunkIndex) -> None:
        """Append the chunk of the ChunkIndex record ``index``."""
        assert self._rows is not None
        if index.compression not in COMPRESSIONS:
            self.unknown_compressions.add(index.compression)
            compression = 0
        else:
            compression = _COMPRESSION_NAMES.index(index.compression)
        for name, value in zip(_COLUMNS, (
                index.chunk_start_offset, index.chunk_length, index.message_index_length,
                compression, index.compressed_size, index.uncompressed_size,
                index.message_start_time, index.message_end_time, len(self._cids))):
            self._rows[name].append(value)
        for cid, offset in index.message_index_offsets.items():
            self._cids.append(cid)
            self._offsets.append(offset)

    def freeze(self) -> None:
        """Turn the appended rows into numpy columns, sorted by chunk offset."""
        assert self._rows is not None
        rows = {name: np.frombuffer(column, dtype=np.uint64).copy()
                for name, column in self._rows.items()}
        self._rows = None
        cids = np.frombuffer(self._cids, dtype=np.uint16).astype(np.int64)
        offsets = np.frombuffer(self._offsets, dtype=np.uint64).copy()
        self._cids, self._offsets = array('H'), array('Q')
        order = np.argsort(rows['start_offset'], kind='stable')
        if (np.diff(order) != 1).any():
            ends = np.append(rows['first_entry'][1:], cids.size).astype(np.int64)
            entries = [np.arange(int(rows['first_entry'][i]), int(ends[i]))
                       for i in order.tolist()]
            taken = np.concatenate(entries).astype(np.int64)
            sizes = (ends - rows['first_entry'].astype(np.int64))[order]
            rows = {name: column[order] for name, column in rows.items()}
            rows['first_entry'] = np.concatenate(([0], np.cumsum(sizes)[:-1])).astype(np.uint64)
            cids, offsets = cids[taken], offsets[taken]
        self.columns = rows
        self.cids, self.offsets = cids, offsets
        self.counts = np.zeros(cids.size, dtype=np.int64)

    def entries(self, row: int) -> slice:
        """Return where the channels of chunk ``row`` are.

        They are at this slice of :attr:`cids`, :attr:`offsets` and :attr:`counts`.
        """
        first = self.columns['first_entry']
        return slice(int(first[row]), int(first[row + 1]) if row + 1 < first.size
                     else int(self.cids.size))

    def chunk(self, row: int) -> _Chunk:
        """Chunk ``row`` as a :class:`_Chunk`."""
        value = {name: int(column[row]) for name, column in self.columns.items()}
        span = self.entries(row)
        cids = self.cids[span].tolist()
        return _Chunk(
            self.stream, self.path, self.first_number + row, value['start_offset'],
            value['length'], value['index_length'], _COMPRESSION_NAMES[value['compression']],
            value['compressed_size'], value['uncompressed_size'], value['start_ns'],
            value['end_ns'], dict(zip(cids, self.offsets[span].tolist())),
            {cid: n for cid, n in zip(cids, self.counts[span].tolist()) if n}, self.topics)


def _walk(data: bytes, start: int, end: int, where: str) -> Iterator[tuple[int, int, int]]:
    """(op, record offset, body length) of the records in ``data[start:end]``.

    CorruptChunk when one overruns ``end``.
    """
    try:
        yield from records(data, start, end)
    except FormatError as exc:
        raise CorruptChunk(f'{where}: {exc}') from None


def _channel_topic(body: bytes) -> str | None:
    """Return the topic of the Channel record ``body``, None when it does not parse."""
    try:
        channel = parse_record(Opcode.CHANNEL, body)
    except FormatError:
        return None
    return channel.topic if isinstance(channel, Channel) else None


class McapChunkReader:
    """Reads the chunks of one or more MCAP files (the parts of one rosbag2 bag).

    Raises :class:`NotIndexed` from the constructor when a file lacks what the fast path
    needs or contradicts itself, and from :meth:`batches` when a chunk's content contradicts
    its index in a way it cannot read around (then some batches may have been yielded).
    """

    def __init__(self, paths: Iterable[str | Path]) -> None:
        self._streams: list[BinaryIO] = []
        self._tables: list[_ChunkTable] = []
        #: Whether the statistics prove that the message indexes list every message, so
        #: chunks without a wanted channel in their index can be skipped.
        self.complete = True
        self._counts: dict[str, int] | None = {}    # topic -> indexed messages (all files)
        try:
            for path in paths:
                stream = open(path, 'rb')  # noqa: SIM115 (closed in close())
                self._streams.append(stream)
                self._index_file(Path(path), stream)
        except BaseException:
            self.close()
            raise

    def close(self) -> None:
        for stream in self._streams:
            stream.close()
        self._streams.clear()

    def __enter__(self) -> McapChunkReader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def message_counts(self, topics: Iterable[str]) -> dict[str, int] | None:
        """Return the messages per topic that the indexes list.

        None when a chunk has no message index (then the count is only known after reading).
        """
        if self._counts is None:
            return None
        return {topic: self._counts.get(topic, 0) for topic in topics}

    # --- the file's structure, checked before anything is read ---------------------------

    def _index_file(self, path: Path, stream: BinaryIO) -> None:
        try:
            footer = read_footer(stream)
        except NotMcap:
            raise NotIndexed(f'{path}: not an MCAP file') from None
        if footer is None:
            raise NotIndexed(f'{path}: no MCAP footer (truncated?)')
        summary_start = footer.summary_start
        if summary_start == 0:
            raise NotIndexed(f'{path}: no summary section')
        size = stream.seek(0, 2)
        if not len(MAGIC) < summary_start <= size - FOOTER_BYTES - len(MAGIC):
            raise IndexMismatch(f'{path}: summary offset {summary_start} is outside the file')
        table = _ChunkTable(stream, path, sum(len(t) for t in self._tables))
        stats = self._read_summary(table, summary_start)
        topics = table.topics
        if table.unknown_compressions:
            raise NotIndexed(f'{path}: chunk compression '
                             f'{sorted(table.unknown_compressions)[0]!r}')
        self._check_data_section(table, summary_start)
        columns = table.columns
        unindexed = columns['first_entry'] == np.append(columns['first_entry'][1:],
                                                        table.cids.size)
        indexed_all = not unindexed.any()
        for row in range(len(table)):
            if unindexed[row]:
                if columns['index_length'][row]:
                    raise IndexMismatch(f'{table.chunk(row).where}: message index records '
                                        f'that the chunk index does not list')
                continue
            chunk = table.chunk(row)
            counts = self._check_message_indexes(chunk, topics)
            span = table.entries(row)
            table.counts[span] = [counts.get(cid, 0) for cid in table.cids[span].tolist()]
        self._tables.append(table)
        counts = {cid: int(table.counts[table.cids == cid].sum())
                  for cid in np.unique(table.cids).tolist()}
        if stats is not None and indexed_all:
            if (stats.chunk_count != len(table) or stats.message_count != sum(counts.values())
                    or (stats.channel_message_counts
                        and {c: n for c, n in stats.channel_message_counts.items() if n}
                        != {c: n for c, n in counts.items() if n})):
                raise IndexMismatch(f'{path}: the statistics ({stats.message_count} messages '
                                    f'in {stats.chunk_count} chunks) disagree with the '
                                    f'indexes ({sum(counts.values())} in {len(table)})')
        else:
            self.complete = False
        if not indexed_all:
            self._counts = None
        elif self._counts is not None:
            for cid, count in counts.items():
                self._counts[topics[cid]] = self._counts.get(topics[cid], 0) + count

    @staticmethod
    def _read_summary(table: _ChunkTable, summary_start: int) -> Statistics | None:
        """Read the summary section record by record into ``table``; return its statistics.

        ``table`` gets the section's chunk indexes and channels. NotIndexed when it does not parse
        or lacks chunk indexes or channels.
        """
        from mcap.exceptions import McapError
        from mcap.stream_reader import StreamReader

        path, stream = table.path, table.stream
        stats = None
        try:
            stream.seek(summary_start)
            for record in StreamReader(stream, skip_magic=True).records:
                if isinstance(record, ChunkIndex):
                    table.add(record)
                elif isinstance(record, Channel):
                    table.topics[record.id] = record.topic
                elif isinstance(record, Statistics):
                    stats = record
                elif isinstance(record, Footer):
                    break
        except (McapError, EOFError, ValueError, KeyError) as exc:
            raise NotIndexed(f'{path}: no readable summary ({exc})') from exc
        table.freeze()
        if not len(table):
            raise NotIndexed(f'{path}: no chunk index')
        if not table.topics:
            raise NotIndexed(f'{path}: the summary does not repeat the channels')
        return stats

    @staticmethod
    def _check_data_section(table: _ChunkTable, summary_start: int) -> None:
        """Check the records between the indexed chunks against the summary.

        No message, chunk or stray message index outside the indexed chunks, and every channel
        record agrees with the summary (reads only the records between chunks).
        """
        path, stream, topics = table.path, table.stream, table.topics
        at = 8
        first = True
        columns = table.columns
        spans = zip(columns['start_offset'].tolist(), columns['length'].tolist(),
                    columns['index_length'].tolist())
        for chunk in [*spans, None]:
            end = summary_start if chunk is None else chunk[0]
            if at > end:
                raise IndexMismatch(f'{path}: chunk indexes overlap or point into records')
            while at < end:
                stream.seek(at)
                head = stream.read(RECORD_HEAD.size)
                if len(head) < RECORD_HEAD.size \
                        or at + RECORD_HEAD.size + RECORD_HEAD.unpack(head)[1] > end:
                    raise IndexMismatch(f'{path}: the record at byte {at} overruns an indexed '
                                        f'chunk or the summary')
                op, length = RECORD_HEAD.unpack(head)
                if op in (Opcode.MESSAGE, Opcode.CHUNK, Opcode.MESSAGE_INDEX, Opcode.FOOTER) \
                        or op in SUMMARY_OPCODES or (op == Opcode.HEADER and not first):
                    raise IndexMismatch(f'{path}: a record of type {op:#04x} at byte {at} is '
                                        f'outside the indexed chunks')
                if op == Opcode.CHANNEL:
                    body = stream.read(length)
                    cid = int.from_bytes(body[:2], 'little')
                    if cid not in topics or _channel_topic(body) != topics[cid]:
                        raise IndexMismatch(f'{path}: channel {cid} of the data section is '
                                            f'not in the summary')
                first = False
                at += RECORD_HEAD.size + length
            if chunk is not None:
                start, length, index_length = chunk
                stream.seek(start)
                head = stream.read(RECORD_HEAD.size)
                if len(head) < RECORD_HEAD.size or head[0] != Opcode.CHUNK or length < 41 \
                        or RECORD_HEAD.size + RECORD_HEAD.unpack(head)[1] != length:
                    raise IndexMismatch(f'{path.name}: chunk at byte {start}: no chunk record '
                                        f'of the indexed length there')
                at = start + length + index_length
                first = False

    @staticmethod
    def _check_message_indexes(chunk: _Chunk, topics: dict[int, str]) -> dict[int, int]:
        """Check the message indexes after ``chunk``; return the indexed messages per channel.

        The message index records after ``chunk`` must be those its chunk index lists, with log
        times inside its time range.
        """
        start = chunk.start_offset + chunk.length
        chunk.stream.seek(start)
        region = chunk.stream.read(chunk.index_length)
        if len(region) != chunk.index_length:
            raise IndexMismatch(f'{chunk.where}: message indexes past the end of the file')
        found: dict[int, int] = {}
        counts: dict[int, int] = {}
        for op, at, length in _walk(region, 0, len(region), chunk.where):
            if op != Opcode.MESSAGE_INDEX or length < 6:
                raise IndexMismatch(f'{chunk.where}: a record of type {op:#04x} among its '
                                    f'message indexes')
            try:
                cid, entries = message_index(region, at)
            except FormatError:
                raise IndexMismatch(f'{chunk.where}: malformed message index') from None
            if cid in found:
                raise IndexMismatch(f'{chunk.where}: malformed message index')
            found[cid] = start + at
            if len(entries):
                times = entries[:, 0]
                if int(times.min()) < chunk.start_ns or int(times.max()) > chunk.end_ns:
                    raise IndexMismatch(f'{chunk.where}: message index times outside the '
                                        f"chunk's time range")
                counts[cid] = len(entries)
        if found != chunk.index_offsets:
            raise IndexMismatch(f'{chunk.where}: the message index records differ from the '
                                f'chunk index')
        unknown = set(found) - set(topics)
        if unknown:
            raise NotIndexed(f'{chunk.where}: channels {sorted(unknown)} are not in the '
                             f'summary')
        return counts

    # --- reading ---------------------------------------------------------------------------

    def _plan(self, wanted: set[str]) -> list[tuple[_ChunkTable, np.ndarray]]:
        """Return the chunks to read for topics ``wanted``, in (start time, number) order.

        As (table, rows) pairs, one pair per run of rows from one file.
        """
        numbers, starts, keep = [], [], []
        for table in self._tables:
            ids = [cid for cid, topic in table.topics.items() if topic in wanted]
            row_of_entry = np.repeat(np.arange(len(table)), np.diff(np.append(
                table.columns['first_entry'].astype(np.int64), table.cids.size)))
            ours = np.zeros(len(table), dtype=bool)
            ours[row_of_entry[np.isin(table.cids, ids) & (table.counts > 0)]] = True
            numbers.append(table.first_number + np.arange(len(table)))
            starts.append(table.columns['start_ns'])
            # skipped when the statistics prove: none of ours there; else read, its content
            # may hold some
            keep.append(ours if self.complete else np.ones(len(table), dtype=bool))
        number, start = np.concatenate(numbers), np.concatenate(starts)
        order = np.lexsort((number, start))
        order = order[np.concatenate(keep)[order]]
        if not order.size:
            return []
        firsts = [table.first_number for table in self._tables]
        which = np.searchsorted(firsts, order, side='right') - 1
        cut = np.flatnonzero(np.diff(which)) + 1
        return [(self._tables[int(part[0])], rows - self._tables[int(part[0])].first_number)
                for part, rows in zip(np.split(which, cut), np.split(order, cut))]

    def _chunks(self, wanted: set[str]) -> Iterator[tuple[_Chunk, dict[int, str]]]:
        """Yield the chunks to read for topics ``wanted`` in (start time, number) order.

        Each with its channels of ``wanted`` topics.
        """
        for table, rows in self._plan(wanted):
            channels = {cid: topic for cid, topic in table.topics.items() if topic in wanted}
            for row in rows.tolist():
                yield table.chunk(row), channels

    def batches(self, topics: Iterable[str]) -> Iterator[RawBatch]:
        """Yield a RawBatch per topic and chunk, in log-time order per topic.

        A message that a later chunk could precede is held back and merged into that chunk's batch.
        """
        chunks = self._chunks(set(topics))
        carry: dict[str, _Part] = {}
        upcoming = next(chunks, None)
        while upcoming is not None:
            chunk, channels = upcoming
            upcoming = next(chunks, None)
            following = None if upcoming is None else upcoming[0]
            for topic, part in self._read(chunk, channels).items():
                if topic in carry:
                    previous = carry.pop(topic)
                    part = _Part(concatenate(previous.batch, part.batch),
                                 np.concatenate((previous.keys, part.keys))).in_order()
                times = part.batch.log_time_ns
                if following is not None and len(times) and times[-1] >= following.start_ns:
                    first_key = following.number << _KEY_SHIFT
                    later = (times > following.start_ns) | (
                        (times == following.start_ns) & (part.keys > first_key))
                    if later.any():
                        carry[topic] = part.take(np.flatnonzero(later))
                        part = part.take(np.flatnonzero(~later))
                if len(part.batch):
                    yield part.batch
        for part in carry.values():
            yield part.batch

    def _read(self, chunk: _Chunk, channels: dict[int, str]) -> dict[str, _Part]:
        """Return the messages of ``channels`` in one chunk, per topic, by (log time, file order).

        The message indexes are checked against the records they point at, and the records must
        tile the chunk; messages the index missed are read from the chunk.
        """
        indexes, data = self._decompressed(chunk)
        parts_cid, parts_time, parts_offset = [], [], []
        base = chunk.start_offset + chunk.length
        for cid, offset in chunk.index_offsets.items():
            _, entries = message_index(indexes, offset - base)
            count = len(entries)
            parts_cid.append(np.full(count, cid, dtype=np.int64))
            parts_time.append(entries[:, 0].astype(np.int64))
            parts_offset.append(entries[:, 1].astype(np.int64))
        if parts_offset:
            cids = np.concatenate(parts_cid)
            times = np.concatenate(parts_time)
            records = np.concatenate(parts_offset)
        else:
            cids = times = records = np.zeros(0, dtype=np.int64)
        if records.size:
            try:
                head = message_heads(np.frombuffer(data, dtype=np.uint8), records)
            except FormatError:
                raise IndexMismatch(f'{chunk.where}: message index out of bounds') from None
            lengths = head['length'].astype(np.int64)
            if ((head['op'] != Opcode.MESSAGE).any() or (head['channel'] != cids).any()
                    or (head['log_time'].astype(np.int64) != times).any()
                    or (lengths < MESSAGE_FIELDS).any()
                    or (records + RECORD_HEAD.size + lengths > len(data)).any()):
                raise IndexMismatch(f'{chunk.where}: message index does not match the '
                                    f'messages')
        else:
            lengths = np.zeros(0, dtype=np.int64)
        extra = self._unindexed(chunk, data, records, lengths)
        if extra:
            cids = np.concatenate((cids, np.array([e[0] for e in extra], dtype=np.int64)))
            times = np.concatenate((times, np.array([e[1] for e in extra], dtype=np.int64)))
            records = np.concatenate((records, np.array([e[2] for e in extra], dtype=np.int64)))
            lengths = np.concatenate((lengths, np.array([e[3] for e in extra],
                                                        dtype=np.int64)))
            if times.min() < chunk.start_ns or times.max() > chunk.end_ns:
                raise IndexMismatch(f"{chunk.where}: unindexed messages outside the chunk's "
                                    f'time range')
        by_topic: dict[str, list[int]] = {}
        for cid, topic in channels.items():
            by_topic.setdefault(topic, []).append(cid)
        parts = {}
        for topic, ids in by_topic.items():
            ours = np.isin(cids, ids)
            mine = np.arange(cids.size) if ours.all() else np.flatnonzero(ours)
            if mine.size == 0:
                continue
            offsets = records[mine] + MESSAGE_HEAD.size
            batch = RawBatch(topic, times[mine], data, offsets,
                             lengths[mine] - MESSAGE_FIELDS)
            parts[topic] = _Part(batch, (chunk.number << _KEY_SHIFT) + records[mine]).in_order()
        return parts

    @staticmethod
    def _unindexed(chunk: _Chunk, data: bytes, records: np.ndarray,
                   lengths: np.ndarray) -> list[tuple[int, int, int, int]]:
        """Check that the indexed message records and the records between them tile the chunk.

        Return the messages that no index lists as (channel, log time, record offset, record
        length).
        """
        if records.size:
            order = np.argsort(records, kind='stable') if (np.diff(records) < 0).any() \
                else np.arange(records.size)
            starts = records[order]
            ends = starts + RECORD_HEAD.size + lengths[order]
            if (ends[:-1] > starts[1:]).any():
                raise IndexMismatch(f'{chunk.where}: message index entries overlap')
            gap = np.flatnonzero(ends[:-1] < starts[1:])
            gaps = [(0, int(starts[0]))] if starts[0] > 0 else []
            gaps += [(int(ends[i]), int(starts[i + 1])) for i in gap.tolist()]
            if ends[-1] < len(data):
                gaps.append((int(ends[-1]), len(data)))
        else:
            gaps = [(0, len(data))]
        extra = []
        for begin, end in gaps:
            for op, at, length in _walk(data, begin, end, chunk.where):
                if op == Opcode.CHANNEL:
                    body = data[at + RECORD_HEAD.size:at + RECORD_HEAD.size + length]
                    cid = int.from_bytes(body[:2], 'little')
                    topic = chunk.topics.get(cid)
                    if topic is None or _channel_topic(body) != topic:
                        raise NotIndexed(f'{chunk.where}: channel {cid} is not in the '
                                         f'summary')
                elif op == Opcode.MESSAGE:
                    if length < MESSAGE_FIELDS:
                        raise CorruptChunk(f'{chunk.where}: a message record is too short')
                    _, _, cid, _, log_time, _ = MESSAGE_HEAD.unpack_from(data, at)
                    if cid not in chunk.topics:
                        raise NotIndexed(f'{chunk.where}: channel {cid} is not in the summary')
                    extra.append((cid, log_time, at, length))
                elif op != Opcode.SCHEMA and op < 0x80:
                    raise CorruptChunk(f'{chunk.where}: a record of type {op:#04x} inside it')
        return extra

    def _decompressed(self, chunk: _Chunk) -> tuple[bytes, bytes]:
        """(its message index records as read, the chunk's decompressed records)."""
        stream = chunk.stream
        stream.seek(chunk.start_offset)
        head = stream.read(RECORD_HEAD.size)
        if len(head) < RECORD_HEAD.size or head[0] != Opcode.CHUNK:
            raise CorruptChunk(f'{chunk.where} is truncated or not a chunk record')
        _, length = RECORD_HEAD.unpack(head)
        if RECORD_HEAD.size + length != chunk.length:
            raise IndexMismatch(f'{chunk.where}: its length differs from the chunk index')
        body = stream.read(length)
        indexes = stream.read(chunk.index_length)
        if len(body) < length or len(indexes) < chunk.index_length:
            raise CorruptChunk(f'{chunk.where} is truncated')
        try:
            record = parse_record(Opcode.CHUNK, body)
        except FormatError as exc:
            raise CorruptChunk(f'{chunk.where}: {exc}') from None
        assert isinstance(record, Chunk)
        del body
        if (record.message_start_time, record.message_end_time, record.uncompressed_size,
                len(record.data), record.compression) != (
                chunk.start_ns, chunk.end_ns, chunk.uncompressed_size, chunk.compressed_size,
                chunk.compression):
            raise IndexMismatch(f'{chunk.where}: its header differs from the chunk index')
        try:
            data = decompress(record)
        except FormatError as exc:
            raise CorruptChunk(f'{chunk.where}: {exc}') from None
        return indexes, data


def scan_batches(paths: Iterable[str | Path], topics: Iterable[str],
                 batch_size: int = 20000) -> Iterator[RawBatch]:
    """Yield every message of ``topics`` in ``paths``, read linearly with mcap's own reader.

    Chunk checksums are checked; per topic in log-time order with equal times in file order.
    Needs no index or summary; holds the wanted messages in memory to sort them.
    """
    from mcap.reader import NonSeekingReader

    wanted = set(topics)
    found: dict[str, tuple[bytearray, list[int], list[int]]] = {}   # buffer, times, sizes
    for path in paths:
        try:
            with open(path, 'rb') as stream:
                for _, channel, message in NonSeekingReader(
                        stream, validate_crcs=True).iter_messages(
                            topics=wanted, log_time_order=False):
                    buffer, times, sizes = found.setdefault(channel.topic,
                                                            (bytearray(), [], []))
                    buffer += message.data
                    times.append(message.log_time)
                    sizes.append(len(message.data))
        except Exception as exc:  # mcap raises many types for damaged input
            text = ' '.join(str(exc).split()) or type(exc).__name__
            raise CorruptChunk(f'{Path(path).name}: {text}') from exc
    for topic, (buffer, times, sizes) in found.items():
        lengths = np.array(sizes, dtype=np.int64)
        offsets = np.zeros(lengths.size, dtype=np.int64)
        np.cumsum(lengths[:-1], out=offsets[1:])
        everything = RawBatch(topic, np.array(times, dtype=np.int64), bytes(buffer), offsets,
                              lengths)
        del buffer[:]
        order = np.argsort(everything.log_time_ns, kind='stable')    # file order on ties
        for start in range(0, order.size, batch_size):
            yield everything.take(order[start:start + batch_size])


class _Fingerprint:
    """Count, log times and sizes of the messages of one topic yielded so far.

    To check that a fallback reader agrees with what the fast reader already gave.
    """

    def __init__(self) -> None:
        self.count = 0
        self.value: tuple[int, ...] = (0, 0, 0)

    def add(self, times: np.ndarray, lengths: np.ndarray) -> None:
        position = np.arange(self.count, self.count + times.size, dtype=np.uint64) + 1
        t = times.astype(np.uint64)
        with np.errstate(over='ignore'):
            terms = (int(t.sum()), int((t * position).sum()),
                     int((lengths.astype(np.uint64) * position).sum()))
        self.value = tuple((a + b) % (1 << 64) for a, b in zip(self.value, terms))
        self.count += int(times.size)


class McapBatchReader:
    """Raw batches from MCAP files, by the fast chunk reader or else mcap's linear reader.

    :class:`McapChunkReader` when it can prove its answer, else mcap's linear reader
    (:func:`scan_batches`). :attr:`kind` says which was used: 'mcap-chunks', 'mcap-scan', or
    'mcap-chunks+scan' when a chunk contradicted its index after batches were yielded (the scan
    then continues where the fast reader stopped, after checking that it agrees with what was
    yielded); :attr:`reason` why it fell back.
    """

    def __init__(self, paths: Iterable[str | Path]) -> None:
        self.paths = [Path(p) for p in paths]
        self.kind = ''
        self.reason = ''

    def batches(self, topics: Iterable[str], batch_size: int = 20000,
                expected: Mapping[str, int] | None = None) -> Iterator[RawBatch]:
        """Yield the RawBatches of ``topics``, per topic in log-time order.

        ``expected``: message counts per topic known from elsewhere (rosbag2 metadata); indexes
        that count differently are not trusted.
        """
        wanted = sorted(set(topics))
        try:
            reader = McapChunkReader(self.paths)
        except NotIndexed as exc:
            yield from self._scan(wanted, batch_size, str(exc))
            return
        with reader:
            counts = reader.message_counts(wanted)
            if expected is not None and counts is not None:
                differ = {t: (counts[t], n) for t, n in expected.items()
                          if t in counts and counts[t] != n}
                if differ:
                    reader.close()
                    yield from self._scan(wanted, batch_size,
                                          f'index counts (index, metadata) {differ}')
                    return
            self.kind = 'mcap-chunks'
            given = {topic: _Fingerprint() for topic in wanted}
            try:
                for batch in reader.batches(wanted):
                    given[batch.topic].add(batch.log_time_ns, batch.lengths)
                    yield batch
                return
            except NotIndexed as exc:
                reason = str(exc)
        if not any(fingerprint.count for fingerprint in given.values()):
            yield from self._scan(wanted, batch_size, reason)
            return
        self.kind, self.reason = 'mcap-chunks+scan', reason
        yield from _resume(scan_batches(self.paths, wanted, batch_size), given, reason)

    def _scan(self, topics: list[str], batch_size: int, reason: str) -> Iterator[RawBatch]:
        self.kind, self.reason = 'mcap-scan', reason
        yield from scan_batches(self.paths, topics, batch_size)


def _resume(batches: Iterator[RawBatch], given: dict[str, _Fingerprint],
            reason: str) -> Iterator[RawBatch]:
    """Yield ``batches`` without the messages already yielded per topic (``given``).

    Checks first that they are the same messages.
    """
    seen = {topic: _Fingerprint() for topic in given}
    for batch in batches:
        done, check = given[batch.topic], seen[batch.topic]
        skip = min(done.count - check.count, len(batch))
        if skip > 0:
            check.add(batch.log_time_ns[:skip], batch.lengths[:skip])
            if check.count == done.count and check.value != done.value:
                raise CorruptChunk(f'{reason}; the messages read so far disagree with a full '
                                   f'read')
            if skip == len(batch):
                continue
            batch = batch.take(np.arange(skip, len(batch)))
        yield batch
    short = [t for t in given if seen[t].count < given[t].count]
    if short:
        raise CorruptChunk(f'{reason}; a full read has fewer messages of {short} than were '
                           f'already read')
