"""Recover MCAP recordings whose writer died (``kill -9``) or whose bytes were damaged.

:func:`recover` decides what to do with a file or a rosbag2 directory: each MCAP file is
scanned (:mod:`.recover_scan`: what is intact, what has to be dropped and why), the files
that are not intact are rewritten from their usable records (:mod:`.recover_rewrite`), either
in place with the originals kept as ``<name>.orig`` or into a new file or directory, and a
rosbag2 directory gets a new metadata.yaml (:mod:`.metadata`) that names in ``custom_data``
what was dropped. A complete file (footer, magic, valid summary CRC) in which nothing had to
be dropped is left as it is.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
import os
from pathlib import Path
import re
import shutil

from gear_phm.bagio.metadata import (listed_files, METADATA_FILE, qos_list, TopicInfo,
                                     write_metadata)
from gear_phm.bagio.reader import BagError, BagReader
from gear_phm.bagio.recover_rewrite import RECOVER_METADATA, rewrite, rewrite_in_place
from gear_phm.bagio.recover_scan import Dropped, RecoverError, Scan, scan

_ROS_SCHEMA_ENCODINGS = ('ros2msg', 'ros2idl')
#: Suffixes of other storage formats, refused as ``out`` (recover writes MCAP only).
OTHER_FORMATS = ('.db3', '.sqlite3', '.bag', '.yaml')


def _natural(path: Path) -> list[object]:
    return [int(part) if part.isdigit() else part for part in re.split(r'(\d+)', path.name)]


def _bag_files(directory: Path) -> list[Path]:
    """Return the .mcap files of a rosbag2 directory: as metadata.yaml lists them, else all."""
    listed = listed_files(directory)
    if listed is None:
        return sorted(directory.glob('*.mcap'), key=_natural)
    for path in listed:
        if path.suffix != '.mcap':
            raise RecoverError(f'{path}: recover handles MCAP storage only')
    return listed


def _check_ros2(source: Scan) -> None:
    """Raise RecoverError unless every channel with messages is CDR with a ROS 2 schema."""
    for channel_id in source.counts:
        channel = source.channels.get(channel_id)
        if channel is None:
            continue                            # counted as lost when written
        schema = source.schemas.get(channel.schema_id)
        if channel.message_encoding != 'cdr' or schema is None \
                or schema.encoding not in _ROS_SCHEMA_ENCODINGS:
            kind = 'no schema' if schema is None else f'schema encoding {schema.encoding!r}'
            raise RecoverError(
                f'{source.path}: not a ROS 2 recording (channel {channel.topic!r} has '
                f'message encoding {channel.message_encoding!r}, {kind}); recover the '
                f'file alone: gear-phm recover {source.path} --out NEW.mcap')


def _topics(scans: Sequence[Scan]) -> list[TopicInfo]:
    """metadata.yaml topics (one per topic and type) of the messages that ``scans`` keep."""
    topics: dict[tuple[str, str], TopicInfo] = {}
    for source in scans:
        for channel_id, count in sorted(source.counts.items()):
            channel = source.channels.get(channel_id)
            schema = None if channel is None else source.schemas.get(channel.schema_id)
            if channel is None or schema is None:
                continue
            key = (channel.topic, schema.name)
            entry = topics.get(key)
            if entry is None:
                entry = topics[key] = TopicInfo(
                    channel.topic, schema.name, channel_id,
                    channel.metadata.get('topic_type_hash', ''),
                    qos=qos_list(channel.metadata.get('offered_qos_profiles', '')))
            entry.count += count
    return list(topics.values())


def _metadata_problem(directory: Path) -> str | None:
    """Return why rosbag2's reader refuses ``directory``'s metadata.yaml, or None if it reads.

    Called when every MCAP file of the directory is intact: what is refused then is the
    metadata (unparsable, not a rosbag2 version this reader knows, naming missing files).
    """
    try:
        with BagReader(directory):
            return None
    except BagError as exc:
        return ' '.join(str(exc).split())


def _recoverable(source: Scan) -> bool:
    """Return whether ``source`` holds any record to keep (its header at least)."""
    return bool(source.header or source.schemas or source.channels or source.messages
                or source.attachments or source.metadata)


def _write_bag_metadata(directory: Path, scans: Sequence[Scan],
                        custom_data: dict[str, str] | None) -> None:
    files = [(s.path.name, s.start_ns or 0, s.end_ns or 0, s.messages) for s in scans]
    write_metadata(directory, files, _topics(scans), custom_data)


@dataclass
class Recovery:
    """What :func:`recover` did."""

    source: Path
    output: Path
    scans: list[Scan]
    #: files written (recovered MCAP, metadata.yaml), and originals kept as backups
    written: list[Path] = field(default_factory=list)
    backups: list[Path] = field(default_factory=list)
    #: messages in the output (all files)
    messages: int = 0
    topics: int = 0
    #: messages of channels whose definition or schema was lost
    lost: list[Dropped] = field(default_factory=list)
    #: why the directory's metadata.yaml was rebuilt although it existed (None: it was not)
    metadata_problem: str | None = None

    @property
    def dropped(self) -> list[tuple[Path, Dropped]]:
        return [(s.path, d) for s in self.scans for d in s.dropped] + \
            [(self.source, d) for d in self.lost]

    @property
    def nothing_to_do(self) -> bool:
        return not self.written


def recover(path: str | Path, out: str | Path | None = None) -> Recovery:
    """Recover the rosbag2 MCAP directory or the MCAP file ``path``.

    Directory: every ``.mcap`` that lacks its footer or holds damaged records is rewritten
    from its usable records, and ``metadata.yaml`` is written. With ``out`` None this
    happens in place, each replaced file kept beside it as ``<name>.orig``; otherwise a new
    rosbag2 directory ``out`` receives the recovered and the intact files. A directory whose
    files are intact and that has metadata.yaml is left alone.

    File: written to ``out`` (default ``<stem>.recovered.mcap`` beside it) unless intact; an
    ``out`` without the ``.mcap`` suffix becomes a rosbag2 directory with metadata.yaml. An
    ``out`` named like another storage format (:data:`OTHER_FORMATS`) is refused.

    A directory whose files are intact but whose metadata.yaml rosbag2's reader refuses
    (unparsable, unknown version, naming a missing file) gets a new one, the old kept as
    ``metadata.yaml.orig`` (:attr:`Recovery.metadata_problem` says why).

    Raises RecoverError (nothing written) for non-MCAP input, input with nothing to keep (not
    even its header record), non-ROS 2 content where a rosbag2 directory is
    made, or an output that exists.
    """
    path = Path(path)
    if not path.exists():
        raise RecoverError(f'not found: {path}')
    if out is not None and Path(out).suffix.lower() in OTHER_FORMATS:
        raise RecoverError(f'--out {out}: recover writes MCAP (a .mcap file, or a rosbag2 '
                           f'directory for any other name), not {Path(out).suffix}')
    if out is not None and path.is_dir() and Path(out).suffix == '.mcap':
        raise RecoverError(f'--out {out}: a rosbag2 directory is recovered into a new '
                           'directory; give a name without the .mcap suffix')
    if path.is_dir():
        files = _bag_files(path)
        if not files:
            raise RecoverError(f'{path}: no .mcap file in this directory')
        return _recover_directory(path, files, None if out is None else Path(out))
    if out is not None and Path(out).suffix != '.mcap':
        return _recover_directory(path.parent, [path], Path(out))
    target = Path(out) if out is not None else path.with_name(f'{path.stem}.recovered.mcap')
    source = scan(path)
    result = Recovery(path, target, [source], messages=source.messages)
    if source.intact:
        return result
    if not _recoverable(source):
        raise RecoverError(_nothing(source))
    if target.exists():
        raise RecoverError(f'{target} exists; give another --out')
    result.messages, result.lost = rewrite(source, target)
    result.written.append(target)
    result.topics = len({c.topic for i, c in source.channels.items() if i in source.counts})
    return result


def _recover_directory(directory: Path, files: list[Path], out: Path | None) -> Recovery:
    scans = [scan(p) for p in files]
    for source in scans:
        _check_ros2(source)
    meta = directory / METADATA_FILE
    result = Recovery(directory, out or directory, scans)
    broken = [s for s in scans if not s.intact]
    if broken and not any(_recoverable(s) for s in scans):
        raise RecoverError(_nothing(*scans))
    result.topics = len(_topics(scans))
    result.messages = sum(s.messages for s in scans)
    if not broken and meta.is_file() and out is None:
        result.metadata_problem = _metadata_problem(directory)
        if result.metadata_problem is None:
            return result
    if out is not None:
        if out.exists() and (not out.is_dir() or any(out.iterdir())):
            raise RecoverError(f'--out {out} exists and is not an empty directory')
    else:
        backups = [s.path.with_name(s.path.name + '.orig') for s in broken]
        if meta.is_file():
            backups.append(meta.with_name(METADATA_FILE + '.orig'))
        for backup in backups:
            if backup.exists():
                raise RecoverError(f'{backup} exists (recovered before?); move it away or '
                                   f'give --out')
    created = out is not None and not out.exists()
    try:
        if out is not None:
            out.mkdir(parents=True, exist_ok=True)
        counts = _write_files(scans, broken, out, result)
        custom: dict[str, str] = {}
        for source, dropped in ((s, d) for s in broken for d in s.dropped):
            custom[f'{RECOVER_METADATA}.{source.path.name}.{len(custom)}'] = dropped.describe()
        for number, dropped in enumerate(result.lost):
            custom[f'{RECOVER_METADATA}.lost.{number}'] = dropped.describe()
        target = out or directory
        if out is None and meta.is_file():
            os.replace(meta, meta.with_name(METADATA_FILE + '.orig'))
            result.backups.append(meta.with_name(METADATA_FILE + '.orig'))
        written = [scan(target / s.path.name) if s in broken else s for s in scans]
        _write_bag_metadata(target, written, custom)
        result.written.append(target / METADATA_FILE)
        result.messages = counts
        result.topics = len(_topics(written))
    except BaseException:
        if created and out is not None:
            shutil.rmtree(out, ignore_errors=True)
        raise
    return result


def _nothing(*scans: Scan) -> str:
    """Return the message of input holding no record that recover could keep."""
    names = ', '.join(str(s.path) for s in scans)
    reasons = '; '.join(d.describe() for s in scans for d in s.dropped)
    return (f'{names}: nothing recoverable (not even its MCAP header record'
            + (f'; {reasons})' if reasons else ')') + '; nothing written')


def _write_files(scans: list[Scan], broken: list[Scan], out: Path | None,
                 result: Recovery) -> int:
    """Write the recovered files (and copy intact ones to ``out``); returns messages kept."""
    total = 0
    for source in scans:
        if source not in broken:
            total += source.messages
            if out is not None:
                shutil.copyfile(source.path, out / source.path.name)
                result.written.append(out / source.path.name)
            continue
        target = (out or source.path.parent) / source.path.name
        if out is None:
            count, lost, backup = rewrite_in_place(source)
            result.backups.append(backup)
        else:
            count, lost = rewrite(source, target)
        result.written.append(target)
        result.lost += lost
        total += count
    return total
