"""The JointState codec: sensor_msgs/JointState CDR <-> stamps, speeds and torques (no ROS).

The one encoder (:func:`joint_state_rows`, ``gear-phm simulate``'s block writes) and the one
decoder of the package, with two entry points over one layout parser:

- :func:`decode_joint_state_buffer` (and :func:`decode_joint_states`) decodes many payloads
  at once into numpy columns (:class:`JointBatch`): ``gear-phm analyze`` hands it the
  decompressed chunks of a bag, the replay source its check batches;
- :class:`JointStateDecoder` decodes one payload at a time with one ``struct`` call: the
  estimator node's raw subscription.

Both parse a layout (frame_id, joint names, array lengths) once and reuse it for the payloads
that share it; unusable payloads give a reason, the key of the estimator's drop counter:
``missing_joint`` (a joint name is absent), ``short_arrays`` (velocity or effort too short for
a joint's index), ``truncated``, ``bad_encoding`` (not little-endian CDR). Position may be
empty (then 0.0); NaN and Inf are passed through (the estimator counts them itself).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
import functools
import operator
import struct
from typing import Any

import numpy as np

#: Distinct layouts handled at once: the batch decoder groups at most this many per batch
#: (the rest message by message), the live decoder caches at most this many.
MAX_LAYOUTS = 16

_COLUMNS = ('stamp_ns', 'motor_position', 'motor_velocity', 'motor_effort', 'load_position',
            'load_velocity', 'load_effort')


@dataclass
class JointBatch:
    """Columns of many samples (numpy arrays of equal length) and the rejected messages.

    Stamps [ns] (int64), positions [rad], speeds [rad/s], torques [N m].
    """

    stamp_ns: np.ndarray
    motor_position: np.ndarray
    motor_velocity: np.ndarray
    motor_effort: np.ndarray
    load_position: np.ndarray
    load_velocity: np.ndarray
    load_effort: np.ndarray
    #: Position of each sample's message in the decoded input.
    message_index: np.ndarray
    #: (position, reason) of each rejected message, in input order.
    rejected_at: list[tuple[int, str]] = field(default_factory=list)

    def __len__(self) -> int:
        return int(self.stamp_ns.shape[0])


# --- layouts ----------------------------------------------------------------------------------

def _align(offset: int, size: int) -> int:
    return (offset + size - 1) // size * size


def _read_string(raw: bytes, offset: int) -> tuple[str, int]:
    offset = _align(offset, 4)
    (length,) = struct.unpack_from('<I', raw, offset)
    start = offset + 4
    return raw[start:start + max(length - 1, 0)].decode('utf-8', 'replace'), start + length


@dataclass(frozen=True)
class _Layout:
    """Byte offsets of the fields of one JointState CDR layout.

    Offsets count from the start of the payload (the 4-byte encapsulation header included;
    CDR alignment counts from the end of it).
    """

    size: int
    names_start: int
    names_end: int
    length_words: tuple[int, int, int]    # uint32 element counts of position, velocity, effort
    array_offsets: tuple[int, int, int]   # start of their float64 data
    array_lengths: tuple[int, int, int]

    def signature(self) -> np.ndarray:
        """Return the offsets of the bytes that fix this layout.

        These are encapsulation, frame_id length, names and array lengths. Two payloads of
        equal size that agree there share every offset.
        """
        spans = [(0, 4), (12, 16), (self.names_start, self.names_end)]
        spans += [(w, w + 4) for w in self.length_words]
        return np.concatenate([np.arange(a, b) for a, b in spans])


def _parse_layout(raw: bytes) -> tuple[_Layout, list[str]] | None:
    """Return the layout and joint names of a little-endian payload, None if it is truncated.

    Raises struct.error, UnicodeDecodeError or IndexError on a payload cut inside its header.
    """
    body = raw[4:]
    offset = 8                                          # stamp: int32 sec, uint32 nanosec
    _, offset = _read_string(body, offset)              # frame_id
    names_start = _align(offset, 4)
    (count,) = struct.unpack_from('<I', body, names_start)
    offset = names_start + 4
    names = []
    for _ in range(count):
        name, offset = _read_string(body, offset)
        names.append(name)
    names_end = offset
    words, offsets, lengths = [], [], []
    for _ in range(3):
        offset = _align(offset, 4)
        (length,) = struct.unpack_from('<I', body, offset)
        words.append(4 + offset)
        offset += 4
        if length:
            offset = _align(offset, 8)
        offsets.append(4 + offset)
        lengths.append(length)
        offset += 8 * length
    if 4 + offset > len(raw):
        return None
    layout = _Layout(len(raw), 4 + names_start, 4 + names_end,
                     (words[0], words[1], words[2]), (offsets[0], offsets[1], offsets[2]),
                     (lengths[0], lengths[1], lengths[2]))
    return layout, names


def _any_layout(raw: bytes) -> tuple[_Layout, list[str]] | str:
    """(layout, joint names) of one payload, or the reason it is unusable for any joint."""
    if len(raw) < 8 or raw[1] != 0x01:
        return 'bad_encoding'
    try:
        parsed = _parse_layout(raw)
    except (struct.error, UnicodeDecodeError, IndexError):
        return 'truncated'
    if parsed is None:
        return 'truncated'
    return parsed


def _pair_indices(layout: _Layout, names: list[str], motor_joint: str, load_joint: str
                  ) -> tuple[int, int] | str:
    """(motor index, load index) of two joints in a layout, or the reason they are unusable."""
    if motor_joint not in names or load_joint not in names:
        return 'missing_joint'
    mi, li = names.index(motor_joint), names.index(load_joint)
    if min(layout.array_lengths[1:]) <= max(mi, li):
        return 'short_arrays'
    return mi, li


def _joint_layout(raw: bytes, motor_joint: str, load_joint: str
                  ) -> tuple[_Layout, int, int] | str:
    """(layout, motor index, load index) of one payload, or the reason it is unusable."""
    parsed = _any_layout(raw)
    if isinstance(parsed, str):
        return parsed
    layout, names = parsed
    indices = _pair_indices(layout, names, motor_joint, load_joint)
    if isinstance(indices, str):
        return indices
    return layout, indices[0], indices[1]


# --- many payloads at once (numpy) -------------------------------------------------------------

def packed(raws: Sequence[bytes]) -> tuple[bytes, np.ndarray, np.ndarray]:
    """Return ``raws`` as one buffer, each payload's offset and length (decoders' input)."""
    lengths = np.fromiter(map(len, raws), dtype=np.int64, count=len(raws))
    offsets = np.zeros(len(raws), dtype=np.int64)
    np.cumsum(lengths[:-1], out=offsets[1:])
    return b''.join(raws), offsets, lengths


def decode_joint_states(raws: Sequence[bytes], motor_joint: str, load_joint: str) -> JointBatch:
    """Decode a list of JointState CDR payloads; see :func:`decode_joint_state_buffer`."""
    return decode_joint_state_buffer(*packed(raws), motor_joint, load_joint)


def decode_joint_state_buffer(buffer: bytes | memoryview, offsets: np.ndarray,
                              lengths: np.ndarray, motor_joint: str,
                              load_joint: str) -> JointBatch:
    """Decode JointState CDR payloads into columns.

    The payloads are ``buffer[offsets[i]:offsets[i] + lengths[i]]``. Payloads that share a
    layout (size, frame_id length, joint names, array lengths; a recording from one driver
    has one) are decoded together by numpy gathers straight from ``buffer``; there is no
    Python work per message. Unusable messages are left out and listed in ``rejected_at``
    with their reason (module docstring).
    """
    offsets = np.asarray(offsets, dtype=np.int64)
    lengths = np.asarray(lengths, dtype=np.int64)
    n = offsets.size
    data = np.frombuffer(buffer, dtype=np.uint8)
    out = {name: np.zeros(n, dtype=np.int64 if name == 'stamp_ns' else float)
           for name in _COLUMNS}
    keep = np.zeros(n, dtype=bool)
    pending = np.ones(n, dtype=bool)
    rejected_at: list[tuple[int, str]] = []
    groups = 0
    while groups < MAX_LAYOUTS:
        remaining = np.flatnonzero(pending)
        if remaining.size == 0:
            break
        first = int(remaining[0])
        parsed = _joint_layout(_payload(buffer, offsets, lengths, first), motor_joint,
                               load_joint)
        if isinstance(parsed, str):
            rejected_at.append((first, parsed))
            pending[first] = False
            continue
        layout, mi, li = parsed
        groups += 1
        same = remaining[lengths[remaining] == layout.size]
        signature = layout.signature()
        rows = data[offsets[same, None] + signature]
        members = same[(rows == rows[0]).all(axis=1)]
        pending[members] = False
        keep[members] = True
        _gather(data, offsets[members], layout, mi, li, out, members)
    for i in np.flatnonzero(pending).tolist():          # many layouts: one by one
        parsed = _joint_layout(_payload(buffer, offsets, lengths, i), motor_joint, load_joint)
        if isinstance(parsed, str):
            rejected_at.append((i, parsed))
            continue
        layout, mi, li = parsed
        keep[i] = True
        _gather(data, offsets[i:i + 1], layout, mi, li, out, np.array([i]))
    rejected_at.sort()
    return JointBatch(**{name: out[name][keep] for name in _COLUMNS},
                      message_index=np.flatnonzero(keep), rejected_at=rejected_at)


def decode_joint_state_pairs(buffer: bytes | memoryview, offsets: np.ndarray,
                             lengths: np.ndarray, pairs: Sequence[tuple[str, str]]
                             ) -> list[JointBatch]:
    """Decode JointState CDR payloads into columns for several (motor, load) joint pairs.

    One :class:`JointBatch` per pair, each equal to :func:`decode_joint_state_buffer`'s for
    that pair (the same samples, values, ``message_index`` and rejections), with each layout
    parsed and each payload checked once for all pairs (many drives in one stream).
    """
    offsets = np.asarray(offsets, dtype=np.int64)
    lengths = np.asarray(lengths, dtype=np.int64)
    n = offsets.size
    data = np.frombuffer(buffer, dtype=np.uint8)
    outs = [{name: np.zeros(n, dtype=np.int64 if name == 'stamp_ns' else float)
             for name in _COLUMNS} for _ in pairs]
    keeps = [np.zeros(n, dtype=bool) for _ in pairs]
    rejections: list[list[tuple[int, str]]] = [[] for _ in pairs]
    pending = np.ones(n, dtype=bool)
    groups = 0
    while True:
        remaining = np.flatnonzero(pending)
        if remaining.size == 0:
            break
        first = int(remaining[0])
        parsed = _any_layout(_payload(buffer, offsets, lengths, first))
        if isinstance(parsed, str):
            for rejected in rejections:
                rejected.append((first, parsed))
            pending[first] = False
            continue
        layout, names = parsed
        if groups < MAX_LAYOUTS:
            groups += 1
            same = remaining[lengths[remaining] == layout.size]
            signature = layout.signature()
            rows = data[offsets[same, None] + signature]
            members = same[(rows == rows[0]).all(axis=1)]
        else:                                   # many layouts: one by one
            members = np.array([first])
        pending[members] = False
        for k, (motor_joint, load_joint) in enumerate(pairs):
            indices = _pair_indices(layout, names, motor_joint, load_joint)
            if isinstance(indices, str):
                rejections[k].extend((i, indices) for i in members.tolist())
                continue
            keeps[k][members] = True
            _gather(data, offsets[members], layout, indices[0], indices[1], outs[k], members)
    batches = []
    for out, keep, rejected_at in zip(outs, keeps, rejections):
        rejected_at.sort()
        batches.append(JointBatch(**{name: out[name][keep] for name in _COLUMNS},
                                  message_index=np.flatnonzero(keep), rejected_at=rejected_at))
    return batches


def joint_names(buffer: bytes | memoryview, offsets: np.ndarray, lengths: np.ndarray,
                count: int = 16) -> list[tuple[str, ...]]:
    """Return the distinct joint-name lists of the first ``count`` JointState payloads.

    In order of appearance; unreadable payloads are skipped. For error messages (which joints
    a bag's messages do name).
    """
    found: list[tuple[str, ...]] = []
    for i in range(min(count, len(offsets))):
        parsed = _any_layout(_payload(buffer, offsets, lengths, i))
        if not isinstance(parsed, str) and tuple(parsed[1]) not in found:
            found.append(tuple(parsed[1]))
    return found


def joints_hint(names: Sequence[tuple[str, ...]], motor_joint: str, load_joint: str) -> str:
    """Return what the joint-name lists ``names`` (:func:`joint_names`) tell a lost user.

    For a user whose joints were not found: the names the messages carry, and whether the
    two joints come in separate messages. '' without names.
    """
    if not names:
        return ''
    hint = f'the first messages name the joints {" or ".join(str(list(n)) for n in names)}'
    wanted = {motor_joint, load_joint}
    if not any(wanted <= set(n) for n in names) and wanted <= {j for n in names for j in n}:
        hint += ' (both joints must be in one message, as joint_state_broadcaster publishes them)'
    return hint


def _payload(buffer: bytes | memoryview, offsets: np.ndarray, lengths: np.ndarray,
             i: int) -> bytes:
    start = int(offsets[i])
    return bytes(buffer[start:start + int(lengths[i])])


def _gather_values(data: np.ndarray, starts: np.ndarray, dtype: str) -> np.ndarray:
    """Read one value of ``dtype`` (e.g. '<f8') at each byte offset ``starts`` of ``data``.

    ``data`` is a uint8 array; unaligned reads are allowed (a numpy gather, no Python loop).
    """
    size = np.dtype(dtype).itemsize
    return data[starts[:, None] + np.arange(size)].view(dtype)[:, 0]


def common_stride(data: np.ndarray, starts: np.ndarray) -> int | None:
    """Return the one byte step [B] between the payloads at ``starts`` of ``data``, or None.

    Payloads of one size back to back (an MCAP chunk's messages) have one step; they can be
    read as strided views of a C-contiguous ``data``, without an index per byte.
    """
    steps = np.diff(starts)
    if starts.size > 1 and data.flags.c_contiguous and steps[0] > 0 and (steps == steps[0]).all():
        return int(steps[0])
    return None


def _strided(data: np.ndarray, starts: np.ndarray) -> Callable[[int, str], np.ndarray]:
    """Return ``read(at, dtype)``: the value of ``dtype`` at byte ``at`` of each payload.

    Payloads with a :func:`common_stride` are read as a strided view; others by
    :func:`_gather_values`.
    """
    n = starts.size
    stride = common_stride(data, starts)
    if stride is not None:
        first = int(starts[0])

        def view(at: int, dtype: str) -> np.ndarray:
            return np.ndarray((n,), dtype=dtype, buffer=data, offset=first + at,
                              strides=(stride,))
        return view
    return lambda at, dtype: _gather_values(data, starts + at, dtype)


def _gather(data: np.ndarray, starts: np.ndarray, layout: _Layout, mi: int, li: int,
            out: dict[str, np.ndarray], rows: np.ndarray) -> None:
    """Copy the stamp and both joints' fields of payloads at ``starts`` (one layout)."""
    read = _strided(data, starts)
    sec = read(4, '<i4').astype(np.int64)
    out['stamp_ns'][rows] = sec * 1_000_000_000 + read(8, '<u4')
    for kind, start, length in zip(('position', 'velocity', 'effort'), layout.array_offsets,
                                   layout.array_lengths):
        for joint, j in (('motor', mi), ('load', li)):
            if j < length:          # position may be empty (stays 0.0)
                out[f'{joint}_{kind}'][rows] = read(start + 8 * j, '<f8')


# --- one payload at a time (struct) -------------------------------------------------------------

class _FastLayout:
    """One JointState CDR layout, ready for :class:`JointStateDecoder`.

    It holds the layout's constant bytes and a struct that reads the stamp, both joints'
    velocity and effort and the two array lengths in one call.
    """

    __slots__ = ('prefix_end', 'prefix', 'unpack', 'order', 'lengths')

    def __init__(self, raw: bytes, layout: _Layout, mi: int, li: int) -> None:
        self.prefix_end = layout.array_offsets[0]
        self.prefix = raw[:4] + raw[12:self.prefix_end]
        vel, eff = layout.array_offsets[1], layout.array_offsets[2]
        fields = {'sec': (4, 'i'), 'nanosec': (8, 'I'),
                  'vel_len': (layout.length_words[1], 'I'),
                  'eff_len': (layout.length_words[2], 'I'), 'wm': (vel + 8 * mi, 'd'),
                  'wl': (vel + 8 * li, 'd'), 'tm': (eff + 8 * mi, 'd'), 'tl': (eff + 8 * li, 'd')}
        fmt, position, names = '<', 0, []
        for name, (offset, code) in sorted(fields.items(), key=lambda kv: kv[1][0]):
            fmt += 'x' * (offset - position) + code
            position = offset + struct.calcsize('<' + code)
            names.append(name)
        self.unpack = struct.Struct(fmt).unpack_from
        self.order = operator.itemgetter(*(names.index(n) for n in (
            'sec', 'nanosec', 'wm', 'tm', 'wl', 'tl', 'vel_len', 'eff_len')))
        self.lengths = layout.array_lengths[1:]

    def matches(self, raw: bytes) -> bool:
        return raw[12:self.prefix_end] == self.prefix[4:] and raw[:4] == self.prefix[:4]


class JointStateDecoder:
    """Decode one serialized JointState at a time, in a few microseconds.

    :meth:`decode` gives (stamp [ns], motor speed [rad/s], motor torque [N m], load speed,
    load torque).

    The layout is parsed once and cached by size and frame_id length (at most
    :data:`MAX_LAYOUTS`); a message is checked against its layout's constant bytes and read
    with one ``struct`` call. An unusable message gives its reason (module docstring).
    """

    def __init__(self, motor_joint: str, load_joint: str) -> None:
        self.motor_joint, self.load_joint = motor_joint, load_joint
        self._layouts: dict[tuple[int, bytes], _FastLayout] = {}

    def decode(self, raw: bytes) -> tuple[int, float, float, float, float] | str:
        key = (len(raw), raw[12:16])            # size and frame_id length
        fast = self._layouts.get(key)
        if fast is None or not fast.matches(raw):
            parsed = _joint_layout(raw, self.motor_joint, self.load_joint)
            if isinstance(parsed, str):
                return parsed
            if len(self._layouts) >= MAX_LAYOUTS:
                self._layouts.clear()
            fast = self._layouts[key] = _FastLayout(raw, *parsed)
        sec, nanosec, wm, tm, wl, tl, vel_len, eff_len = fast.order(fast.unpack(raw))
        if (vel_len, eff_len) != fast.lengths:      # same size, arrays split differently
            del self._layouts[key]
            return self.decode(raw)
        return sec * 1_000_000_000 + nanosec, wm, tm, wl, tl


def joint_state_rows(stamps_ns: np.ndarray, names: Sequence[str], position: np.ndarray,
                     velocity: np.ndarray, effort: np.ndarray, frame_id: str = '') -> np.ndarray:
    """Little-endian CDR payloads of N sensor_msgs/JointState, all with the joints ``names``.

    ``position``, ``velocity``, ``effort``: (N, len(names)) [rad, rad/s, N m]. Returns an
    (N, L) uint8 array, row i the bytes rosbags' ``serialize_cdr`` gives for message i (the
    tests check it). Raises ValueError for a stamp outside builtin_interfaces/Time's seconds.
    """
    dtype, constants = _joint_state_layout(tuple(names), frame_id)
    stamps = np.asarray(stamps_ns, dtype=np.int64)
    sec, nanosec = np.divmod(stamps, 1_000_000_000)
    if len(sec) and (sec.min() < -2**31 or sec.max() >= 2**31):
        raise ValueError('a stamp is outside the int32 seconds of builtin_interfaces/Time')
    rows = np.empty(len(stamps), dtype=dtype)
    for name, value in constants.items():
        rows[name] = np.void(value)
    rows['sec'] = sec
    rows['nanosec'] = nanosec
    rows['position'] = position
    rows['velocity'] = velocity
    rows['effort'] = effort
    return rows.view(np.uint8).reshape(len(stamps), dtype.itemsize)


@functools.lru_cache(maxsize=16)
def _joint_state_layout(names: tuple[str, ...],
                        frame_id: str) -> tuple[np.dtype, dict[str, bytes]]:
    """(row dtype, constant bytes per field) of JointState CDR with these joints and frame.

    CDR aligns each value to its size, counted from the end of the 4-byte encapsulation
    header; only the stamp and the three float64 arrays vary between messages.
    """
    fields: list[tuple[Any, ...]] = [('encapsulation', 'V4'), ('sec', '<i4'), ('nanosec', '<u4')]
    constants = {'encapsulation': b'\x00\x01\x00\x00'}
    pending = bytearray()

    def align(size: int) -> None:
        pending.extend(b'\0' * (-(8 + len(pending)) % size))

    def string(text: str) -> None:
        data = text.encode() + b'\0'
        align(4)
        pending.extend(struct.pack('<I', len(data)) + data)

    string(frame_id)
    align(4)
    pending.extend(struct.pack('<I', len(names)))
    for name in names:
        string(name)
    for array in ('position', 'velocity', 'effort'):
        align(4)
        pending.extend(struct.pack('<I', len(names)))
        if names:
            align(8)
        constants[f'before_{array}'] = bytes(pending)
        fields += [(f'before_{array}', f'V{len(pending)}'), (array, '<f8', (len(names),))]
        pending = bytearray()
    return np.dtype(fields), constants


def decode_vector3_stamped_buffer(buffer: bytes | memoryview, offsets: np.ndarray,
                                  lengths: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Decode geometry_msgs/Vector3Stamped CDR payloads: stamps [ns] (int64), values (n, 3).

    The payloads as in :func:`decode_joint_state_buffer`; a numpy gather per field, no Python
    work per message (any frame_id). None when a payload is not little-endian CDR of that
    type, or its stamp's nanosec is 1e9 or more: the caller decodes those with rosbags.
    """
    offsets = np.asarray(offsets, dtype=np.int64)
    lengths = np.asarray(lengths, dtype=np.int64)
    n = offsets.size
    if n == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    data = np.frombuffer(buffer, dtype=np.uint8)
    if not (lengths >= 40).all():           # header, stamp, frame_id "\0", 3 float64
        return None
    head = data[offsets[:, None] + np.arange(4)]
    if not ((head[:, 0] == 0) & (head[:, 1] == 1)).all():        # CDR_LE
        return None
    sec = _gather_values(data, offsets + 4, '<i4').astype(np.int64)
    nanosec = _gather_values(data, offsets + 8, '<u4').astype(np.int64)
    size = _gather_values(data, offsets + 12, '<u4').astype(np.int64)   # frame_id with its NUL
    # x, y, z: 8-aligned from the end of the encapsulation header
    start = 4 + ((12 + size + 7) // 8) * 8
    if not ((size >= 1) & (start + 24 <= lengths) & (nanosec < 1_000_000_000)).all():
        return None
    values = data[(offsets + start)[:, None] + np.arange(24)].view('<f8')
    return sec * 1_000_000_000 + nanosec, values.astype(float)
