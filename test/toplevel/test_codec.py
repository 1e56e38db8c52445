"""The JointState codec against rosbags' own deserializer, message by message.

Both entry points of :mod:`gear_phm.codec` are checked: the batch decoder (``gear-phm
analyze``, replay) and the one-message decoder (the estimator node), which must agree on every
payload, reasons included.
"""
from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np

from gear_phm.bagio import TYPESTORE
from gear_phm.codec import (decode_joint_state_buffer, decode_joint_states, JointStateDecoder,
                            MAX_LAYOUTS)

JOINT_STATE = 'sensor_msgs/msg/JointState'
FLOATS = st.floats(allow_nan=True, allow_infinity=True, width=64)


@st.composite
def payloads(draw: st.DrawFn) -> bytes:
    """Draw a JointState CDR payload: valid with a random layout, damaged, or random bytes."""
    kind = draw(st.sampled_from(['valid', 'valid', 'valid', 'truncated', 'big_endian',
                                 'random']))
    if kind == 'random':
        return draw(st.binary(max_size=120))
    names = draw(st.lists(st.sampled_from(['motor', 'load', 'aux', 'ü', 'wheel_joint_7']),
                          unique=True, max_size=4))
    n = len(names)
    arrays = [np.array(draw(st.lists(FLOATS, min_size=size, max_size=size)), dtype=float)
              for size in (draw(st.sampled_from([0, n, max(n - 1, 0)])),
                           draw(st.sampled_from([n, n, max(n - 1, 0)])),
                           draw(st.sampled_from([n, n, n + 1])))]
    types = TYPESTORE.types
    msg = types[JOINT_STATE](
        header=types['std_msgs/msg/Header'](
            stamp=types['builtin_interfaces/msg/Time'](
                sec=draw(st.integers(-2**31, 2**31 - 1)),
                nanosec=draw(st.integers(0, 999_999_999))),
            frame_id=draw(st.sampled_from(['', 'base', 'gearbox_frame']))),
        name=names, position=arrays[0], velocity=arrays[1], effort=arrays[2])
    raw = bytes(TYPESTORE.serialize_cdr(msg, JOINT_STATE))
    if kind == 'truncated':
        return raw[:draw(st.integers(0, len(raw) - 1))]
    if kind == 'big_endian':
        return raw[:1] + b'\x00' + raw[2:]
    return raw


COLUMNS = ('stamp_ns', 'motor_position', 'motor_velocity', 'motor_effort', 'load_position',
           'load_velocity', 'load_effort')


def reference_row(msg, motor: str = 'motor', load: str = 'load') -> tuple | None:
    """Return the row of COLUMNS of a rosbags JointState, None if it lacks a joint's data.

    Position may be empty (then 0.0); velocity and effort must reach both joints' indices.
    """
    names = list(msg.name)
    if motor not in names or load not in names:
        return None
    m, j = names.index(motor), names.index(load)
    if min(len(msg.velocity), len(msg.effort)) <= max(m, j):
        return None
    position = msg.position
    return (msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec,
            float(position[m]) if len(position) > m else 0.0, float(msg.velocity[m]),
            float(msg.effort[m]), float(position[j]) if len(position) > j else 0.0,
            float(msg.velocity[j]), float(msg.effort[j]))


def reference(raws: list[bytes]) -> tuple[list[tuple], int]:
    """Return (rows, rejected count) decoded one by one with rosbags."""
    rows, rejected = [], 0
    for raw in raws:
        try:
            msg = TYPESTORE.deserialize_cdr(raw, JOINT_STATE)
            if raw[1] != 0x01:
                raise ValueError('big-endian: gear_phm accepts little-endian CDR only')
            row = reference_row(msg)
        except Exception:  # noqa: BLE001 rosbags raises many types
            row = None
        if row is None:
            rejected += 1
        else:
            rows.append(row)
    return rows, rejected


def assert_same(raws: list[bytes]) -> None:
    rows, rejected = reference(raws)
    batch = decode_joint_states(raws, 'motor', 'load')
    assert len(batch) == len(rows)
    assert len(batch.rejected_at) == rejected
    assert sorted(batch.message_index.tolist() + [i for i, _ in batch.rejected_at]) == \
        list(range(len(raws)))
    expected = np.array(rows, dtype=object).reshape(-1, len(COLUMNS))
    for k, column in enumerate(COLUMNS):
        np.testing.assert_array_equal(getattr(batch, column),
                                      expected[:, k].astype(getattr(batch, column).dtype),
                                      err_msg=column)
    assert_live_decoder_agrees(raws, batch)


def assert_live_decoder_agrees(raws: list[bytes], batch) -> None:
    """Check the node's one-message decoder gives the batch's values and reasons."""
    decoder = JointStateDecoder('motor', 'load')
    results = [decoder.decode(raw) for raw in raws]
    assert [(i, r) for i, r in enumerate(results) if isinstance(r, str)] == batch.rejected_at
    kept = np.array([r for r in results if not isinstance(r, str)],
                    dtype=object).reshape(-1, 5)
    for k, column in enumerate(('stamp_ns', 'motor_velocity', 'motor_effort', 'load_velocity',
                                'load_effort')):
        np.testing.assert_array_equal(kept[:, k].astype(getattr(batch, column).dtype),
                                      getattr(batch, column), err_msg=column)


@settings(max_examples=300, deadline=None, derandomize=True)
@given(st.lists(payloads(), max_size=40))
def test_decoding_matches_rosbags_message_by_message(raws: list[bytes]) -> None:
    assert_same(raws)


@settings(max_examples=20, deadline=None, derandomize=True)
@given(st.lists(payloads(), min_size=60, max_size=120))
def test_many_layouts_fall_back_to_one_by_one(raws: list[bytes]) -> None:
    """More distinct layouts than the codec handles at once decode the same way."""
    assert MAX_LAYOUTS == 16
    assert_same(raws)


def test_same_size_different_layout_is_not_merged() -> None:
    """Two payloads of one size whose joint order differs keep their own offsets."""
    types = TYPESTORE.types

    def raw(names: list[str], velocity: list[float]) -> bytes:
        msg = types[JOINT_STATE](
            header=types['std_msgs/msg/Header'](
                stamp=types['builtin_interfaces/msg/Time'](sec=1, nanosec=2), frame_id=''),
            name=names, position=np.zeros(0), velocity=np.array(velocity),
            effort=np.array([5.0, 6.0]))
        return bytes(TYPESTORE.serialize_cdr(msg, JOINT_STATE))

    a, b = raw(['motor', 'load'], [1.0, 2.0]), raw(['load', 'motor'], [1.0, 2.0])
    assert len(a) == len(b)
    batch = decode_joint_states([a, b, a], 'motor', 'load')
    assert batch.motor_velocity.tolist() == [1.0, 2.0, 1.0]
    assert batch.load_effort.tolist() == [6.0, 5.0, 6.0]
    decoder = JointStateDecoder('motor', 'load')
    assert [decoder.decode(r) for r in (a, b, a)] == [(10**9 + 2, 1.0, 5.0, 2.0, 6.0),
                                                      (10**9 + 2, 2.0, 6.0, 1.0, 5.0),
                                                      (10**9 + 2, 1.0, 5.0, 2.0, 6.0)]


def test_buffer_with_gaps_decodes_only_the_given_spans() -> None:
    """The bag reader hands over a decompressed chunk and the payload spans inside it."""
    raws = [bytes(TYPESTORE.serialize_cdr(_simple(i), JOINT_STATE)) for i in range(5)]
    filler = b'\xff' * 13
    buffer = filler + filler.join(raws)
    offsets = np.array([13 + i * (len(raws[0]) + 13) for i in range(5)])
    batch = decode_joint_state_buffer(buffer, offsets, np.full(5, len(raws[0])), 'motor',
                                      'load')
    assert batch.load_velocity.tolist() == [0.0, 1.0, 2.0, 3.0, 4.0]
    assert batch.stamp_ns.tolist() == [10**9 + i for i in range(5)]


def _simple(i: int):
    types = TYPESTORE.types
    return types[JOINT_STATE](
        header=types['std_msgs/msg/Header'](
            stamp=types['builtin_interfaces/msg/Time'](sec=1, nanosec=i), frame_id=''),
        name=['motor', 'load'], position=np.zeros(2), velocity=np.array([9.0, float(i)]),
        effort=np.array([1.0, 2.0]))


def test_payloads_at_one_stride_read_as_at_any_offsets() -> None:
    """Payloads at one stride read as at any offsets, bit for bit.

    Payloads of one size back to back (an MCAP chunk's) are read by a strided view; the same
    payloads at irregular offsets by a gather.
    """
    rng = np.random.default_rng(7)
    raws, motor_velocity = [], []
    for i in range(50):
        msg = _simple(i)
        msg.velocity[:] = rng.normal(size=2)
        msg.effort[:] = rng.normal(size=2)
        motor_velocity.append(float(msg.velocity[0]))
        raws.append(bytes(TYPESTORE.serialize_cdr(msg, JOINT_STATE)))
    size = len(raws[0])
    gap = b'\x00' * 11                          # an odd stride: unaligned reads
    buffer = gap + gap.join(raws)
    strided = decode_joint_state_buffer(buffer, 11 + np.arange(50) * (size + 11),
                                        np.full(50, size), 'motor', 'load')
    order = np.r_[0:50:2, 1:50:2]               # not one stride: gathered
    gathered = decode_joint_state_buffer(buffer, (11 + np.arange(50) * (size + 11))[order],
                                         np.full(50, size), 'motor', 'load')
    for name in COLUMNS:
        np.testing.assert_array_equal(getattr(gathered, name), getattr(strided, name)[order])
    assert strided.stamp_ns.tolist() == [10**9 + i for i in range(50)]
    assert strided.motor_velocity.tolist() == motor_velocity
