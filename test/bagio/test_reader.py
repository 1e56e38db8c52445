"""BagReader (gear_phm.bagio.reader): the storages it reads and the errors it names."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.rosbag2 import StoragePlugin, Writer as Ros2Writer
from rosbags.typesys import get_typestore, Stores

from gear_phm.bagio import TYPESTORE
from gear_phm.bagio.reader import BagError, BagReader
from gear_phm.codec import decode_joint_states
from gear_phm.interfaces import stamp_to_ns
from helpers.bags import JOINT_STATE, joint_state, write_bag


def test_reader_accepts_sqlite3_and_ros1(tmp_path: Path) -> None:
    sqlite_bag = tmp_path / 'sqlite'
    with Ros2Writer(sqlite_bag, version=9, storage_plugin=StoragePlugin.SQLITE3) as writer:
        connection = writer.add_connection('/joint_states', JOINT_STATE, typestore=TYPESTORE)
        for i in range(20):
            cdr = TYPESTORE.serialize_cdr(joint_state(i), JOINT_STATE)
            writer.write(connection, 10**9 + i, cdr)
    ros1_store = get_typestore(Stores.ROS1_NOETIC)
    ros1_bag = tmp_path / 'old.bag'
    with Ros1Writer(ros1_bag) as writer:
        connection = writer.add_connection('/joint_states', JOINT_STATE, typestore=ros1_store)
        for i in range(20):
            msg = ros1_store.types[JOINT_STATE](
                header=ros1_store.types['std_msgs/msg/Header'](
                    seq=i, stamp=ros1_store.types['builtin_interfaces/msg/Time'](
                        sec=10, nanosec=i), frame_id=''),
                name=['motor', 'load'], position=np.zeros(2), velocity=np.array([1.0, float(i)]),
                effort=np.array([2.0, 3.0]))
            writer.write(connection, 10**9 + i, ros1_store.serialize_ros1(msg, JOINT_STATE))
    for path in (sqlite_bag, ros1_bag):
        with BagReader(path) as bag:
            topic = bag.require_topic('joint_states', JOINT_STATE)
            raws = [raw for _, _, raw in bag.raw_messages([topic])]
            msgs = [m for _, _, m in bag.messages([topic])]
        batch = decode_joint_states(raws, 'motor', 'load')
        assert len(batch) == 20
        np.testing.assert_array_equal(batch.load_velocity, [m.velocity[1] for m in msgs])
        np.testing.assert_array_equal(batch.stamp_ns, [stamp_to_ns(m.header.stamp) for m in msgs])


@pytest.mark.parametrize('make, message', [
    (lambda p: p / 'missing', 'bag not found'),
    (lambda p: (p / 'empty').mkdir() or p / 'empty', 'without metadata.yaml'),
    (lambda p: (p / 'x.txt').write_text('hi') and p / 'x.txt', 'not a bag'),
])
def test_reader_errors_name_the_problem(tmp_path: Path, make, message: str) -> None:
    path = make(tmp_path)
    with pytest.raises(BagError, match=message) as info:
        with BagReader(path):
            pass
    assert str(path) in str(info.value) and '\n' not in str(info.value)


def test_reader_topic_errors(tmp_path: Path) -> None:
    write_bag(tmp_path / 'bag', 10)
    with BagReader(tmp_path / 'bag') as bag:
        with pytest.raises(BagError, match="no topic 'wheel_states'"):
            bag.require_topic('wheel_states', JOINT_STATE)
        with pytest.raises(BagError, match='has type geometry_msgs/msg/Vector3Stamped'):
            bag.require_topic('gear_phm/friction', JOINT_STATE)
        assert bag.require_topic('joint_states', JOINT_STATE) == '/joint_states'
