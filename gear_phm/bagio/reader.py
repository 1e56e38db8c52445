"""Read rosbag2 (MCAP, sqlite3), bare MCAP files and ROS1 bags through rosbags."""
from __future__ import annotations

from array import array
from collections.abc import Iterable, Iterator
from dataclasses import fields
from pathlib import Path
import sys
from types import TracebackType
from typing import Any, cast

from rosbags.highlevel import AnyReader
from rosbags.interfaces import Connection
from rosbags.rosbag2 import Reader as Rosbag2Reader
from rosbags.rosbag2.reader import DirectoryReader
from rosbags.rosbag2.storage_mcap import ChunkInfo, McapReader
from rosbags.typesys import get_typestore, Stores

from gear_phm.bagio.chunks import CorruptChunk, McapBatchReader, RawBatch
from gear_phm.bagio.recover_scan import unfinished
from gear_phm.errors import GearPhmError


_JAZZY = get_typestore(Stores.ROS2_JAZZY)


def _to_jazzy(value: Any) -> Any:
    """Copy a ROS1 message into the Jazzy type of the same name (drops e.g. Header.seq)."""
    msgtype = getattr(value, '__msgtype__', None)
    if msgtype is None:
        if isinstance(value, list):
            return [_to_jazzy(item) for item in value]
        return value
    cls = _JAZZY.types[msgtype]
    return cls(**{f.name: _to_jazzy(getattr(value, f.name)) for f in fields(cast(Any, cls))})


class _CompactChunks:
    """rosbags' chunk index of one MCAP file (``McapReader.chunks``) kept as integer columns.

    About 150 bytes a chunk instead of about 1 KB of ChunkInfo objects and dicts (12 MB for 40M
    samples of 1 kHz); iterating makes the ChunkInfo records again.
    """

    def __init__(self) -> None:
        self._fields = array('Q')       # per chunk: the 7 integer fields of _INTS
        self._compressions: list[str] = []
        self._offsets = array('Q')      # per chunk: channel id, offset, ... (message indexes)
        self._counts = array('Q')       # per chunk: channel id, count, ...
        self._ends = array('Q')         # per chunk: end in _offsets, end in _counts

    def append(self, chunk: ChunkInfo) -> None:
        self._fields.extend(getattr(chunk, name) for name in _INTS)
        self._compressions.append(sys.intern(chunk.compression))
        for cid, value in chunk.message_index_offsets.items():
            self._offsets.extend((cid, value))
        for cid, value in chunk.channel_count.items():
            self._counts.extend((cid, value))
        self._ends.extend((len(self._offsets), len(self._counts)))

    def __len__(self) -> int:
        return len(self._compressions)

    def __iter__(self) -> Iterator[ChunkInfo]:
        ints, offsets, counts, ends = self._fields, self._offsets, self._counts, self._ends
        at_offsets = at_counts = 0
        for k, compression in enumerate(self._compressions):
            values = dict(zip(_INTS, ints[k * len(_INTS):(k + 1) * len(_INTS)]))
            end_offsets, end_counts = ends[2 * k], ends[2 * k + 1]
            pairs = offsets[at_offsets:end_offsets]
            index_offsets = dict(zip(pairs[0::2], pairs[1::2]))
            pairs = counts[at_counts:end_counts]
            channel_count = dict(zip(pairs[0::2], pairs[1::2]))
            at_offsets, at_counts = end_offsets, end_counts
            yield ChunkInfo(message_index_offsets=index_offsets, compression=compression,
                            channel_count=channel_count, **values)

    def clear(self) -> None:
        for column in (self._fields, self._offsets, self._counts, self._ends):
            del column[:]
        self._compressions.clear()


_INTS = ('message_start_time', 'message_end_time', 'chunk_start_offset', 'chunk_length',
         'message_index_length', 'compressed_size', 'uncompressed_size')


class _CompactMcapReader(McapReader):
    """rosbags' MCAP storage reader with its chunk index in :class:`_CompactChunks`."""

    def __init__(self, path: Any) -> None:
        super().__init__(path)
        self.chunks = cast(Any, _CompactChunks())


def _compact_chunk_indexes(reader: AnyReader) -> None:
    """Have rosbags keep the chunk indexes of ``reader``'s MCAP files compactly.

    Before ``open``; per instance, rosbags' classes are left as they are.
    """
    for bag in reader.readers:
        storage = getattr(bag, 'storage', None)
        if isinstance(storage, McapReader) and not storage.chunks:
            storage.chunks = cast(Any, _CompactChunks())
        elif isinstance(storage, DirectoryReader) and storage.STORAGE_PLUGINS.get('mcap') \
                is McapReader:
            storage.STORAGE_PLUGINS = {**storage.STORAGE_PLUGINS, 'mcap': _CompactMcapReader}


class BagError(GearPhmError):
    """A bag that cannot be used; the message names the bag and the problem on one line."""


def _one_line(exc: BaseException) -> str:
    text = ' '.join(str(exc).split())
    return text or type(exc).__name__


def _truncation_error(bag: Path, files: Iterable[Path]) -> BagError | None:
    """Return a BagError with the recover advice, or None.

    The error if one of ``files`` (MCAP) really lacks its footer or summary
    (:func:`gear_phm.bagio.recover_scan.unfinished`), else None.
    """
    for file in sorted(files):
        reason = unfinished(file) if file.suffix == '.mcap' else None
        if reason:
            return BagError(f'cannot read bag {bag}: {file.name}: {reason}, so it looks '
                            f'truncated (e.g. a recording that was killed); run: '
                            f'gear-phm recover {bag}')
    return None


def _bag_paths(path: Path) -> list[Path]:
    """Return the paths to hand to AnyReader.

    A rosbag2 directory, its storage files (.mcap, .db3) when it has no metadata.yaml, or a ROS1
    .bag file.
    """
    if not path.exists():
        raise BagError(f'bag not found: {path}')
    if path.is_dir():
        if (path / 'metadata.yaml').exists():
            return [path]
        files = sorted([*path.glob('*.mcap'), *path.glob('*.db3')])
        if not files:
            raise BagError(f'{path} is a directory without metadata.yaml and without .mcap or '
                           f'.db3 files: not a rosbag2 bag')
        error = _truncation_error(path, files)
        if error is not None:
            raise error
        return files
    if path.suffix in ('.mcap', '.db3') and (path.parent / 'metadata.yaml').exists():
        return [path.parent]
    if path.suffix in ('.bag', '.db3'):
        return [path]
    if path.suffix == '.mcap':
        error = _truncation_error(path, [path])
        if error is not None:
            raise error
        return [path]
    raise BagError(f'{path}: not a bag (expected a rosbag2 directory, .mcap, .db3 or .bag)')


class BagReader:
    """Context manager over one bag. Messages come in log-time order.

    ``topics`` maps topic name -> message type (``sensor_msgs/msg/JointState``).
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._reader: AnyReader | None = None
        #: How :meth:`raw_batches` read the bag: 'mcap-chunks' (the fast chunk reader),
        #: 'mcap-scan' (mcap's linear reader, where the fast one declined), 'mcap-chunks+scan'
        #: or 'rosbags' (sqlite3, ROS1, compressed rosbag2 files).
        self.reader_kind = ''
        #: Why the fast chunk reader declined, if it did.
        self.fallback_reason = ''
        #: rosbags' MCAP storages whose chunk index :meth:`raw_batches` released.
        self._released: list[McapReader] = []

    def __enter__(self) -> BagReader:
        paths = _bag_paths(self.path)
        try:
            ros2 = paths[0].suffix != '.bag'   # ROS1 bags carry their own definitions
            self._reader = AnyReader(
                paths, default_typestore=_JAZZY if ros2 else None)
            _compact_chunk_indexes(self._reader)
            self._reader.open()
        except Exception as exc:  # rosbags raises many types for corrupt input
            files = [file for part in paths for file in (
                sorted(part.glob('*.mcap')) if part.is_dir() else [part])]
            error = _truncation_error(self.path, files)
            raise (error or BagError(f'cannot read bag {self.path}: {_one_line(exc)}')) from exc
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self.close()

    def close(self) -> None:
        self._released = []
        if self._reader is not None:
            try:
                self._reader.close()
            finally:
                self._reader = None

    @property
    def reader(self) -> AnyReader:
        if self._reader is None:
            raise BagError(f'bag {self.path} is not open')
        return self._reader

    @property
    def topics(self) -> dict[str, str]:
        """Topic name -> message type."""
        return {topic: info.msgtype or '' for topic, info in self.reader.topics.items()}

    @property
    def start_ns(self) -> int:
        return int(self.reader.start_time)

    @property
    def end_ns(self) -> int:
        return int(self.reader.end_time)

    def message_count(self, topic: str | None = None) -> int:
        if topic is None:
            return int(self.reader.message_count)
        return sum(c.msgcount for c in self.reader.connections if c.topic == topic)

    def topics_of_type(self, msgtype: str) -> list[str]:
        """Topics that carry ``msgtype``, sorted."""
        return sorted(t for t, kind in self.topics.items() if kind == msgtype)

    def resolve_topic(self, topic: str) -> str:
        """Return the bag's spelling of ``topic``.

        A relative name and its absolute form are the same.
        """
        topics = self.topics
        for candidate in (topic, '/' + topic.lstrip('/'), topic.lstrip('/')):
            if candidate in topics:
                return candidate
        return topic

    def require_topic(self, topic: str, msgtype: str) -> str:
        """Return the bag's name of ``topic``; BagError unless it exists with type ``msgtype``."""
        topics = self.topics
        topic = self.resolve_topic(topic)
        if topic not in topics:
            raise BagError(f'bag {self.path} has no topic {topic!r} '
                           f'(topics: {", ".join(sorted(topics)) or "none"})')
        if topics[topic] != msgtype:
            raise BagError(f'topic {topic!r} in bag {self.path} has type {topics[topic]}, '
                           f'expected {msgtype}')
        return topic

    def _connections(self, topics: Iterable[str] | None) -> list[Connection]:
        wanted = None if topics is None else {self.resolve_topic(t) for t in topics}
        return [c for c in self.reader.connections if wanted is None or c.topic in wanted]

    def _records(self, topics: Iterable[str] | None, start_ns: int | None,
                 stop_ns: int | None, decode: bool) -> Iterator[tuple[Any, int, Any]]:
        """Yield (connection, log time [ns], raw bytes or decoded message).

        A read or decode error becomes one BagError naming the bag.
        """
        connections = self._connections(topics)
        if not connections:
            return
        while self._released:                  # rosbags reads through its chunk index
            self._released.pop().read_index()
        iterator = self.reader.messages(connections=connections, start=start_ns, stop=stop_ns)
        while True:
            try:
                connection, t_ns, raw = next(iterator)
                payload = self.reader.deserialize(raw, connection.msgtype) if decode else raw
            except StopIteration:
                return
            except Exception as exc:
                raise BagError(f'bag {self.path} is truncated or corrupt: '
                               f'{_one_line(exc)}') from exc
            yield connection, int(t_ns), payload

    def raw_messages(self, topics: Iterable[str] | None = None, start_ns: int | None = None,
                     stop_ns: int | None = None) -> Iterator[tuple[str, int, bytes]]:
        """Yield (topic, log time [ns], serialized CDR bytes)."""
        for connection, t_ns, raw in self._records(topics, start_ns, stop_ns, decode=False):
            if not self.reader.is2:   # ROS1 bag: re-encode as ROS 2 Jazzy CDR
                msg = _to_jazzy(self.reader.deserialize(raw, connection.msgtype))
                raw = _JAZZY.serialize_cdr(msg, connection.msgtype)
            yield connection.topic, t_ns, bytes(raw)

    def raw_batches(self, topics: Iterable[str],
                    batch_size: int = 20000) -> Iterator[RawBatch]:
        """Yield :class:`RawBatch` es of ``topics``, each in log-time order within its topic.

        MCAP storage with chunk and message indexes (what ros2 bag, rosbags, mcap and gear_phm
        write) is read chunk by chunk without per-message Python work; MCAP files that the
        fast reader cannot prove complete (no index, channels only in the data section, an
        index that disagrees with the content or with the bag's metadata) are read with mcap's
        linear reader instead (:class:`~.chunks.McapBatchReader`). sqlite3, ROS1 and
        compressed rosbag2 files go through rosbags, ``batch_size`` messages per batch.
        :attr:`reader_kind` says which was used.
        """
        names = sorted({self.resolve_topic(t) for t in topics})
        storages = self._plain_mcap_storages()
        if storages is not None:
            files = [Path(str(part.path)) for part in storages]
            self._release_index(storages)
            mcap = McapBatchReader(files)
            expected = {name: self.message_count(name) for name in names}
            try:
                for batch in mcap.batches(names, batch_size, expected):
                    self.reader_kind, self.fallback_reason = mcap.kind, mcap.reason
                    yield batch
            except CorruptChunk as exc:
                raise (_truncation_error(self.path, files) or BagError(
                    f'bag {self.path} is corrupt: {_one_line(exc)}')) from exc
            self.reader_kind, self.fallback_reason = mcap.kind, mcap.reason
            return
        self.reader_kind = 'rosbags'
        pending: dict[str, list[tuple[int, bytes]]] = {}
        for topic, t_ns, raw in self.raw_messages(names):
            messages = pending.setdefault(topic, [])
            messages.append((t_ns, raw))
            if len(messages) >= batch_size:
                yield RawBatch.from_messages(topic, pending.pop(topic))
        for topic, messages in pending.items():
            yield RawBatch.from_messages(topic, messages)

    def _release_index(self, storages: list[McapReader]) -> None:
        """Free rosbags' chunk index of ``storages`` while the fast reader reads them.

        The index takes about 1 KB a chunk (12 MB for 40M samples of 1 kHz); the fast reader has
        its own compact index. :meth:`messages` and :meth:`raw_messages` have rosbags read it again
        first.
        """
        for storage in storages:
            if storage not in self._released and storage.chunks:
                storage.chunks.clear()
                self._released.append(storage)

    def _plain_mcap_storages(self) -> list[McapReader] | None:
        """Return rosbags' readers of the .mcap files of a bag stored as plain MCAP, else None.

        The bag is a rosbag2 bag; plain MCAP: no file/message compression.
        """
        reader = self.reader
        if not reader.is2:
            return None
        files: list[McapReader] = []
        for bag in reader.readers:
            if not isinstance(bag, Rosbag2Reader):
                return None
            storage = bag.storage               # a DirectoryReader, or one storage file
            parts = getattr(storage, 'storages', [storage])
            if storage.metadata.compression_mode or not all(
                    isinstance(part, McapReader) for part in parts):
                return None
            files += parts
        return files

    def messages(self, topics: Iterable[str] | None = None, start_ns: int | None = None,
                 stop_ns: int | None = None) -> Iterator[tuple[str, int, Any]]:
        """Yield (topic, log time [ns], deserialized rosbags message)."""
        for connection, t_ns, msg in self._records(topics, start_ns, stop_ns, decode=True):
            yield connection.topic, t_ns, msg
