"""Write rosbag2 (version 9, Jazzy) MCAP directories, crash-safely, with mcap's ``Writer``.

:class:`Rosbag2McapWriter` is the one adapter between gear_phm and :class:`mcap.writer.Writer`:
it declares ROS 2 topics (``ros2msg`` schema, CDR channel with the rosbag2 channel metadata),
closes the open chunk and flushes the file every ``flush_period_s`` (so a ``kill -9`` loses at
most that much; :func:`gear_phm.bagio.recover` rebuilds the rest) and writes ``metadata.yaml``
on close. The CDR packers below serialize gear_phm's output records without rosbags' generic
serializer.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence
import functools
import itertools
import os
from pathlib import Path
import struct
import time
from types import TracebackType
from typing import Any, BinaryIO

from mcap.writer import LIBRARY_IDENTIFIER, Writer
import numpy as np
from rosbags.typesys import get_typestore, Stores

from gear_phm.bagio.batch_writer import BatchWriter, pack_block, vector3_stamped_rows
from gear_phm.bagio.mcapformat import COMPRESSIONS
from gear_phm.bagio.metadata import qos_list, TopicInfo, write_metadata
from gear_phm.interfaces import (DIAGNOSTIC_ARRAY_TYPE, DiagnosticsOut, ns_to_sec_nanosec,
                                 vector3_stamped_cdr, VECTOR3_STAMPED_TYPE, Vector3Out)

#: rosbags typestore for ROS 2 Jazzy message types.
TYPESTORE = get_typestore(Stores.ROS2_JAZZY)

#: The MCAP header's library field of the files written here.
LIBRARY = f'gear_phm; {LIBRARY_IDENTIFIER}'


def absolute_topic(topic: str) -> str:
    """'/name' for 'name' (bags store fully qualified topic names)."""
    return topic if topic.startswith('/') else '/' + topic


class Rosbag2McapWriter:
    """A rosbag2 directory ``<dir>/metadata.yaml`` + ``<dir>/<dir name>_0.mcap``.

    ``flush_period_s`` [s]: while messages arrive, the open chunk is closed and written and
    the file flushed (and fsync'd when ``fsync``) at least this often, and on :meth:`flush`;
    after a crash everything older is recoverable with :func:`gear_phm.bagio.recover`.
    None: chunks close only at ``chunk_size`` [bytes of uncompressed records] and on close.
    ``compression``: None, 'zstd' or 'lz4' (per MCAP chunk; rosbag2 reads it transparently).
    Output is deterministic for the same calls when ``flush_period_s`` is None (no clock
    value is written). ``batch``: write through :class:`gear_phm.bagio.batch_writer.BatchWriter`
    (the same file layout as mcap's Writer, with :meth:`write_vector3_columns` packed by numpy;
    ``gear-phm analyze`` uses it) instead of mcap's Writer.
    """

    def __init__(self, directory: str | Path, compression: str | None = 'zstd',
                 flush_period_s: float | None = 0.5, fsync: bool = False,
                 chunk_size: int = 1 << 20, batch: bool = False) -> None:
        self.directory = Path(directory)
        if compression is not None and compression not in COMPRESSIONS:
            raise ValueError(f'compression must be one of None, zstd, lz4, got {compression!r}')
        if flush_period_s is not None and flush_period_s <= 0:
            raise ValueError(f'flush_period_s must be > 0 or None, got {flush_period_s!r}')
        if self.directory.exists() and any(self.directory.iterdir()):
            raise FileExistsError(f'{self.directory} exists and is not empty')
        self.directory.mkdir(parents=True, exist_ok=True)
        self._batch = batch
        self._chunk_size = chunk_size
        self._compression = COMPRESSIONS[compression or '']
        self._topics: dict[str, TopicInfo] = {}
        self._schemas: dict[str, int] = {}
        self._msgdefs: dict[str, str] = {}
        #: (name, first log time, last log time, message count) of each finished file
        self._files: list[tuple[str, int, int, int]] = []
        self._open_file()
        self._flush_period_s = flush_period_s
        self._fsync = fsync
        self._last_flush = time.monotonic()
        self._closed = False

    # -- topics and messages --------------------------------------------------------------
    def add_topic(self, topic: str, msgtype: str, offered_qos_profiles: str = '') -> None:
        """Declare ``topic`` of ``msgtype`` (e.g. 'sensor_msgs/msg/JointState'); idempotent.

        Relative names are stored absolute (a leading '/' added), as rosbag2 does.
        ``offered_qos_profiles`` is rosbag2's YAML text of the publishers' QoS profiles.
        """
        topic = absolute_topic(topic)
        if topic in self._topics:
            if self._topics[topic].msgtype != msgtype:
                raise ValueError(f'topic {topic!r} already added with type '
                                 f'{self._topics[topic].msgtype}, not {msgtype}')
            return
        if msgtype not in self._msgdefs:
            self._msgdefs[msgtype] = TYPESTORE.generate_msgdef(msgtype, ros_version=2)[0]
        info = TopicInfo(topic, msgtype, 0, TYPESTORE.hash_rihs01(msgtype),
                         qos=qos_list(offered_qos_profiles), offered=offered_qos_profiles)
        self._register(info)
        self._topics[topic] = info

    def _register(self, info: TopicInfo) -> None:
        """Register ``info``'s schema (once per file) and channel in the open file."""
        if info.msgtype not in self._schemas:
            self._schemas[info.msgtype] = self._writer.register_schema(
                name=info.msgtype, encoding='ros2msg',
                data=self._msgdefs[info.msgtype].encode())
        info.channel_id = self._writer.register_channel(
            topic=info.name, message_encoding='cdr', schema_id=self._schemas[info.msgtype],
            metadata={'offered_qos_profiles': info.offered,
                      'topic_type_hash': info.type_hash})

    def _open_file(self) -> None:
        """Start the bag's next file ``<dir name>_<k>.mcap`` with every topic declared."""
        self.mcap_path = self.directory / f'{self.directory.name}_{len(self._files)}.mcap'
        self._file: BinaryIO | None = open(  # noqa: SIM115 (closed in finish_file())
            self.mcap_path, 'wb')
        self._writer: Any = (BatchWriter if self._batch else Writer)(
            self._file, chunk_size=self._chunk_size, compression=self._compression)
        self._writer.start(profile='ros2', library=LIBRARY)
        self._schemas = {}
        for info in self._topics.values():
            self._register(info)
        self._file_count = self.message_count       # messages before this file
        self._start_ns: int | None = None
        self._end_ns = 0

    def write_raw(self, topic: str, t_ns: int, data: bytes | memoryview) -> None:
        """Append one CDR payload at log time ``t_ns`` [ns] to a declared topic."""
        topic = absolute_topic(topic)
        entry = self._topics.get(topic)
        if entry is None:
            raise KeyError(f'topic {topic!r} was not added')
        t_ns = int(t_ns)
        if self._file is None:
            self._open_file()
        self._writer.add_message(entry.channel_id, t_ns, bytes(data), t_ns, entry.count)
        entry.count += 1
        self._note_times(t_ns, t_ns)
        self._maybe_flush()

    def write(self, topic: str, t_ns: int, msg: Any) -> None:
        """Serialize a rosbags message object with CDR and append it."""
        msgtype = self._topics[absolute_topic(topic)].msgtype
        self.write_raw(topic, t_ns, TYPESTORE.serialize_cdr(msg, msgtype))

    def write_output(self, output: Vector3Out | DiagnosticsOut, t_ns: int | None = None) -> None:
        """Append a gear_phm output record (adds its topic on first use)."""
        t_ns = output.stamp_ns if t_ns is None else t_ns
        if isinstance(output, Vector3Out):
            if absolute_topic(output.topic) not in self._topics:
                self.add_topic(output.topic, VECTOR3_STAMPED_TYPE)
            self.write_raw(output.topic, t_ns, vector3_stamped_cdr(output))
            return
        self._write_array(output, diagnostic_array_cdr(output), t_ns)

    def _write_array(self, output: DiagnosticsOut, payload: bytes, t_ns: int | None = None
                     ) -> None:
        """Append a DiagnosticArray's CDR ``payload`` (adds its topic on first use)."""
        self.add_topic(output.topic, DIAGNOSTIC_ARRAY_TYPE)
        self.write_raw(output.topic, output.stamp_ns if t_ns is None else t_ns, payload)

    def write_outputs(self, outputs: Iterable[Vector3Out | DiagnosticsOut]) -> None:
        """Append many output records in order, each at its own stamp.

        The batch path of ``gear-phm analyze``: the same records as :meth:`write_output`, with the
        per-message bookkeeping done once per call.
        """
        add_message = self._writer.add_message
        entries: dict[str, TopicInfo] = {}
        first, last = None, None
        for output in outputs:
            if not isinstance(output, Vector3Out):
                self.write_output(output)
                continue
            entry = entries.get(output.topic)
            if entry is None:
                self.write_output(output)           # declares the topic on first use
                entries[output.topic] = self._topics[absolute_topic(output.topic)]
                continue
            t_ns = output.stamp_ns
            add_message(entry.channel_id, t_ns, vector3_stamped_cdr(output), t_ns, entry.count)
            entry.count += 1
            if first is None or t_ns < first:
                first = t_ns
            if last is None or t_ns > last:
                last = t_ns
        if first is not None and last is not None:
            self._note_times(first, last)
        self._maybe_flush()

    def write_vector3_columns(self, columns: Sequence[tuple[str, np.ndarray, np.ndarray]],
                              frame_id: str = '',
                              between: Sequence[tuple[int, DiagnosticsOut]] = ()) -> None:
        """Append Vector3Stamped messages given as columns ``(topic, stamps [ns], xyz (N, 3))``.

        They go in stamp order and, at equal stamps, in the order of ``columns`` (the order the
        nodes publish them): the same file content as :meth:`write_outputs` of the same records.
        With ``batch`` the whole block is packed at once (:mod:`gear_phm.bagio.batch_writer`).
        ``between``: (limit [ns], record) pairs, limits ascending; each record is written
        after the messages stamped at or before its limit and before the later ones (packed
        all at once, :func:`diagnostic_arrays_cdr`).
        """
        columns = [(topic, np.asarray(stamps, dtype=np.int64), np.asarray(xyz, dtype=float))
                   for topic, stamps, xyz in columns if len(stamps)]
        payloads = iter(diagnostic_arrays_cdr([record for _, record in between]))
        if not columns:
            for _, record in between:
                self._write_array(record, next(payloads))
            return
        for topic, _, _ in columns:
            if absolute_topic(topic) not in self._topics:
                self.add_topic(topic, VECTOR3_STAMPED_TYPE)
        entries = [self._topics[absolute_topic(topic)] for topic, _, _ in columns]
        stamps = np.concatenate([c[1] for c in columns])
        rank = np.concatenate([np.full(len(c[1]), i) for i, c in enumerate(columns)])
        order = np.lexsort((rank, stamps))
        xyz = np.concatenate([c[2] for c in columns])
        cuts = np.searchsorted(stamps[order], [limit for limit, _ in between],
                               side='right').tolist() + [len(order)]
        records: list[DiagnosticsOut | None] = [record for _, record in between] + [None]
        if not self._batch:
            begin = 0
            for cut, extra in zip(cuts, records):
                self.write_outputs([Vector3Out(columns[rank[i]][0], int(stamps[i]),
                                               float(xyz[i, 0]), float(xyz[i, 1]),
                                               float(xyz[i, 2]), frame_id)
                                    for i in order[begin:cut]])
                begin = cut
                if extra is not None:
                    self._write_array(extra, next(payloads))
            return
        channel = np.array([e.channel_id for e in entries])[rank][order]
        sequence = np.concatenate([e.count + np.arange(len(c[1]))
                                   for e, c in zip(entries, columns)])[order]
        rows = vector3_stamped_rows(stamps, xyz, frame_id)[order]
        packed, channel, stamps = pack_block(channel, stamps[order], rows, sequences=sequence)
        for entry, column in zip(entries, columns):
            entry.count += len(column[1])
        begin = 0
        for cut, extra in zip(cuts, records):
            if cut > begin:                     # stamps ascend: the first and last bound
                self._writer.add_packed(packed[begin:cut], channel[begin:cut],
                                        stamps[begin:cut])
                self._note_times(int(stamps[begin]), int(stamps[cut - 1]))
                self._maybe_flush()
            begin = cut
            if extra is not None:
                self._write_array(extra, next(payloads))

    def write_groups(self, parts: Sequence[tuple[str, np.ndarray, np.ndarray]]) -> None:
        """Append N groups of CDR payloads: group g is part 0's messages g, then part 1's, ...

        A part is (declared topic, stamps (N, c) [ns], payloads (N, c, L) uint8): c messages
        of one payload size per group, logged at their stamps ((N,) and (N, L) mean c = 1); a
        topic may be in several parts. The same file as :meth:`write_raw` of every message in
        that order; with ``batch`` packed at once (:meth:`BatchWriter.add_groups`).
        """
        shaped = []
        for topic, stamps, payloads in parts:
            payloads = np.asarray(payloads, dtype=np.uint8)
            if payloads.ndim == 2:
                payloads = payloads[:, None, :]
            n, count, _ = payloads.shape
            if count:
                entry = self._topics.get(absolute_topic(topic))
                if entry is None:
                    raise KeyError(f'topic {topic!r} was not added')
                stamps = np.asarray(stamps, dtype=np.int64).reshape(n, count)
                shaped.append((entry, stamps, payloads))
        if not shaped or not len(shaped[0][1]):
            return
        if not self._batch:
            for g in range(len(shaped[0][1])):
                for entry, stamps, payloads in shaped:
                    for stamp, payload in zip(stamps[g].tolist(), payloads[g]):
                        self.write_raw(entry.name, stamp, payload.tobytes())
            return
        n = len(shaped[0][1])
        per_group = {id(entry): 0 for entry, _, _ in shaped}
        for entry, _, payloads in shaped:
            per_group[id(entry)] += payloads.shape[1]
        before = dict.fromkeys(per_group, 0)
        blocks = []
        for entry, stamps, payloads in shaped:
            count = payloads.shape[1]
            sequence = (entry.count + before[id(entry)] + np.arange(count)
                        + per_group[id(entry)] * np.arange(n)[:, None])
            before[id(entry)] += count
            blocks.append((entry.channel_id, stamps, payloads, sequence))
        for entry, _, _ in shaped:
            entry.count += n * per_group.pop(id(entry), 0)
        self._writer.add_groups(blocks)
        self._note_times(min(int(s.min()) for _, s, _ in shaped),
                         max(int(s.max()) for _, s, _ in shaped))
        self._maybe_flush()

    def _note_times(self, first_ns: int, last_ns: int) -> None:
        """Widen the bag's time range [ns] (metadata.yaml) to hold first..last."""
        self._start_ns = first_ns if self._start_ns is None else min(self._start_ns, first_ns)
        self._end_ns = max(self._end_ns, last_ns)

    def _maybe_flush(self) -> None:
        """Flush once ``flush_period_s`` has passed since the last flush."""
        if self._flush_period_s is not None \
                and time.monotonic() - self._last_flush >= self._flush_period_s:
            self.flush()

    def flush(self) -> None:
        """Close the open chunk (if it holds a message) and write it with its message indexes.

        Then push the file to the OS (and to disk, with ``fsync``).
        """
        if self._closed or self._file is None:
            return
        self._writer.flush()
        if self._fsync:
            os.fsync(self._file.fileno())
        self._last_flush = time.monotonic()

    @property
    def message_count(self) -> int:
        return sum(t.count for t in self._topics.values())

    # -- closing --------------------------------------------------------------------------
    def finish_file(self) -> None:
        """Finish the open file (MCAP summary and footer) and write metadata.yaml listing it.

        The bag on disk is then complete. A later :meth:`write_raw` starts the next file
        ``<dir name>_<k>.mcap`` (rosbag2's split layout); nothing to finish: nothing done.
        """
        file = self._file
        if file is None:
            return
        self._file = None
        try:
            self._writer.finish()
            file.flush()
            os.fsync(file.fileno())
        finally:
            file.close()
        start_ns = self._start_ns or 0
        self._files.append((self.mcap_path.name, start_ns, max(start_ns, self._end_ns),
                            self.message_count - self._file_count))
        write_metadata(self.directory, self._files, list(self._topics.values()))

    def close(self) -> None:
        """Write the MCAP summary and footer, then metadata.yaml (atomically)."""
        if self._closed:
            return
        self._closed = True
        self.finish_file()

    def __enter__(self) -> Rosbag2McapWriter:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self.close()


# --- gear_phm output records -> rosbags messages -------------------------------------------
def _header(stamp_ns: int, frame_id: str = '') -> Any:
    sec, nanosec = ns_to_sec_nanosec(stamp_ns)
    return TYPESTORE.types['std_msgs/msg/Header'](
        stamp=TYPESTORE.types['builtin_interfaces/msg/Time'](sec=sec, nanosec=nanosec),
        frame_id=frame_id)


def diagnostic_array_cdr(output: DiagnosticsOut) -> bytes:
    """Little-endian CDR of a diagnostic_msgs/DiagnosticArray, packed directly.

    The tests check the bytes are identical to rosbags' serializer for any strings and list
    lengths.

    Offsets count from the end of the 4-byte encapsulation header, as CDR alignment does.
    Every string starts 4-aligned, so a string followed by another string or a uint32 takes
    its length, UTF-8, NUL and padding to 4 (:func:`_cdr_text`; the constant ones, names and
    keys, cached); only the last string of a status, followed by the next status's level
    byte or the end, goes without its padding.
    """
    sec, nanosec = divmod(int(output.stamp_ns), 1_000_000_000)
    parts = [_ARRAY_HEAD, _STAMP.pack(sec, nanosec), _EMPTY_FRAME,
             _UINT32.pack(len(output.statuses))]
    size = 16                                   # header and frame_id, from the CDR origin
    for status in output.statuses:
        level = _LEVEL_HEADS[int(status.level)][size % 4]
        body = [_cdr_constant(status.name), _cdr_text(status.message),
                _cdr_constant(status.hardware_id), _UINT32.pack(len(status.values))]
        for key, value in status.values:
            body.append(_cdr_constant(key))
            body.append(_cdr_text(value))
        if status.values:                       # no padding after the status's last string
            data = status.values[-1][1].encode()
            body[-1] = _UINT32.pack(len(data) + 1) + data + b'\x00'
        parts.append(level)
        parts += body
        size += len(level) + sum(map(len, body))
    return b''.join(parts)


def diagnostic_arrays_cdr(outputs: Sequence[DiagnosticsOut]) -> list[bytes]:
    """Return :func:`diagnostic_array_cdr` of each output, all packed at once by numpy.

    The Python work is per status (its strings gathered into one list); the sizes, the
    alignment and the bytes of every string are placed with array operations, the strings
    encoded in one piece (the tests check the bytes equal :func:`diagnostic_array_cdr`'s).
    """
    if not outputs:
        return []
    strings: list[str] = []
    levels: list[int] = []
    counts: list[int] = []                      # KeyValue pairs per status
    statuses = [len(output.statuses) for output in outputs]
    chain = itertools.chain.from_iterable
    for output in outputs:
        for status in output.statuses:
            levels.append(status.level)
            counts.append(len(status.values))
            strings += (status.name, status.message, status.hardware_id)
            strings += chain(status.values)
    per_status = np.array(counts, dtype=np.int64)
    lengths, blob = _encoded(strings)
    # pieces in order: per output its head, per status its level byte (and padding), name,
    # message, hardware_id, the count of values, then the keys and values
    in_status = 5 + 2 * per_status
    status_output = np.repeat(np.arange(len(outputs)), statuses)
    status_first = _before(in_status) + status_output + 1
    head_piece = np.arange(len(outputs)) + _before(np.bincount(
        status_output, weights=in_status, minlength=len(outputs)).astype(np.int64))
    strings_in = 3 + 2 * per_status
    local = np.arange(len(strings)) - np.repeat(_before(strings_in), strings_in)
    string_piece = (np.repeat(status_first, strings_in) + 1 + local + (local >= 3))
    sizes = np.empty(len(outputs) + int(in_status.sum()), dtype=np.int64)
    sizes[head_piece] = _DIAGNOSTIC_HEAD.itemsize
    sizes[status_first + 4] = 4
    padded = 4 + (lengths + 4) // 4 * 4        # the length, UTF-8, NUL and padding to 4
    last = per_status > 0                      # the status's last string goes unpadded
    ends = np.cumsum(strings_in) - 1
    padded[ends[last]] = 4 + lengths[ends[last]] + 1
    sizes[string_piece] = padded
    # a level byte follows a 4-aligned end, or a status's unpadded last string
    after = np.zeros(per_status.size, dtype=np.int64)
    follows = np.flatnonzero(np.diff(status_output) == 0) + 1      # not an output's first
    ended = last[follows - 1]
    after[follows[ended]] = (lengths[ends[follows[ended] - 1]] + 1) % 4
    sizes[status_first] = 1 + (-(after + 1)) % 4
    offsets = np.concatenate(([0], np.cumsum(sizes)))
    data = np.zeros(int(offsets[-1]), dtype=np.uint8)
    heads = np.zeros(len(outputs), dtype=_DIAGNOSTIC_HEAD)
    sec, nanosec = np.divmod(np.array([o.stamp_ns for o in outputs], dtype=np.int64),
                             1_000_000_000)
    heads['encapsulation'] = np.void(_ARRAY_HEAD)
    heads['sec'], heads['nanosec'] = sec, nanosec
    heads['frame'] = np.void(_EMPTY_FRAME)
    heads['statuses'] = statuses
    _scatter(data, offsets[head_piece], heads.view(np.uint8))
    data[offsets[status_first]] = levels
    _scatter(data, offsets[status_first + 4], per_status.astype('<u4').view(np.uint8))
    _scatter(data, offsets[string_piece], (lengths + 1).astype('<u4').view(np.uint8))
    # the strings' bytes, in order: runs of other bytes and of string bytes alternate
    starts = offsets[string_piece] + 4
    runs = np.empty(2 * len(strings) + 1, dtype=np.int64)
    runs[0:-1:2] = starts - np.concatenate(([0], (starts + lengths)[:-1]))
    runs[1::2] = lengths
    runs[-1] = data.size - (int(starts[-1] + lengths[-1]) if len(strings) else 0)
    data[np.repeat(np.arange(runs.size) % 2 == 1, runs)] = np.frombuffer(blob, np.uint8)
    cuts = offsets[np.append(head_piece, sizes.size)].tolist()
    packed = data.tobytes()
    return [packed[a:b] for a, b in zip(cuts[:-1], cuts[1:])]


def _encoded(strings: list[str]) -> tuple[np.ndarray, bytes]:
    """Return (UTF-8 byte length of each string, all of them encoded back to back)."""
    blob = ''.join(strings).encode()
    lengths = np.fromiter(map(len, strings), dtype=np.int64, count=len(strings))
    if len(blob) != int(lengths.sum()):         # not all ASCII: lengths in bytes
        encoded = [text.encode() for text in strings]
        lengths = np.fromiter(map(len, encoded), dtype=np.int64, count=len(encoded))
    return lengths, blob


def _before(sizes: np.ndarray) -> np.ndarray:
    """Return the exclusive cumulative sum: where each of consecutive pieces starts."""
    starts: np.ndarray = np.cumsum(sizes) - sizes
    return starts


def _scatter(data: np.ndarray, starts: np.ndarray, rows: np.ndarray) -> None:
    """Copy equal-sized byte rows (``rows`` flat, one row per start) to ``data[starts:]``."""
    if starts.size:
        width = rows.size // starts.size
        data[(starts[:, None] + np.arange(width)).ravel()] = rows


def _cdr_text(text: str) -> bytes:
    """Return a CDR string that starts 4-aligned (uint32 length with the NUL, UTF-8, NUL).

    It is padded to a multiple of 4 bytes.
    """
    data = text.encode()
    count = len(data) + 1
    return _UINT32.pack(count) + data + _NULS[1 + (-count % 4)]


_cdr_constant = functools.lru_cache(maxsize=1024)(_cdr_text)


_UINT32 = struct.Struct('<I')
_STAMP = struct.Struct('<iI')
_NULS = tuple(bytes(n) for n in range(5))
_ARRAY_HEAD = b'\x00\x01\x00\x00'             # CDR little-endian encapsulation
_EMPTY_FRAME = _UINT32.pack(1) + bytes(4)       # header.frame_id '' at offset 8, padded
#: The head of a DiagnosticArray: encapsulation, stamp, the empty frame_id, status count.
_DIAGNOSTIC_HEAD = np.dtype([('encapsulation', 'V4'), ('sec', '<i4'), ('nanosec', '<u4'),
                             ('frame', 'V8'), ('statuses', '<u4')])
#: A status's level byte at an offset of remainder r (mod 4), with the padding after it that
#: aligns its name: ``_LEVEL_HEADS[level][r]``.
_LEVEL_HEADS = tuple(tuple(bytes((level,)) + bytes(-(r + 1) % 4) for r in range(4))
                     for level in range(256))


def vector3_stamped_from_cdr(raw: bytes) -> tuple[int, float, float, float]:
    """(stamp [ns], x, y, z) of a little-endian CDR geometry_msgs/Vector3Stamped.

    The inverse of :func:`vector3_stamped_cdr`.
    """
    sec, nanosec, length = struct.unpack_from('<iII', raw, 4)
    offset = 12 + length                         # after frame_id, from the CDR origin
    offset = (offset + 7) // 8 * 8
    x, y, z = struct.unpack_from('<3d', raw, 4 + offset)
    return sec * 1_000_000_000 + nanosec, x, y, z


def to_rosbags(output: Vector3Out | DiagnosticsOut) -> Any:
    """Build the rosbags message object of an output record."""
    types = TYPESTORE.types
    if isinstance(output, Vector3Out):
        return types[VECTOR3_STAMPED_TYPE](
            header=_header(output.stamp_ns, output.frame_id),
            vector=types['geometry_msgs/msg/Vector3'](
                x=float(output.x), y=float(output.y), z=float(output.z)))
    status_type = types['diagnostic_msgs/msg/DiagnosticStatus']
    key_value = types['diagnostic_msgs/msg/KeyValue']
    return types[DIAGNOSTIC_ARRAY_TYPE](
        header=_header(output.stamp_ns),
        status=[status_type(level=int(s.level), name=s.name, message=s.message,
                            hardware_id=s.hardware_id,
                            values=[key_value(key=k, value=v) for k, v in s.values])
                for s in output.statuses])
