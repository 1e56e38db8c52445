"""Rewriting what a scan kept (gear_phm.bagio.recover_rewrite): records, provenance, backup."""
from __future__ import annotations

from pathlib import Path

from mcap.reader import make_reader
from mcap.writer import Writer

from gear_phm.bagio.recover_rewrite import (provenance, RECOVER_METADATA, rewrite,
                                            rewrite_in_place)
from gear_phm.bagio.recover_scan import Dropped, scan


def _write(path: Path) -> list[tuple[str, int, bytes]]:
    """Write an MCAP file: two channels in small chunks, an attachment, a metadata record."""
    sent = []
    with open(path, 'wb') as stream:
        writer = Writer(stream, chunk_size=256)
        writer.start(profile='ros2', library='test')
        schema = writer.register_schema('std_msgs/msg/String', 'ros2msg', b'string data')
        channels = {topic: writer.register_channel(topic, 'cdr', schema)
                    for topic in ('/a', '/b')}
        for i in range(60):
            topic = '/a' if i % 3 else '/b'
            data = bytes([i]) * (i % 7 + 1)
            writer.add_message(channels[topic], 1_000 + 10 * i, data, 1_000 + 10 * i)
            sent.append((topic, 1_000 + 10 * i, data))
        writer.add_attachment(5, 6, 'note.txt', 'text/plain', b'kept')
        writer.add_metadata('origin', {'k': 'v'})
        writer.finish()
    return sent


def _read(path: Path) -> tuple[list[tuple[str, int, bytes]], dict[str, dict[str, str]], list]:
    with open(path, 'rb') as stream:
        reader = make_reader(stream)
        messages = [(channel.topic, message.log_time, message.data)
                    for _, channel, message in reader.iter_messages(log_time_order=False)]
        metadata = {record.name: dict(record.metadata) for record in reader.iter_metadata()}
        attachments = [(a.name, a.data) for a in reader.iter_attachments()]
    return messages, metadata, attachments


def test_an_intact_file_is_rewritten_record_for_record_with_its_provenance(
        tmp_path: Path) -> None:
    source = tmp_path / 'in.mcap'
    sent = _write(source)
    kept = scan(source)
    count, lost = rewrite(kept, tmp_path / 'out.mcap')
    assert (count, lost) == (60, [])
    messages, metadata, attachments = _read(tmp_path / 'out.mcap')
    assert sorted(messages, key=lambda m: m[1]) == sent
    assert attachments == [('note.txt', b'kept')]
    assert metadata['origin'] == {'k': 'v'}
    assert metadata[RECOVER_METADATA] == {'source': 'in.mcap', 'dropped_ranges': '0',
                                          'dropped_messages_known': '0'}
    assert not (tmp_path / 'out.mcap.recovering').exists()


def test_messages_whose_schema_was_lost_are_counted_by_channel(tmp_path: Path) -> None:
    source = tmp_path / 'in.mcap'
    _write(source)
    kept = scan(source)
    kept.schemas.clear()                         # as if the schema record was in a bad chunk
    count, lost = rewrite(kept, tmp_path / 'out.mcap')
    assert count == 0
    assert sorted(d.describe() for d in lost) == [
        "20 messages of channel '/b' (its schema 1 was lost)",
        "40 messages of channel '/a' (its schema 1 was lost)"]
    _, metadata, _ = _read(tmp_path / 'out.mcap')
    assert metadata[RECOVER_METADATA]['dropped_ranges'] == '2'
    assert metadata[RECOVER_METADATA]['dropped_messages_known'] == '60'


def test_in_place_keeps_the_original_as_orig(tmp_path: Path) -> None:
    source = tmp_path / 'bag_0.mcap'
    sent = _write(source)
    original = source.read_bytes()
    count, lost, backup = rewrite_in_place(scan(source))
    assert (count, lost, backup) == (60, [], tmp_path / 'bag_0.mcap.orig')
    assert backup.read_bytes() == original
    assert sorted(_read(source)[0], key=lambda m: m[1]) == sent


def test_provenance_describes_every_dropped_range(tmp_path: Path) -> None:
    source = tmp_path / 'in.mcap'
    _write(source)
    kept = scan(source)
    kept.dropped.append(Dropped(100, 200, 'chunk', 'CRC mismatch', 1_000, 2_000_000_000, 5))
    values = provenance(kept, [Dropped(0, 0, 'messages', '3 messages of channel 9', messages=3)])
    assert values == {'source': 'in.mcap', 'dropped_ranges': '2', 'dropped_messages_known': '8',
                      'dropped_0': 'chunk at bytes 100-200, log time 0.000-2.000 s, '
                                   '5 messages: CRC mismatch',
                      'dropped_1': '3 messages of channel 9'}
