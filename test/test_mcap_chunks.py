"""The indexed-MCAP fast path of BagReader.raw_batches against rosbags' reader.

Message by message, on bags from three writers and on the cases it must hand over or refuse.
"""
from __future__ import annotations

from pathlib import Path

from mcap.writer import CompressionType, IndexType, Writer
import numpy as np
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer as Ros2Writer

from gear_phm.bagio import BagError, BagReader, Rosbag2McapWriter, TYPESTORE
from gear_phm.bagio.chunks import RawBatch
from gear_phm.bagio.writer import _rebuild_metadata, vector3_stamped_cdr
from gear_phm.interfaces import Vector3Out

JOINT_STATE = 'sensor_msgs/msg/JointState'
VECTOR = 'geometry_msgs/msg/Vector3Stamped'
TOPICS = ['/joint_states', '/gear_phm/truth/friction']


def joint_state_cdr(i: int) -> bytes:
    types = TYPESTORE.types
    msg = types[JOINT_STATE](
        header=types['std_msgs/msg/Header'](
            stamp=types['builtin_interfaces/msg/Time'](sec=i // 1000, nanosec=i % 1000),
            frame_id='f' * (i % 3)),
        name=['motor', 'load'], position=np.zeros(2), velocity=np.array([1.0, float(i)]),
        effort=np.array([2.0, -float(i)]))
    return bytes(TYPESTORE.serialize_cdr(msg, JOINT_STATE))


def by_topic(batches) -> dict[str, list[tuple[int, bytes]]]:
    out: dict[str, list[tuple[int, bytes]]] = {}
    for batch in batches:
        assert isinstance(batch, RawBatch)
        out.setdefault(batch.topic, []).extend(zip(batch.log_time_ns.tolist(),
                                                   batch.payloads()))
    return out


def reference(bag: Path) -> dict[str, list[tuple[int, bytes]]]:
    out: dict[str, list[tuple[int, bytes]]] = {}
    with BagReader(bag) as reader:
        for topic, t_ns, raw in reader.raw_messages(TOPICS):
            out.setdefault(topic, []).append((t_ns, raw))
    return out


def fast(bag: Path) -> tuple[dict[str, list[tuple[int, bytes]]], str]:
    with BagReader(bag) as reader:
        result = by_topic(reader.raw_batches(TOPICS, batch_size=7))
        return result, reader.reader_kind


def write_mcap(directory: Path, messages: list[tuple[str, int, bytes]], **writer_args) -> None:
    """Write a rosbag2 directory with mcap's Writer directly.

    ``writer_args`` choose chunk size, compression and which indexes exist.
    """
    directory.mkdir()
    path = directory / f'{directory.name}_0.mcap'
    with open(path, 'wb') as stream:
        writer = Writer(stream, **writer_args)
        writer.start(profile='ros2', library='test')
        channels = {}
        for topic, msgtype in (('/joint_states', JOINT_STATE),
                               ('/gear_phm/truth/friction', VECTOR)):
            msgdef, _ = TYPESTORE.generate_msgdef(msgtype, ros_version=2)
            schema = writer.register_schema(msgtype, 'ros2msg', msgdef.encode())
            channels[topic] = writer.register_channel(
                topic, 'cdr', schema, {'topic_type_hash': TYPESTORE.hash_rihs01(msgtype)})
        for sequence, (topic, t_ns, data) in enumerate(messages):
            writer.add_message(channels[topic], t_ns, data, t_ns, sequence)
        writer.finish()
    _rebuild_metadata(directory, [path])


def interleaved(count: int, order: np.ndarray | None = None) -> list[tuple[str, int, bytes]]:
    """Make JointState at 1 kHz with a Vector3Stamped every 10th message, log times distinct."""
    messages = []
    for i in range(count):
        t_ns = 10**9 + i * 10**6
        messages.append(('/joint_states', t_ns, joint_state_cdr(i)))
        if i % 10 == 0:
            vector = Vector3Out('gear_phm/truth/friction', t_ns + 1, float(i), 0.0, 0.0)
            messages.append(('/gear_phm/truth/friction', t_ns + 1, vector3_stamped_cdr(vector)))
    if order is not None:
        messages = [messages[k] for k in order]
    return messages


@pytest.mark.parametrize('compression', [None, 'zstd', 'lz4'])
def test_gear_phm_writer_bag_matches_rosbags(tmp_path: Path, compression: str | None) -> None:
    bag = tmp_path / 'bag'
    with Rosbag2McapWriter(bag, compression=compression, chunk_size=4096) as writer:
        writer.add_topic('joint_states', JOINT_STATE)
        for topic, t_ns, data in interleaved(3000):
            if topic != '/joint_states':
                writer.add_topic(topic, VECTOR)
            writer.write_raw(topic, t_ns, data)
    result, kind = fast(bag)
    assert kind == 'mcap-chunks'
    expected = reference(bag)
    assert len(expected['/joint_states']) == 3000 and len(expected[TOPICS[1]]) == 300
    assert result == expected


@pytest.mark.parametrize('storage, kind', [(StoragePlugin.MCAP, 'mcap-chunks'),
                                           (StoragePlugin.SQLITE3, 'rosbags')])
def test_rosbags_writer_bags_match_rosbags(tmp_path: Path, storage: StoragePlugin,
                                           kind: str) -> None:
    """Bags from an independent writer (rosbags) read as rosbags' reader reads them.

    Its MCAP takes the chunk path, sqlite3 goes through rosbags.
    """
    bag = tmp_path / 'bag'
    with Ros2Writer(bag, version=9, storage_plugin=storage) as writer:
        connections = {topic: writer.add_connection(topic, msgtype, typestore=TYPESTORE)
                       for topic, msgtype in zip(TOPICS, (JOINT_STATE, VECTOR))}
        for topic, t_ns, data in interleaved(2000):
            writer.write(connections[topic], t_ns, data)
    result, used = fast(bag)
    assert used == kind
    assert result == reference(bag) and len(result['/joint_states']) == 2000


def test_out_of_order_and_overlapping_chunks_come_out_in_log_time_order(tmp_path: Path) -> None:
    """Messages written shuffled within a window of 60 spread over overlapping chunks.

    Each topic still comes out sorted by log time, nothing lost or repeated.
    """
    rng = np.random.default_rng(7)
    count = 2000
    keys = np.arange(count * 11 // 10) + rng.uniform(0, 60, count * 11 // 10)
    order = np.argsort(keys, kind='stable')
    bag = tmp_path / 'bag'
    write_mcap(bag, interleaved(count, order), chunk_size=2048,
               compression=CompressionType.ZSTD)
    result, kind = fast(bag)
    assert kind == 'mcap-chunks'
    expected = reference(bag)
    for topic in TOPICS:
        times = [t for t, _ in result[topic]]
        assert times == sorted(times)
        assert result[topic] == sorted(expected[topic])


def test_mcap_without_message_index_goes_through_rosbags(tmp_path: Path) -> None:
    bag = tmp_path / 'bag'
    write_mcap(bag, interleaved(500), chunk_size=2048, index_types=IndexType.CHUNK)
    result, kind = fast(bag)
    assert kind == 'rosbags'
    assert result == reference(bag)


def test_corrupt_chunk_is_a_one_line_bag_error(tmp_path: Path) -> None:
    bag = tmp_path / 'bag'
    write_mcap(bag, interleaved(3000), chunk_size=8192, compression=CompressionType.NONE)
    path = next(bag.glob('*.mcap'))
    data = bytearray(path.read_bytes())
    at = data.index(joint_state_cdr(1500))
    data[at + 40] ^= 0xFF                      # inside a payload: the chunk CRC no longer fits
    path.write_bytes(bytes(data))
    with BagReader(bag) as reader:
        with pytest.raises(BagError, match='truncated or corrupt.*checksum') as info:
            by_topic(reader.raw_batches(TOPICS))
    assert '\n' not in str(info.value) and str(bag) in str(info.value)


def test_message_index_that_disagrees_with_the_messages_is_refused(tmp_path: Path) -> None:
    from mcap.reader import make_reader
    bag = tmp_path / 'bag'
    write_mcap(bag, interleaved(1000), chunk_size=8192, compression=CompressionType.ZSTD)
    path = next(bag.glob('*.mcap'))
    with open(path, 'rb') as stream:
        chunk = make_reader(stream).get_summary().chunk_indexes[1]
    data = bytearray(path.read_bytes())
    entry = chunk.message_index_offsets[1] + 15 + 16 * 3      # 4th entry's log time
    data[entry] ^= 0x01
    path.write_bytes(bytes(data))
    with BagReader(bag) as reader:
        with pytest.raises(BagError, match='message index does not match'):
            by_topic(reader.raw_batches(TOPICS))
