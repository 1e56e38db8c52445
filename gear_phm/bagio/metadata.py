"""rosbag2's ``metadata.yaml`` (version 9, Jazzy): writing it, and reading its file list.

The writer (:mod:`.writer`) writes it on close from the topics it declared; the recovery
(:mod:`.recover`) writes it from what it scanned, and reads the list of storage files of a
bag it recovers.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from gear_phm.staging import write_atomic

#: The name of the file in a rosbag2 directory.
METADATA_FILE = 'metadata.yaml'
#: The rosbag2 metadata version written (Jazzy).
ROSBAG2_VERSION = 9
_QOS_KEYS = frozenset(('history', 'depth', 'reliability', 'durability', 'deadline', 'lifespan',
                       'liveliness', 'liveliness_lease_duration',
                       'avoid_ros_namespace_conventions'))


@dataclass
class TopicInfo:
    """One topic of a rosbag2 bag as metadata.yaml lists it."""

    name: str
    msgtype: str
    channel_id: int
    type_hash: str
    count: int = 0
    #: offered QoS profiles as rosbag2 version 9 lists them (list of dicts).
    qos: list[Any] = field(default_factory=list)
    #: the same as rosbag2's YAML text, for the MCAP channel metadata
    offered: str = ''


def qos_list(offered_qos_profiles: str) -> list[Any]:
    """Return rosbag2's QoS YAML text (MCAP channel metadata) as metadata.yaml lists it.

    Version 9 holds a list of profiles; [] when the text is empty, not YAML, or not a list
    of complete profiles.
    """
    if not offered_qos_profiles:
        return []
    try:
        value = yaml.safe_load(offered_qos_profiles)
    except yaml.YAMLError:
        return []
    if isinstance(value, list) and all(isinstance(item, dict) and _QOS_KEYS <= set(item)
                                       for item in value):
        return value
    return []


def write_metadata(directory: Path, files: Sequence[tuple[str, int, int, int]],
                   topics: Sequence[TopicInfo], custom_data: dict[str, str] | None = None
                   ) -> None:
    """Write a rosbag2 version 9 ``metadata.yaml`` (atomically: temporary file, rename).

    ``files``: (name, first log time [ns], last log time [ns], message count) per file.
    Raises OSError when the directory cannot be written.
    """
    timed = [(start, end) for _, start, end, count in files if count]
    start_ns = min((start for start, _ in timed), default=0)
    end_ns = max((end for _, end in timed), default=0)
    info = {
        'version': ROSBAG2_VERSION,
        'storage_identifier': 'mcap',
        'duration': {'nanoseconds': max(0, end_ns - start_ns)},
        'starting_time': {'nanoseconds_since_epoch': start_ns},
        'message_count': sum(t.count for t in topics),
        'topics_with_message_count': [
            {'topic_metadata': {'name': t.name, 'type': t.msgtype,
                                'serialization_format': 'cdr', 'offered_qos_profiles': t.qos,
                                'type_description_hash': t.type_hash},
             'message_count': t.count}
            for t in topics],
        'compression_format': '',
        'compression_mode': '',
        'relative_file_paths': [name for name, *_ in files],
        'files': [{'path': name, 'starting_time': {'nanoseconds_since_epoch': start},
                   'duration': {'nanoseconds': max(0, end - start)}, 'message_count': count}
                  for name, start, end, count in files],
        'custom_data': dict(custom_data or {}),
        'ros_distro': 'jazzy',
    }
    text = yaml.safe_dump({'rosbag2_bagfile_information': info}, sort_keys=False)
    write_atomic(directory / METADATA_FILE, text)


def listed_files(directory: Path) -> list[Path] | None:
    """Return the storage files that ``directory/metadata.yaml`` lists, as paths in it.

    None when there is no metadata.yaml, it does not parse or lists no file, or a listed
    file is missing.
    """
    try:
        info = yaml.safe_load((directory / METADATA_FILE).read_text())
        listed = [directory / name
                  for name in info['rosbag2_bagfile_information']['relative_file_paths']]
    except (yaml.YAMLError, KeyError, TypeError, OSError):
        return None
    if listed and all(path.is_file() for path in listed):
        return listed
    return None
