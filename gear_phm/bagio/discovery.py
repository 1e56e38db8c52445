"""Which recordings to read, in which order: bag discovery and rosbag2 metadata.

A bag is a rosbag2 directory (with ``metadata.yaml``), a storage file (``.mcap``, ``.db3``)
or a ROS1 ``.bag``; a folder of such recordings stands for the recordings in it. A campaign
of recordings is read as one run, in order of their first messages (:func:`order_bags`).
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from gear_phm.bagio.reader import BagError, BagReader

#: File suffixes of recordings (rosbag2 storage files and ROS1 bags).
BAG_SUFFIXES = ('.mcap', '.db3', '.bag')


def recordings_in(folder: Path) -> list[Path]:
    """Return the recordings in a folder, sorted by name.

    Recordings are rosbag2 directories (with metadata.yaml) and bag files; :func:`order_bags`
    orders them by start time.
    """
    found = []
    for entry in sorted(folder.iterdir()):
        if entry.is_dir() and (entry / 'metadata.yaml').is_file():
            found.append(entry)
        elif entry.is_file() and entry.suffix in BAG_SUFFIXES:
            found.append(entry)
    return found


def expand(path: Path) -> list[Path]:
    """Return a bag as it is, a folder of recordings as the recordings in it.

    A folder of recordings is not itself a bag: it has no metadata.yaml and no storage
    files of its own. Raises BagError for a folder that holds no recording.
    """
    if not path.is_dir() or (path / 'metadata.yaml').is_file() or any(
            entry.suffix in BAG_SUFFIXES for entry in path.iterdir() if entry.is_file()):
        return [path]
    found = recordings_in(path)
    if not found:
        raise BagError(f'{path} holds no recording (rosbag2 directories or bag files)')
    return found


def order_bags(paths: Sequence[str | Path]) -> list[Path]:
    """Return the bags in order of their first message (a campaign of recordings).

    A folder of recordings stands for the recordings in it. Raises BagError for a path that
    is not one or does not exist, a bag given twice, or a bag that cannot be opened.
    """
    for given in paths:
        if not isinstance(given, (str, Path)):
            raise BagError(f'a bag is a path (str or Path), got {given!r}')
        if not Path(given).exists():
            raise BagError(f'bag {given} does not exist')
    expanded = [bag for given in paths for bag in expand(Path(given))]
    seen: dict[Path, Path] = {}
    for path in expanded:
        first = seen.setdefault(path.resolve(), path)
        if first is not path:       # its samples would repeat in one run: time runs twice
            raise BagError(f'bag {path} is given twice (also as {first})')
    starts = []
    for path in expanded:
        start = metadata_start_ns(Path(path))
        if start is None:
            with BagReader(path) as bag:
                start = bag.start_ns
        starts.append((start, str(path)))
    return [Path(p) for _, p in sorted(starts)]


def metadata_start_ns(path: Path) -> int | None:
    """Return a rosbag2 directory's start time [ns] from its metadata.yaml, or None.

    It is the start rosbags reports, read with libyaml: opening every bag of a campaign twice
    through rosbags' pure-Python YAML cost a third of a fleet unit's time. None where the file
    is not there or not readable; the bag is then opened, and any problem reported then.
    """
    import yaml
    metadata = path / 'metadata.yaml'
    if not metadata.is_file():
        return None
    try:
        loader = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)
        info = yaml.load(metadata.read_text(), Loader=loader)['rosbag2_bagfile_information']
        return int(info['starting_time']['nanoseconds_since_epoch'])
    except (OSError, UnicodeDecodeError, yaml.YAMLError, KeyError, TypeError, ValueError):
        return None
