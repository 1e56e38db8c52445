"""Rosbag2McapWriter.finish_file: a complete bag at once, the next message in the next file."""
from __future__ import annotations

from pathlib import Path

from mcap.reader import make_reader
from rosbags.highlevel import AnyReader

from gear_phm.bagio.writer import Rosbag2McapWriter
from gear_phm.interfaces import Vector3Out


def _stamps(bag: Path) -> list[int]:
    with AnyReader([bag]) as reader:
        return [t for _, t, _ in reader.messages()]


def _mcap_stamps(path: Path) -> list[int]:
    with open(path, 'rb') as stream:
        return [m.log_time for _, _, m in make_reader(stream).iter_messages()]


def test_finish_file_leaves_a_complete_bag_and_the_next_write_starts_the_next_file(
        tmp_path: Path) -> None:
    bag = tmp_path / 'rec'
    writer = Rosbag2McapWriter(bag, compression=None)
    for i in range(3):
        writer.write_output(Vector3Out('gear_phm/friction', 10 + i, 0.1, 0.0, 0.0))
    writer.finish_file()
    writer.finish_file()                                  # nothing open: nothing done
    assert _stamps(bag) == [10, 11, 12] and not (bag / 'rec_1.mcap').exists()
    for i in range(2):
        writer.write_raw('gear_phm/friction', 20 + i,
                         _payload(Vector3Out('gear_phm/friction', 20 + i, 0.2, 0.0, 0.0)))
    writer.close()
    assert _mcap_stamps(bag / 'rec_0.mcap') == [10, 11, 12]
    assert _mcap_stamps(bag / 'rec_1.mcap') == [20, 21]
    assert _stamps(bag) == [10, 11, 12, 20, 21]


def _payload(output: Vector3Out) -> bytes:
    from gear_phm.interfaces import vector3_stamped_cdr
    return vector3_stamped_cdr(output)
