"""Bag input/output with rosbags and mcap (no rosbag2_py needed).

- :class:`BagReader` reads any rosbag2 directory (MCAP or sqlite3), a bare ``.mcap`` file or a
  ROS1 ``.bag``, with one-line :class:`BagError` messages for missing, corrupt or unsuitable bags.
- :class:`Rosbag2McapWriter` writes a rosbag2 (version 9, Jazzy) directory through mcap's
  ``Writer``: ``metadata.yaml`` plus one ``.mcap`` file with ``ros2msg`` schemas and CDR
  payloads, a chunk closed and flushed every ``flush_period_s`` so that a crash loses at most
  that much.
- :func:`recover` rebuilds a recording after ``kill -9`` (no MCAP footer, no metadata.yaml) or
  damage, into a new file or beside a backup of the original, dropping (and reporting) every
  record whose checksum fails.
"""
from gear_phm.bagio.reader import BagError, BagReader
from gear_phm.bagio.recover import recover, Recovery
from gear_phm.bagio.recover_scan import RecoverError
from gear_phm.bagio.writer import Rosbag2McapWriter, to_rosbags, TYPESTORE

__all__ = ['TYPESTORE', 'BagError', 'BagReader', 'RecoverError', 'Recovery',
           'Rosbag2McapWriter', 'recover', 'to_rosbags']
