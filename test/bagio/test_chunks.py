"""The MCAP path of BagReader.raw_batches: exactly the messages that were written.

Per topic in log-time order (equal times in file order), from bags of several writers and
writer options. Files the fast chunk reader cannot prove complete, and files whose own index
contradicts their content (built record by record here), are read another way with the same
answer.
"""
from __future__ import annotations

import io
from pathlib import Path
import zlib

from mcap.data_stream import RecordBuilder
from mcap.records import (Channel, Chunk, ChunkIndex, DataEnd, Footer, Header, Message,
                          MessageIndex, Schema, Statistics)
from mcap.writer import CompressionType, IndexType, Writer
import numpy as np
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer as Ros2Writer
import yaml

from gear_phm.bagio import BagError, BagReader, Rosbag2McapWriter, TYPESTORE
from gear_phm.bagio.chunks import McapBatchReader, McapChunkReader, NotIndexed, RawBatch

JOINT_STATE = 'sensor_msgs/msg/JointState'
VECTOR = 'geometry_msgs/msg/Vector3Stamped'
TOPICS = ['/joint_states', '/gear_phm/truth/friction']
TYPES = dict(zip(TOPICS, (JOINT_STATE, VECTOR)))
MAGIC = b'\x89MCAP0\r\n'

Messages = list[tuple[str, int, bytes]]


def joint_state_cdr(i: int) -> bytes:
    types = TYPESTORE.types
    msg = types[JOINT_STATE](
        header=types['std_msgs/msg/Header'](
            stamp=types['builtin_interfaces/msg/Time'](sec=i // 1000, nanosec=i % 1000),
            frame_id='f' * (i % 3)),
        name=['motor', 'load'], position=np.zeros(2), velocity=np.array([1.0, float(i)]),
        effort=np.array([2.0, -float(i)]))
    return bytes(TYPESTORE.serialize_cdr(msg, JOINT_STATE))


def vector_cdr(i: int) -> bytes:
    types = TYPESTORE.types
    msg = types[VECTOR](
        header=types['std_msgs/msg/Header'](
            stamp=types['builtin_interfaces/msg/Time'](sec=i, nanosec=1), frame_id=''),
        vector=types['geometry_msgs/msg/Vector3'](x=float(i), y=0.0, z=0.0))
    return bytes(TYPESTORE.serialize_cdr(msg, VECTOR))


def interleaved(count: int, order: np.ndarray | None = None) -> Messages:
    """Return JointState at 1 kHz with a Vector3Stamped every 10th message, log times distinct."""
    messages = []
    for i in range(count):
        t_ns = 10**9 + i * 10**6
        messages.append(('/joint_states', t_ns, joint_state_cdr(i)))
        if i % 10 == 0:
            messages.append(('/gear_phm/truth/friction', t_ns + 1, vector_cdr(i)))
    if order is not None:
        messages = [messages[k] for k in order]
    return messages


def written(messages: Messages) -> dict[str, list[tuple[int, bytes]]]:
    """Return what a conforming reader gives: per topic, by log time, equal times in file order."""
    out: dict[str, list[tuple[int, bytes]]] = {}
    for topic, t_ns, data in messages:
        out.setdefault(topic, []).append((t_ns, data))
    return {topic: sorted(items, key=lambda item: item[0]) for topic, items in out.items()}


def by_topic(batches) -> dict[str, list[tuple[int, bytes]]]:
    out: dict[str, list[tuple[int, bytes]]] = {}
    for batch in batches:
        assert isinstance(batch, RawBatch)
        times = batch.log_time_ns.tolist()
        assert times == sorted(times)
        out.setdefault(batch.topic, []).extend(zip(times, batch.payloads()))
    return out


def fast(bag: Path) -> tuple[dict[str, list[tuple[int, bytes]]], str]:
    with BagReader(bag) as reader:
        result = by_topic(reader.raw_batches(TOPICS, batch_size=7))
        return result, reader.reader_kind


def qos_yaml(reliability: int) -> str:
    """rosbag2's offered_qos_profiles of one publisher (1 reliable, 2 best effort)."""
    never = '{sec: 9223372036, nsec: 854775807}'
    return (f'- history: 1\n  depth: 10\n  reliability: {reliability}\n  durability: 2\n'
            f'  deadline: {never}\n  lifespan: {never}\n  liveliness: 1\n'
            f'  liveliness_lease_duration: {never}\n  avoid_ros_namespace_conventions: false\n')


def write_mcap(path: Path, messages: Messages, channels_per_topic: int = 1,
               **writer_args) -> Path:
    """Write a bare .mcap file with mcap's Writer.

    ``writer_args`` choose chunk size, compression, indexes, statistics; message k of a topic
    goes to its channel k % channels_per_topic (channels differ in their QoS metadata).
    """
    with open(path, 'wb') as stream:
        writer = Writer(stream, **writer_args)
        writer.start(profile='ros2', library='test')
        channels: dict[str, list[int]] = {}
        for topic, msgtype in TYPES.items():
            msgdef, _ = TYPESTORE.generate_msgdef(msgtype, ros_version=2)
            schema = writer.register_schema(msgtype, 'ros2msg', msgdef.encode())
            metadata = [{'topic_type_hash': TYPESTORE.hash_rihs01(msgtype),
                         'offered_qos_profiles': qos_yaml(1 + k % 2)}
                        for k in range(channels_per_topic)]
            channels[topic] = [writer.register_channel(topic, 'cdr', schema, m)
                               for m in metadata]
        counts = dict.fromkeys(TYPES, 0)
        for sequence, (topic, t_ns, data) in enumerate(messages):
            channel = channels[topic][counts[topic] % channels_per_topic]
            counts[topic] += 1
            writer.add_message(channel, t_ns, data, t_ns, sequence)
        writer.finish()
    return path


def craft_mcap(path: Path, chunks: list[Messages], *, unindexed: frozenset = frozenset(),
               statistics: str = 'indexed', index_chunks: bool | list[bool] = True,
               loose: Messages = (), start_ns: dict[int, int] | None = None) -> Path:
    """Build an MCAP file record by record, uncompressed, to contradict itself on purpose.

    ``chunks``: the messages of each chunk. ``unindexed``: (chunk, position) pairs left out of
    the message indexes. ``statistics``: 'indexed' counts what the indexes list, 'content'
    counts every message, 'none' writes none. ``index_chunks``: which chunks get a chunk
    index. ``loose``: messages written in the data section after the chunks. ``start_ns``:
    a chunk's start time as its chunk record and chunk index claim it.
    """
    cids = {topic: k + 1 for k, topic in enumerate(TYPES)}
    schemas = [Schema(id=cid, name=TYPES[t], encoding='ros2msg', data=b'')
               for t, cid in cids.items()]
    channels = [Channel(id=cid, topic=t, message_encoding='cdr', metadata={}, schema_id=cid)
                for t, cid in cids.items()]
    if isinstance(index_chunks, bool):
        index_chunks = [index_chunks] * len(chunks)
    out = bytearray(MAGIC)

    def put(record) -> int:
        builder = RecordBuilder()
        record.write(builder)
        at = len(out)
        out.extend(builder.end())
        return at

    put(Header(profile='ros2', library='craft'))
    indexes, counted = [], dict.fromkeys(cids.values(), 0)
    for number, messages in enumerate(chunks):
        body = RecordBuilder()
        for record in (*schemas, *channels):
            record.write(body)
        entries: dict[int, list[tuple[int, int]]] = {}
        for position, (topic, t_ns, data) in enumerate(messages):
            at = body.count
            Message(channel_id=cids[topic], log_time=t_ns, data=data, publish_time=t_ns,
                    sequence=position).write(body)
            if (number, position) not in unindexed or statistics == 'content':
                counted[cids[topic]] += 1
            if (number, position) not in unindexed:
                entries.setdefault(cids[topic], []).append((t_ns, at))
        data = body.end()
        times = [t for _, t, _ in messages]
        first = (start_ns or {}).get(number, min(times))
        start = put(Chunk(compression='', data=data, message_start_time=first,
                          message_end_time=max(times), uncompressed_crc=zlib.crc32(data),
                          uncompressed_size=len(data)))
        index_start = len(out)
        offsets = {cid: put(MessageIndex(channel_id=cid, records=records))
                   for cid, records in entries.items()}
        if index_chunks[number]:
            indexes.append(ChunkIndex(
                message_start_time=first, message_end_time=max(times),
                chunk_start_offset=start, chunk_length=index_start - start,
                message_index_offsets=offsets, message_index_length=len(out) - index_start,
                compression='', compressed_size=len(data), uncompressed_size=len(data)))
    for sequence, (topic, t_ns, data) in enumerate(loose):
        put(Message(channel_id=cids[topic], log_time=t_ns, data=data, publish_time=t_ns,
                    sequence=sequence))
        counted[cids[topic]] += statistics == 'content'
    put(DataEnd(data_section_crc=0))
    summary_start = len(out)
    for record in (*schemas, *channels, *indexes):
        put(record)
    if statistics != 'none':
        times = [t for messages in (*chunks, loose) for _, t, _ in messages]
        put(Statistics(message_count=sum(counted.values()), schema_count=len(schemas),
                       channel_count=len(channels), attachment_count=0, metadata_count=0,
                       chunk_count=len(chunks), message_start_time=min(times),
                       message_end_time=max(times), channel_message_counts=counted))
    put(Footer(summary_start=summary_start, summary_offset_start=0, summary_crc=0))
    out.extend(MAGIC)
    path.write_bytes(bytes(out))
    return path


def read_file(path: Path) -> tuple[dict[str, list[tuple[int, bytes]]], str]:
    reader = McapBatchReader([path])
    return by_topic(reader.batches(TOPICS, batch_size=7)), reader.kind


# --- bags from real writers -------------------------------------------------------------------

def test_gear_phm_writer_bag_is_read_exactly(tmp_path: Path) -> None:
    bag = tmp_path / 'bag'
    messages = interleaved(3000)
    with Rosbag2McapWriter(bag) as writer:
        for topic, msgtype in TYPES.items():
            writer.add_topic(topic, msgtype)
        for topic, t_ns, data in messages:
            writer.write_raw(topic, t_ns, data)
    result, kind = fast(bag)
    assert kind == 'mcap-chunks'
    assert result == written(messages) and len(result['/joint_states']) == 3000


@pytest.mark.parametrize('storage, kind', [(StoragePlugin.MCAP, 'mcap-chunks'),
                                           (StoragePlugin.SQLITE3, 'rosbags')])
def test_rosbags_writer_bags_are_read_exactly(tmp_path: Path, storage: StoragePlugin,
                                              kind: str) -> None:
    """Bags from an independent writer (rosbags), MCAP and sqlite3, give what was written.

    Its MCAP takes the chunk path, sqlite3 goes through rosbags.
    """
    bag = tmp_path / 'bag'
    messages = interleaved(2000)
    with Ros2Writer(bag, version=9, storage_plugin=storage) as writer:
        connections = {topic: writer.add_connection(topic, msgtype, typestore=TYPESTORE)
                       for topic, msgtype in TYPES.items()}
        for topic, t_ns, data in messages:
            writer.write(connections[topic], t_ns, data)
    result, used = fast(bag)
    assert used == kind
    assert result == written(messages) and len(result['/joint_states']) == 2000


@pytest.mark.parametrize('options, kind', [
    ({'compression': CompressionType.NONE}, 'mcap-chunks'),
    ({'compression': CompressionType.ZSTD}, 'mcap-chunks'),
    ({'compression': CompressionType.LZ4}, 'mcap-chunks'),
    ({'index_types': IndexType.CHUNK}, 'mcap-chunks'),      # no message index: walked
    ({'use_statistics': False}, 'mcap-chunks'),             # every chunk read and checked
    ({'use_statistics': False, 'index_types': IndexType.CHUNK}, 'mcap-chunks'),
    ({'index_types': IndexType.NONE}, 'mcap-scan'),
    ({'index_types': IndexType.NONE, 'use_statistics': False}, 'mcap-scan'),
    ({'repeat_channels': False}, 'mcap-scan'),
    ({'use_chunking': False}, 'mcap-scan'),
    ({'use_chunking': False, 'use_statistics': False}, 'mcap-scan'),
], ids=lambda value: value if isinstance(value, str) else '-'.join(
    f'{k}={getattr(v, "name", v)}' for k, v in value.items()))
def test_mcap_writer_options_give_every_message(tmp_path: Path, options: dict,
                                                kind: str) -> None:
    """A bare .mcap file from mcap's Writer with each option that drops an index.

    The chunk reader reads it when it can prove the answer complete, mcap's reader otherwise;
    the messages are those written either way.
    """
    messages = interleaved(1500)
    path = write_mcap(tmp_path / 'bag.mcap', messages, chunk_size=4096, **options)
    result, used = fast(path)
    assert used == kind
    assert result == written(messages)


def test_out_of_order_and_overlapping_chunks_come_out_in_log_time_order(tmp_path: Path) -> None:
    """Messages written shuffled within a window of 60 spread over overlapping chunks.

    Each topic still comes out sorted by log time, nothing lost or repeated.
    """
    rng = np.random.default_rng(7)
    count = 2000
    keys = np.arange(count * 11 // 10) + rng.uniform(0, 60, count * 11 // 10)
    messages = interleaved(count, np.argsort(keys, kind='stable'))
    path = write_mcap(tmp_path / 'bag.mcap', messages, chunk_size=2048,
                      compression=CompressionType.ZSTD)
    result, kind = fast(path)
    assert kind == 'mcap-chunks'
    assert result == written(messages)


@pytest.mark.parametrize('shuffle', [False, True])
def test_two_channels_of_one_topic_are_merged_in_log_time_order(tmp_path: Path,
                                                                shuffle: bool) -> None:
    """A topic on two channels (merged recordings, a second publisher with other QoS).

    It comes out as one stream in log-time order, never going back in time.
    """
    rng = np.random.default_rng(11)
    count = 3000
    order = None
    if shuffle:
        keys = np.arange(count * 11 // 10) + rng.uniform(0, 40, count * 11 // 10)
        order = np.argsort(keys, kind='stable')
    messages = interleaved(count, order)
    path = write_mcap(tmp_path / 'bag.mcap', messages, channels_per_topic=2, chunk_size=3000)
    result, kind = fast(path)
    assert kind == 'mcap-chunks'
    assert result == written(messages) and len(result['/joint_states']) == count


def test_equal_log_times_across_chunks_keep_file_order(tmp_path: Path) -> None:
    """Many messages share each log time and chunks split such groups.

    Equal times come out in file order, as mcap's own reader orders them.
    """
    messages = [('/joint_states', 10**9 + (i // 7) * 10**6, joint_state_cdr(i))
                for i in range(700)]
    path = write_mcap(tmp_path / 'bag.mcap', messages, chunk_size=1000, channels_per_topic=3)
    result, kind = fast(path)
    assert kind == 'mcap-chunks'
    assert result == written(messages)


def test_bag_split_over_two_files_is_merged(tmp_path: Path) -> None:
    """A directory of .mcap files without metadata.yaml (a split recording).

    The files are read together, one log-time ordered stream per topic.
    """
    messages = interleaved(1200)
    bag = tmp_path / 'split'
    bag.mkdir()
    write_mcap(bag / 'split_0.mcap', messages[0::2], chunk_size=2048)
    write_mcap(bag / 'split_1.mcap', messages[1::2], chunk_size=2048)
    result, kind = fast(bag)
    assert kind == 'mcap-chunks'
    assert result == written(messages)


def test_metadata_counts_that_disagree_with_the_index_are_not_trusted(tmp_path: Path) -> None:
    """metadata.yaml says /joint_states has more messages than the file's index lists.

    The file is read in full instead of trusting the index.
    """
    bag = tmp_path / 'bag'
    messages = interleaved(500)
    with Ros2Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {topic: writer.add_connection(topic, msgtype, typestore=TYPESTORE)
                       for topic, msgtype in TYPES.items()}
        for topic, t_ns, data in messages:
            writer.write(connections[topic], t_ns, data)
    metadata = yaml.safe_load((bag / 'metadata.yaml').read_text())
    for topic in metadata['rosbag2_bagfile_information']['topics_with_message_count']:
        if topic['topic_metadata']['name'] == '/joint_states':
            topic['message_count'] += 1
    (bag / 'metadata.yaml').write_text(yaml.safe_dump(metadata))
    result, kind = fast(bag)
    assert kind == 'mcap-scan'
    assert result == written(messages)


# --- damaged files and files that contradict themselves ---------------------------------------

def test_corrupt_chunk_is_a_one_line_bag_error(tmp_path: Path) -> None:
    path = write_mcap(tmp_path / 'bag.mcap', interleaved(3000), chunk_size=8192,
                      compression=CompressionType.NONE)
    data = bytearray(path.read_bytes())
    at = data.index(joint_state_cdr(1500))
    data[at + 40] ^= 0xFF                      # inside a payload: the chunk CRC no longer fits
    path.write_bytes(bytes(data))
    with BagReader(path) as reader:
        with pytest.raises(BagError, match='is corrupt: .*checksum') as info:
            by_topic(reader.raw_batches(TOPICS))
    assert '\n' not in str(info.value) and str(path) in str(info.value)


def chunked(messages: Messages, size: int) -> list[Messages]:
    return [messages[k:k + size] for k in range(0, len(messages), size)]


def test_message_left_out_of_the_index_is_read_from_the_chunk(tmp_path: Path) -> None:
    """No statistics to check the index against: every chunk is read.

    A message that its message index misses is found among the chunk's records.
    """
    messages = interleaved(400)
    path = craft_mcap(tmp_path / 'f.mcap', chunked(messages, 100),
                      unindexed=frozenset({(2, 17), (3, 0)}), statistics='none')
    result, kind = read_file(path)
    assert kind == 'mcap-chunks'
    assert result == written(messages)


@pytest.mark.parametrize('case', ['statistics count more', 'chunk not indexed',
                                  'message outside chunks', 'start time too late'])
def test_index_that_disagrees_with_the_content_is_not_trusted(tmp_path: Path,
                                                              case: str) -> None:
    """The chunk reader declines before yielding anything; mcap's reader gives every message."""
    messages = interleaved(400)
    chunks = chunked(messages, 100)
    loose: Messages = []
    if case == 'statistics count more':
        path = craft_mcap(tmp_path / 'f.mcap', chunks, unindexed=frozenset({(2, 17)}),
                          statistics='content')
    elif case == 'chunk not indexed':
        path = craft_mcap(tmp_path / 'f.mcap', chunks, index_chunks=[True, True, False, True,
                                                                     True])
    elif case == 'message outside chunks':
        loose = [('/joint_states', 5 * 10**9, joint_state_cdr(99999))]
        path = craft_mcap(tmp_path / 'f.mcap', chunks, loose=loose, statistics='indexed')
    else:
        path = craft_mcap(tmp_path / 'f.mcap', chunks, start_ns={1: chunks[1][5][1]})
    with pytest.raises(NotIndexed):
        McapChunkReader([path])
    result, kind = read_file(path)
    assert kind == 'mcap-scan'
    assert result == written(messages + loose)


@pytest.mark.parametrize('chunk, kind', [(0, 'mcap-scan'), (2, 'mcap-chunks+scan')])
def test_message_index_that_points_wrong_falls_back(tmp_path: Path, chunk: int,
                                                    kind: str) -> None:
    """A message index entry whose log time differs from its message's.

    Found in the first chunk: nothing was yielded, mcap's reader reads the file. Found later:
    mcap's reader continues after the messages already given, once it agrees with them.
    """
    messages = interleaved(1000)
    path = write_mcap(tmp_path / 'bag.mcap', messages, chunk_size=8192,
                      compression=CompressionType.ZSTD)
    from mcap.reader import make_reader
    with open(path, 'rb') as stream:
        index = make_reader(stream).get_summary().chunk_indexes[chunk]
    data = bytearray(path.read_bytes())
    entry = index.message_index_offsets[1] + 15 + 16 * 3      # 4th entry's log time
    data[entry] ^= 0x01
    path.write_bytes(bytes(data))
    result, used = fast(path)
    assert used == kind
    assert result == written(messages)


def test_bare_files_of_other_kinds_are_declined_not_misread(tmp_path: Path) -> None:
    """A file that is not MCAP, and one cut short, make the chunk reader decline."""
    path = write_mcap(tmp_path / 'bag.mcap', interleaved(200), chunk_size=2048)
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(path.read_bytes()[:-100])
    other = tmp_path / 'other.mcap'
    other.write_bytes(b'not an mcap file at all' * 10)
    for bad in (cut, other):
        with pytest.raises(NotIndexed):
            McapChunkReader([bad])


def test_chunk_reader_is_as_good_as_mcap_on_a_random_file(tmp_path: Path) -> None:
    """Random channels, payload sizes and log times (with repeats).

    Compared with mcap's own reader in log-time order.
    """
    from mcap.reader import make_reader
    rng = np.random.default_rng(3)
    stream = io.BytesIO()
    writer = Writer(stream, chunk_size=1500, compression=CompressionType.LZ4)
    writer.start(profile='', library='test')
    schema = writer.register_schema('pkg/msg/T', 'ros2msg', b'float64 x')
    channels = [writer.register_channel(f'/t{i % 3}', 'cdr', schema, {'k': str(i)})
                for i in range(5)]
    for sequence in range(3000):
        t_ns = int(rng.integers(0, 400)) * 10**6
        writer.add_message(channels[int(rng.integers(5))], t_ns,
                           rng.bytes(int(rng.integers(0, 40))), t_ns, sequence)
    writer.finish()
    path = tmp_path / 'random.mcap'
    path.write_bytes(stream.getvalue())
    expected: dict[str, list[tuple[int, bytes]]] = {}
    with open(path, 'rb') as file:
        for _, channel, message in make_reader(file).iter_messages(log_time_order=True):
            expected.setdefault(channel.topic, []).append((message.log_time, message.data))
    with McapChunkReader([path]) as reader:
        result = by_topic(reader.batches(['/t0', '/t1', '/t2']))
    assert result == expected and sum(map(len, result.values())) == 3000


def test_rosbags_reads_after_raw_batches_released_its_index(tmp_path: Path) -> None:
    """raw_batches frees rosbags' chunk index while it reads (the fast reader has its own).

    raw_messages on the same open bag has rosbags read it again: every message, in order.
    """
    messages = interleaved(400)
    bag = write_mcap(tmp_path / 'bag.mcap', messages, chunk_size=4000)
    with BagReader(bag) as reader:
        chunks = len(reader.reader.readers[0].storage.chunks)
        batched = by_topic(reader.raw_batches(TOPICS, batch_size=7))
        released = len(reader.reader.readers[0].storage.chunks)
        again = list(reader.raw_messages(TOPICS))
    assert chunks > 10 and released == 0 and reader.reader_kind == 'mcap-chunks'
    assert batched == written(messages) == written(again) and len(again) == len(messages)
    assert [t for _, t, _ in again] == sorted(t for _, t, _ in messages)
