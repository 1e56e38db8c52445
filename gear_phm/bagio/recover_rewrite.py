"""Rewrite what a scan (:mod:`.recover_scan`) kept into a new MCAP file, with mcap's Writer.

Schemas, channels (with or without schema), messages (from intact chunks and outside chunks),
attachments and metadata records are copied in their order; indexes, statistics and the
summary are rebuilt by the writer. No byte of a dropped chunk is re-checksummed into the
output. The output names what was dropped in an MCAP metadata record ``gear_phm.recover``,
so a recovered file never looks like a clean recording.
"""
from __future__ import annotations

from collections.abc import Sequence
import os
from pathlib import Path

from mcap.records import Attachment, Chunk, Message, Metadata
from mcap.writer import CompressionType, Writer

from gear_phm.bagio.mcapformat import chunk_records, COMPRESSIONS, parse_record, RECORD_HEAD
from gear_phm.bagio.recover_scan import Dropped, Scan

#: Name of the MCAP metadata record (and metadata.yaml custom_data key prefix) of a recovery.
RECOVER_METADATA = 'gear_phm.recover'
#: Suffix of the file being written until it replaces its target.
_PARTIAL = '.recovering'


def rewrite(source: Scan, target: Path) -> tuple[int, list[Dropped]]:
    """Write the usable records of ``source`` to ``target`` (replaced atomically at the end).

    Returns (messages written, further drops: messages whose channel or schema was lost).
    Raises OSError when a file cannot be read or written (then ``target`` is untouched).
    """
    return _replace(source, target, None)


def rewrite_in_place(source: Scan) -> tuple[int, list[Dropped], Path]:
    """Rewrite ``source`` over its own file, keeping the original as ``<name>.orig``.

    Returns (messages written, further drops, the backup's path). Raises OSError when a file
    cannot be read or written (then the original is where it was).
    """
    backup = source.path.with_name(source.path.name + '.orig')
    count, lost = _replace(source, source.path, backup)
    return count, lost, backup


def _replace(source: Scan, target: Path, backup: Path | None) -> tuple[int, list[Dropped]]:
    """Write ``source`` beside ``target``, then move it over ``target``.

    A temporary file is written first; ``target`` is moved to ``backup`` (if given) just
    before the temporary file takes its name.
    """
    tmp = target.with_name(target.name + _PARTIAL)
    tmp.unlink(missing_ok=True)
    try:
        outcome = _write(source, tmp)
        if backup is not None:
            os.replace(target, backup)
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return outcome


def _write(source: Scan, out: Path) -> tuple[int, list[Dropped]]:
    """Write the usable records of ``source`` to the new file ``out`` with mcap's Writer.

    Returns (messages written, further drops: messages whose channel or schema was lost).
    """
    schema_ids: dict[int, int] = {}
    channel_ids: dict[int, int] = {}
    lost: dict[str, int] = {}
    written = 0
    with open(source.path, 'rb') as stream, open(out, 'xb') as sink:
        writer = Writer(sink, compression=COMPRESSIONS.get(source.compression or 'zstd',
                                                           CompressionType.ZSTD))
        writer.start(profile=source.profile, library=source.library)
        for old, schema in sorted(source.schemas.items()):
            schema_ids[old] = writer.register_schema(schema.name, schema.encoding,
                                                     schema.data)
        for old, channel in sorted(source.channels.items()):
            if channel.schema_id != 0 and channel.schema_id not in schema_ids:
                continue                        # its messages are counted as lost below
            channel_ids[old] = writer.register_channel(
                channel.topic, channel.message_encoding, schema_ids.get(channel.schema_id, 0),
                dict(channel.metadata))

        def add(message: Message) -> None:
            nonlocal written
            new = channel_ids.get(message.channel_id)
            if new is None:
                channel = source.channels.get(message.channel_id)
                key = (f'channel {message.channel_id} (undefined)' if channel is None else
                       f'channel {channel.topic!r} (its schema {channel.schema_id} was lost)')
                lost[key] = lost.get(key, 0) + 1
                return
            writer.add_message(new, message.log_time, message.data, message.publish_time,
                               message.sequence)
            written += 1

        for offset, opcode in source.usable:
            stream.seek(offset)
            _, length = RECORD_HEAD.unpack(stream.read(RECORD_HEAD.size))
            record = parse_record(opcode, stream.read(length))
            if isinstance(record, Chunk):
                for _, item in chunk_records(record):
                    if isinstance(item, Message):
                        add(item)
            elif isinstance(record, Message):
                add(record)
            elif isinstance(record, Attachment):
                writer.add_attachment(record.create_time, record.log_time, record.name,
                                      record.media_type, record.data)
            elif isinstance(record, Metadata):
                writer.add_metadata(record.name, dict(record.metadata))
        extra = [Dropped(0, 0, 'messages', f'{count} messages of {key}', messages=count)
                 for key, count in lost.items()]
        writer.add_metadata(RECOVER_METADATA, provenance(source, extra))
        writer.finish()  # type: ignore[no-untyped-call]  # mcap's Writer is unannotated
        sink.flush()
        os.fsync(sink.fileno())
    return written, extra


def provenance(source: Scan, extra: Sequence[Dropped] = ()) -> dict[str, str]:
    """Return the key-value record of a recovery: the source and every dropped range."""
    drops = [*source.dropped, *extra]
    values = {'source': source.path.name, 'dropped_ranges': str(len(drops)),
              'dropped_messages_known': str(sum(d.messages or 0 for d in drops))}
    for number, dropped in enumerate(drops):
        values[f'dropped_{number}'] = dropped.describe()
    return values
