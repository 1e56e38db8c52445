"""bagio: rosbag2 MCAP writing (mcap's Writer) read back by rosbags and by mcap's own reader.

Also errors; the crash-safety contract (flushed chunks survive kill -9) and recovery.
"""
from __future__ import annotations

import math
from pathlib import Path
import subprocess
import sys

from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import get_typestore, Stores
import yaml

from gear_phm.bagio import BagError, BagReader, recover, Rosbag2McapWriter, TYPESTORE
from gear_phm.interfaces import DiagnosticsOut, StatusOut, Vector3Out
from helpers.bags import JOINT_STATE, write_bag


def test_written_bag_reads_back_with_rosbags_and_mcap(tmp_path: Path) -> None:
    bag = tmp_path / 'out'
    write_bag(bag, 500)
    with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        assert {c.topic for c in reader.connections} == {
            '/joint_states', '/gear_phm/friction', '/diagnostics'}
        decoded = [(c.topic, t, reader.deserialize(raw, c.msgtype))
                   for c, t, raw in reader.messages()]
    assert len(decoded) == 502
    states = [m for topic, _, m in decoded if topic == '/joint_states']
    assert [float(m.velocity[0]) for m in states[:3]] == [0.0, 0.5, 1.0]
    vector = next(m for topic, _, m in decoded if topic == '/gear_phm/friction').vector
    assert (vector.x, vector.y, vector.z) == (0.125, -1.5, math.inf)
    status = next(m for topic, _, m in decoded if topic == '/diagnostics').status[0]
    assert (status.level, status.name, status.hardware_id) == (1, 'gear_phm: flap', 'bench-1')
    assert [(kv.key, kv.value) for kv in status.values] == [('u', '0.125'), ('rul_s', 'inf')]

    mcap_file = next(bag.glob('*.mcap'))
    with open(mcap_file, 'rb') as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert reader.get_header().profile == 'ros2'
        assert summary.statistics.message_count == 502
        schemas = {s.name: s for s in summary.schemas.values()}
        assert schemas[JOINT_STATE].encoding == 'ros2msg'
        assert b'MSG: std_msgs/Header' in schemas[JOINT_STATE].data
        channels = list(summary.channels.values())
        assert {c.message_encoding for c in channels} == {'cdr'}
        assert all(c.metadata['topic_type_hash'].startswith('RIHS01_') for c in channels)


@pytest.mark.parametrize('frame_id', ['', 'a', 'abc', 'abcd', 'gear_frame_12345'])
def test_fast_vector3_cdr_matches_rosbags(frame_id: str) -> None:
    from gear_phm.bagio.writer import to_rosbags, vector3_stamped_cdr, vector3_stamped_from_cdr
    output = Vector3Out('gear_phm/friction', 1_700_000_000_123_456_789, 0.1, -2.5, math.inf,
                        frame_id)
    reference = TYPESTORE.serialize_cdr(to_rosbags(output), 'geometry_msgs/msg/Vector3Stamped')
    assert vector3_stamped_cdr(output) == bytes(reference)
    assert vector3_stamped_from_cdr(bytes(reference)) == (output.stamp_ns, 0.1, -2.5, math.inf)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.integers(-2**31 * 10**9, (2**31 - 1) * 10**9 + 999_999_999),
       st.lists(st.tuples(st.integers(0, 3), st.text(max_size=9), st.text(max_size=9),
                          st.text(max_size=9),
                          st.lists(st.tuples(st.text(max_size=7), st.text(max_size=7)),
                                   max_size=4)), max_size=3))
def test_fast_diagnostic_array_cdr_matches_rosbags(stamp_ns: int, statuses: list) -> None:
    """Every string length mod 4 (alignment), unicode, empty arrays and lists.

    Packed alone and, by numpy, among others (diagnostic_arrays_cdr).
    """
    from gear_phm.bagio.writer import diagnostic_array_cdr, diagnostic_arrays_cdr, to_rosbags
    output = DiagnosticsOut(stamp_ns, tuple(StatusOut(level, name, message, hardware_id,
                                                      tuple(values))
                                            for level, name, message, hardware_id, values
                                            in statuses))
    reference = TYPESTORE.serialize_cdr(to_rosbags(output), 'diagnostic_msgs/msg/DiagnosticArray')
    assert diagnostic_array_cdr(output) == bytes(reference)
    empty = DiagnosticsOut(stamp_ns, ())
    reversed_output = DiagnosticsOut(stamp_ns, output.statuses[::-1])
    assert diagnostic_arrays_cdr([output, empty, reversed_output, output]) == [
        bytes(reference), diagnostic_array_cdr(empty), diagnostic_array_cdr(reversed_output),
        bytes(reference)]


def test_writer_is_deterministic(tmp_path: Path) -> None:
    """Same calls, same bytes: without a flush period no clock decides where chunks end.

    With one, a slow machine closes chunks elsewhere.
    """
    write_bag(tmp_path / 'a', 300, flush_period_s=None, chunk_size=4096)
    write_bag(tmp_path / 'b', 300, flush_period_s=None, chunk_size=4096)
    files_a = sorted(p.name for p in (tmp_path / 'a').iterdir())
    assert files_a == ['a_0.mcap', 'metadata.yaml']
    assert (tmp_path / 'a' / 'a_0.mcap').read_bytes() == (tmp_path / 'b' / 'b_0.mcap').read_bytes()


def test_truncated_bag_is_an_error_then_recoverable(tmp_path: Path) -> None:
    bag = tmp_path / 'bag'
    write_bag(bag, 2000, chunk_size=4096, compression=None)
    mcap_file = next(bag.glob('*.mcap'))
    data = mcap_file.read_bytes()
    mcap_file.write_bytes(data[:len(data) * 3 // 4])
    with pytest.raises(BagError, match='cannot read bag') as info:
        with BagReader(bag) as reader:
            list(reader.raw_messages())
    assert f'{mcap_file.name}: it has no footer' in str(info.value)
    assert f'run: gear-phm recover {bag}' in str(info.value)
    result = recover(bag)
    assert 1200 < result.messages < 2000
    assert result.backups == [bag / f'{mcap_file.name}.orig', bag / 'metadata.yaml.orig']
    assert (bag / f'{mcap_file.name}.orig').read_bytes() == data[:len(data) * 3 // 4]
    [(_, dropped)] = result.dropped
    assert dropped.what in ('end of file', 'tail') and dropped.end == len(data) * 3 // 4
    with BagReader(bag) as reader:
        stamps = [t for _, t, _ in reader.raw_messages(['joint_states'])]
        assert reader.message_count() == result.messages
    assert stamps == [10**10 + i * 10**6 for i in range(len(stamps))]
    assert len(stamps) == result.messages


def test_flush_period_makes_data_durable_without_close(tmp_path: Path) -> None:
    """A writer process killed with SIGKILL loses at most the data since the last flush."""
    bag = tmp_path / 'live'
    script = f"""
import os, signal, time
from gear_phm.bagio import Rosbag2McapWriter
from gear_phm.interfaces import Vector3Out
w = Rosbag2McapWriter({str(bag)!r}, flush_period_s=0.2)
for i in range(300):
    w.write_output(Vector3Out('gear_phm/friction', 10**9 + i * 10**7, float(i), 0.0, 0.0))
    time.sleep(0.005)
w.flush()
os.kill(os.getpid(), signal.SIGKILL)
"""
    result = subprocess.run([sys.executable, '-c', script], timeout=60)
    assert result.returncode == -9
    assert not (bag / 'metadata.yaml').exists()
    assert recover(bag).messages == 300
    with BagReader(bag) as reader:
        values = [m.vector.x for _, _, m in reader.messages()]
    assert values == [float(i) for i in range(300)]


def test_recover_cli(tmp_path: Path) -> None:
    bag = tmp_path / 'bag'
    write_bag(bag, 100)
    (bag / 'metadata.yaml').unlink()
    exe = Path(sys.executable).with_name('gear-phm')
    ok = subprocess.run([str(exe), 'recover', str(bag)], capture_output=True, text=True,
                        timeout=60)
    assert ok.returncode == 0, ok.stderr
    assert 'recovered 102 messages on 3 topics' in ok.stdout
    assert sorted(p.name for p in bag.iterdir()) == ['bag_0.mcap', 'metadata.yaml']
    again = subprocess.run([str(exe), 'recover', str(bag)], capture_output=True, text=True,
                           timeout=60)
    assert again.returncode == 0, again.stderr
    assert 'complete and intact (102 messages on 3 topics); nothing to recover' in again.stdout
    bad = subprocess.run([str(exe), 'recover', str(tmp_path / 'nope')], capture_output=True,
                         text=True, timeout=60)
    assert bad.returncode == 2
    assert bad.stderr.strip() == f'gear-phm recover: error: not found: {tmp_path / "nope"}'


@pytest.mark.parametrize('compression', [None, 'zstd', 'lz4'])
def test_writer_output_is_read_by_mcap_with_crcs_and_summary(tmp_path: Path,
                                                             compression: str | None) -> None:
    """Through mcap's reader with CRC validation: every message, and a consistent summary.

    Every message (any log-time order, any payload), and a summary whose statistics and indexes
    agree with the data; a flush closes the open chunk.
    """
    rng = np.random.default_rng(3)
    bag = tmp_path / 'bag'
    written = []
    with Rosbag2McapWriter(bag, compression=compression, chunk_size=1500,
                           flush_period_s=None) as writer:
        for i in range(3):
            writer.add_topic(f't{i}', 'std_msgs/msg/String')
        for sequence in range(2000):
            topic = f'/t{int(rng.integers(3))}'
            t_ns = int(rng.integers(0, 10**9))
            data = rng.bytes(int(rng.integers(0, 40)))
            writer.write_raw(topic, t_ns, data)
            written.append((topic, t_ns, data))
            if sequence == 1000:
                size = writer.mcap_path.stat().st_size
                writer.flush()
                assert writer.mcap_path.stat().st_size > size   # the open chunk is written
    with open(bag / 'bag_0.mcap', 'rb') as stream:
        reader = make_reader(stream, validate_crcs=True)
        read = [(c.topic, m.log_time, m.data) for _, c, m in reader.iter_messages()]
        summary = reader.get_summary()
    assert sorted(read) == sorted(written)
    stats = summary.statistics
    assert stats.message_count == 2000 and stats.channel_count == 3 and stats.schema_count == 1
    assert stats.chunk_count == len(summary.chunk_indexes) > 10
    assert stats.message_start_time == min(m[1] for m in written)
    assert stats.message_end_time == max(m[1] for m in written)
    assert all(index.compression == (compression or '') for index in summary.chunk_indexes)
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['message_count'] == 2000
    assert info['starting_time']['nanoseconds_since_epoch'] == stats.message_start_time
    assert info['duration']['nanoseconds'] == stats.message_end_time - stats.message_start_time
    assert {t['topic_metadata']['name']: t['message_count']
            for t in info['topics_with_message_count']} == {
        f'/t{i}': sum(1 for topic, _, _ in written if topic == f'/t{i}') for i in range(3)}


def test_offered_qos_profiles_reach_metadata_yaml(tmp_path: Path) -> None:
    profile = {'history': 'keep_last', 'depth': 10, 'reliability': 'reliable',
               'durability': 'volatile', 'deadline': {'sec': 0, 'nsec': 0},
               'lifespan': {'sec': 0, 'nsec': 0}, 'liveliness': 'automatic',
               'liveliness_lease_duration': {'sec': 0, 'nsec': 0},
               'avoid_ros_namespace_conventions': False}
    qos = yaml.safe_dump([profile])
    with Rosbag2McapWriter(tmp_path / 'bag') as writer:
        writer.add_topic('chatter', 'std_msgs/msg/String', offered_qos_profiles=qos)
        writer.write_raw('chatter', 5, bytes(TYPESTORE.serialize_cdr(
            TYPESTORE.types['std_msgs/msg/String'](data='hi'), 'std_msgs/msg/String')))
    info = yaml.safe_load((tmp_path / 'bag' / 'metadata.yaml').read_text())
    [topic] = info['rosbag2_bagfile_information']['topics_with_message_count']
    assert topic['topic_metadata']['offered_qos_profiles'] == [profile]
    with AnyReader([tmp_path / 'bag'], default_typestore=TYPESTORE) as reader:
        [(connection, t_ns, raw)] = list(reader.messages())
        assert reader.deserialize(raw, connection.msgtype).data == 'hi' and t_ns == 5
        assert connection.ext.offered_qos_profiles[0].depth == 10
    with Rosbag2McapWriter(tmp_path / 'partial') as writer:      # not all keys: not listed
        writer.add_topic('chatter', 'std_msgs/msg/String', offered_qos_profiles='- depth: 1')
    info = yaml.safe_load((tmp_path / 'partial' / 'metadata.yaml').read_text())
    [topic] = info['rosbag2_bagfile_information']['topics_with_message_count']
    assert topic['topic_metadata']['offered_qos_profiles'] == []


def test_vector3_stamped_columns_strided_and_gathered() -> None:
    """Vector3Stamped payloads decode to the records written, bit for bit.

    One size back to back: strided views; irregular offsets or several frame_ids: gathers.
    """
    from gear_phm.interfaces import vector3_stamped_columns
    from gear_phm.bagio.writer import vector3_stamped_cdr
    rng = np.random.default_rng(3)
    outputs = [Vector3Out('gear_phm/truth/friction', 1_700_000_000_000_000_000 + 10**6 * i,
                          *rng.normal(size=3).tolist()) for i in range(40)]
    outputs[5] = Vector3Out('t', -5 * 10**9 + 7, math.inf, math.nan, -0.0)   # before 1970
    raws = [vector3_stamped_cdr(o) for o in outputs]
    gap = b'\x07' * 5                                   # an odd stride: unaligned reads
    buffer = gap + gap.join(raws)
    offsets = 5 + np.arange(40) * (len(raws[0]) + 5)
    lengths = np.full(40, len(raws[0]))
    order = np.r_[1:40:2, 0:40:2]
    for at in (offsets, offsets[order]):
        stamps, xyz = vector3_stamped_columns(buffer, at, lengths)
        expected = [outputs[(at[k] - 5) // (len(raws[0]) + 5)] for k in range(40)]
        assert stamps.tolist() == [o.stamp_ns for o in expected]
        assert repr(xyz.tolist()) == repr([[o.x, o.y, o.z] for o in expected])
    framed = [vector3_stamped_cdr(Vector3Out('t', 10**9 * i, i, 2.0 * i, 3.0, 'f' * i))
              for i in range(6)]
    starts = np.cumsum([0] + [len(r) for r in framed[:-1]])
    stamps, xyz = vector3_stamped_columns(b''.join(framed), starts, [len(r) for r in framed])
    assert stamps.tolist() == [10**9 * i for i in range(6)]
    assert xyz[:, 1].tolist() == [2.0 * i for i in range(6)]
