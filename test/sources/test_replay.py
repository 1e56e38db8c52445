"""The publisher's sources without ROS: what they yield, in what order, and what they refuse."""
from __future__ import annotations

import itertools
from pathlib import Path
import threading

import numpy as np
import pytest

from gear_phm.bagio import BagReader
from gear_phm.sources import PASS_END, read_ahead, Recorded, SourceError
from gear_phm.sources import replay as replay_module
from gear_phm.sources.replay import ReplaySource

REPO = Path(__file__).resolve().parents[2]

HEALTHY = REPO / 'bags' / 'healthy'

JOINT_STATE = 'sensor_msgs/msg/JointState'

VECTOR3 = 'geometry_msgs/msg/Vector3Stamped'


def write_bag(path: Path, count: int, every_missing: int, truth_every: int) -> None:
    """Write a sqlite3 rosbag2 with 100 Hz JointState and a truth topic.

    Every ``every_missing``-th JointState lacks 'load'; a truth message follows every
    ``truth_every``-th sample by 5 ms.
    """
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_JAZZY)
    header = store.types['std_msgs/msg/Header']
    time_type = store.types['builtin_interfaces/msg/Time']
    vector = store.types['geometry_msgs/msg/Vector3']
    with Writer(path, version=9, storage_plugin=StoragePlugin.SQLITE3) as writer:
        joints = writer.add_connection('/joint_states', JOINT_STATE, typestore=store)
        truth = writer.add_connection('/gear_phm/truth/friction', VECTOR3, typestore=store)
        for i in range(count):
            t_ns = 10**9 + i * 10**7
            stamp = time_type(sec=t_ns // 10**9, nanosec=t_ns % 10**9)
            names = ['motor', 'other'] if i % every_missing == 0 else ['motor', 'load']
            msg = store.types[JOINT_STATE](
                header=header(stamp=stamp, frame_id=''), name=names, position=np.zeros(2),
                velocity=np.ones(2), effort=np.array([float(i), 1.0]))
            writer.write(joints, t_ns, store.serialize_cdr(msg, JOINT_STATE))
            if i % truth_every == 0:
                msg = store.types[VECTOR3](header=header(stamp=stamp, frame_id=''),
                                           vector=vector(x=float(i), y=0.0, z=0.0))
                writer.write(truth, t_ns + 5_000_000, store.serialize_cdr(msg, VECTOR3))


@pytest.mark.parametrize('check_batch', [10_000, 64])
def test_replay_source_streams_the_bag_without_bad_messages_pass_after_pass(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, check_batch: int) -> None:
    monkeypatch.setattr(replay_module, 'CHECK_BATCH', check_batch)   # one or many batches
    path = tmp_path / 'bag'
    write_bag(path, count=1000, every_missing=7, truth_every=3)
    with BagReader(path) as bag:
        recorded = list(bag.raw_messages(['/joint_states', '/gear_phm/truth/friction']))
    joint_index = itertools.count()
    kept = [(topic, t_ns, raw) for topic, t_ns, raw in recorded
            if topic != '/joint_states' or next(joint_index) % 7 != 0]
    missing = len(recorded) - len(kept)
    assert missing == 143                          # i = 0, 7, ..., 994
    source = ReplaySource(str(path), motor_joint='motor', load_joint='load', loop=True)
    assert source.dropped == {'missing_joint': 143}
    first_ns = kept[0][1]
    one_pass_ns = (kept[-1][1] - first_ns) + 10**7           # plus the median period
    per_pass = len(kept) + 1                       # and PASS_END
    items = list(itertools.islice(source.items(), 2 * per_pass + 1))
    for k in range(2):
        this_pass = items[k * per_pass:(k + 1) * per_pass]
        for (elapsed, item), (topic, t_ns, raw) in zip(this_pass, kept, strict=False):
            assert isinstance(item, Recorded)
            assert elapsed == t_ns - first_ns + k * one_pass_ns
            assert (item.log_ns, item.raw) == (t_ns, raw)
            assert item.channel == ('joints' if topic == '/joint_states'
                                    else 'truth_friction')
        assert this_pass[-1] == ((k + 1) * one_pass_ns, PASS_END)
    assert items[-1] == (2 * one_pass_ns, items[0][1])    # the third pass starts over
    assert source.describe() == [('bag', str(path)), ('topic', '/joint_states'),
                                 ('rate_factor', 1.0)]


def test_replay_source_without_truth_and_from_an_offset() -> None:
    source = ReplaySource(str(HEALTHY), motor_joint='motor', load_joint='load',
                          start_offset=119.0, replay_truth=False, rate_factor=4.0)
    items = list(source.items())
    assert source.speed == 4.0 and source.dropped == {}
    assert items[-1] == (100 * 10**7, PASS_END)                  # one pass, not looping
    recorded = [item for _, item in items[:-1]]
    assert [item.channel for item in recorded if isinstance(item, Recorded)] == \
        ['joints'] * 100
    assert [elapsed for elapsed, _ in items[:-1]] == [k * 10**7 for k in range(100)]


@pytest.mark.parametrize('kwargs, message', [
    ({'bag_path': ''}, '^parameter bag_path is empty'),
    ({'start_offset': 500.0}, 'start_offset 500 s is beyond the end of bag'),
    ({'motor_joint': 'rotor'}, r"joints 'rotor' and 'load' .* names are \['motor', 'load'\] "
                               r'\(missing_joint\)'),
    ({'topic': '/encoders'}, "no topic '/encoders'"),
])
def test_replay_source_refuses_with_one_line(kwargs: dict[str, object], message: str) -> None:
    arguments: dict = {'bag_path': str(HEALTHY), 'motor_joint': 'motor', 'load_joint': 'load'}
    arguments.update(kwargs)
    with pytest.raises(SourceError, match=message) as raised:
        ReplaySource(arguments.pop('bag_path'), **arguments)
    assert '\n' not in str(raised.value)


def test_read_ahead_keeps_order_raises_in_place_and_stops_its_thread() -> None:
    assert list(read_ahead(iter(range(1000)), batches=2)) == list(range(1000))

    def failing():
        yield from range(300)
        raise ValueError('the gearbox jams')

    got: list[int] = []
    with pytest.raises(ValueError, match='the gearbox jams'):
        for value in read_ahead(failing()):
            got.append(value)
    assert got == list(range(300))                  # every item before the error

    closed = []

    def endless():
        try:
            yield from itertools.count()
        finally:
            closed.append(True)

    reader = read_ahead(endless(), batches=2)
    assert list(itertools.islice(reader, 10)) == list(range(10))
    reader.close()
    assert closed == [True]                         # the source was closed by its reader
    assert not [t for t in threading.enumerate() if t.name == 'source-read-ahead']


def test_replay_median_period_from_counts_equals_numpy_median() -> None:
    """The replay check counts periods instead of keeping every log time: same median."""
    rng = np.random.default_rng(11)
    for size in (1, 2, 3, 10, 11, 1000, 1001):
        values = rng.integers(9_990_000, 10_010_000, size=size) // 1000 * 1000
        values[::5] = 10**7
        counts: dict[int, int] = {}
        for value in values.tolist():
            counts[value] = counts.get(value, 0) + 1
        assert replay_module._median(counts) == int(np.median(values)), size
    assert replay_module._median({}) == 0
    assert replay_module._median({3: 1, 4: 1}) == 3        # 3.5, truncated as int() does
