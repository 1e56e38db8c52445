"""Vectorised JointState CDR decoding against rosbags' own deserializer, message by message."""
from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np

from gear_phm.bagio import TYPESTORE
from gear_phm.interfaces import (BadMessage, decode_joint_state_buffer, decode_joint_states,
                                 joint_state_to_sample)

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


def reference(raws: list[bytes]) -> tuple[list, int]:
    """Return (samples, rejected count) decoded one by one with rosbags."""
    samples, rejected = [], 0
    for raw in raws:
        try:
            msg = TYPESTORE.deserialize_cdr(raw, JOINT_STATE)
            if raw[1] != 0x01:
                raise ValueError('big-endian: gear_phm accepts little-endian CDR only')
            samples.append(joint_state_to_sample(msg, 'motor', 'load'))
        except (BadMessage, Exception):  # noqa: BLE001 rosbags raises many types
            rejected += 1
    return samples, rejected


def assert_same(raws: list[bytes]) -> None:
    samples, rejected = reference(raws)
    batch = decode_joint_states(raws, 'motor', 'load')
    assert len(batch) == len(samples)
    assert sum(batch.rejected.values()) == rejected
    for column in ('stamp_ns', 'motor_position', 'motor_velocity', 'motor_effort',
                   'load_position', 'load_velocity', 'load_effort'):
        np.testing.assert_array_equal(getattr(batch, column),
                                      np.array([getattr(s, column) for s in samples]),
                                      err_msg=column)


@settings(max_examples=300, deadline=None, derandomize=True)
@given(st.lists(payloads(), max_size=40))
def test_decoding_matches_rosbags_message_by_message(raws: list[bytes]) -> None:
    assert_same(raws)


@settings(max_examples=20, deadline=None, derandomize=True)
@given(st.lists(payloads(), min_size=60, max_size=120))
def test_many_layouts_fall_back_to_one_by_one(raws: list[bytes]) -> None:
    """More distinct layouts than the vectorised path groups (16) decode the same way."""
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


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.lists(payloads(), max_size=30), st.data())
def test_decode_once_then_cut_equals_decoding_each_part(raws: list[bytes],
                                                        data: st.DataObject) -> None:
    """``gear-phm analyze`` decodes a whole chunk once and cuts it at /diagnostics ticks.

    Every cut must hold exactly the samples and rejection counts of decoding its messages
    alone (bad messages included, so the estimator's drop counters tick at the same place).
    """
    whole = decode_joint_states(raws, 'motor', 'load')
    cuts = sorted(data.draw(st.lists(st.integers(0, len(raws)), max_size=4)))
    bounds = [0, *cuts, len(raws)]
    for begin, end in zip(bounds[:-1], bounds[1:]):
        part = whole.messages(begin, end)
        alone = decode_joint_states(raws[begin:end], 'motor', 'load')
        assert part.rejected == alone.rejected
        assert part.message_index.tolist() == (alone.message_index + begin).tolist()
        for name in ('stamp_ns', 'motor_velocity', 'motor_effort', 'load_velocity',
                     'load_effort', 'motor_position', 'load_position'):
            np.testing.assert_array_equal(getattr(part, name), getattr(alone, name))
