"""The vectorised MCAP writer of ``gear-phm analyze`` against mcap's own Writer.

The same calls give byte-identical files; through Rosbag2McapWriter both give the same
messages to mcap's reader, rosbags and the package's reader; analyze's columns equal the
records the nodes publish.
"""
from __future__ import annotations

import io
import math
from pathlib import Path

from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer
import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import get_typestore, Stores

from gear_phm import interfaces
from gear_phm.bagio import BagReader, Rosbag2McapWriter
from gear_phm.bagio.batch_writer import BatchWriter, vector3_stamped_rows
from gear_phm.bagio.writer import vector3_stamped_cdr
from gear_phm.estimation import FrictionEstimate
from gear_phm.interfaces import (DiagnosticsOut, estimate_outputs, health_outputs, StatusOut,
                                 Vector3Out)
from gear_phm.offline.drive import estimate_columns
from gear_phm.offline.records import EstimateHistory
from gear_phm.prognostics import RulEstimate, Trend
from gear_phm.prognostics.assessor import HealthState


@pytest.mark.parametrize('frame_id', ['', 'a', 'flap_drive_left_outboard'])
def test_rows_equal_the_scalar_packer(frame_id: str) -> None:
    rng = np.random.default_rng(3)
    stamps = np.sort(rng.integers(-10**12, 10**13, 40))
    xyz = rng.normal(size=(40, 3))
    xyz[0] = (math.inf, -math.inf, math.nan)
    rows = vector3_stamped_rows(stamps, xyz, frame_id)
    for i in range(40):
        expected = vector3_stamped_cdr(Vector3Out('t', int(stamps[i]), *xyz[i], frame_id))
        assert rows[i].tobytes() == expected


def test_rows_refuse_a_stamp_beyond_int32_seconds() -> None:
    with pytest.raises(ValueError, match='int32'):
        vector3_stamped_rows(np.array([2**31 * 10**9]), np.zeros((1, 3)))


def _calls(writer, rng: np.random.Generator) -> None:
    """Make the same sequence of calls on either writer.

    Schemas and channels between messages, blocks across chunk boundaries, single messages of
    other sizes.
    """
    writer.start(profile='ros2', library='test')
    schema = writer.register_schema('geometry_msgs/msg/Vector3Stamped', 'ros2msg', b'x y z')
    a = writer.register_channel('/a', 'cdr', schema, {'k': 'v'})
    b = writer.register_channel('/b', 'cdr', schema)
    t = 10**9
    for block in range(30):
        n = int(rng.integers(1, 60))
        times = t + np.sort(rng.integers(0, 10**8, n))
        channels = rng.choice([a, b], n)
        payloads = rng.integers(0, 256, (n, 24), dtype=np.uint8)
        sequences = np.arange(n) + 7 * block
        if isinstance(writer, BatchWriter):
            writer.add_block(channels, times, payloads, times + 5, sequences)
        else:
            for i in range(n):
                writer.add_message(int(channels[i]), int(times[i]), payloads[i].tobytes(),
                                   int(times[i]) + 5, int(sequences[i]))
        writer.add_message(a, int(times[-1]), b'diag' * int(rng.integers(1, 9)), int(times[-1]),
                           block)
        if block == 10:
            c = writer.register_channel('/c', 'cdr', schema)
            writer.add_message(c, int(times[-1]), b'late channel', int(times[-1]), 0)
        if block == 20:
            writer.flush()
        t += 10**8
    writer.finish()


@pytest.mark.parametrize('compression', [CompressionType.ZSTD, CompressionType.LZ4,
                                         CompressionType.NONE])
def test_byte_identical_to_mcaps_writer(compression: CompressionType) -> None:
    ours, theirs = io.BytesIO(), io.BytesIO()
    _calls(BatchWriter(ours, chunk_size=3000, compression=compression),
           np.random.default_rng(11))
    _calls(Writer(theirs, chunk_size=3000, compression=compression, enable_data_crcs=True),
           np.random.default_rng(11))
    assert len(ours.getvalue()) > 10_000
    assert ours.getvalue() == theirs.getvalue()


def test_negative_log_time_is_refused() -> None:
    writer = BatchWriter(io.BytesIO())
    writer.start()
    with pytest.raises(ValueError, match='unsigned'):
        writer.add_block(np.array([1]), np.array([-1]), np.zeros((1, 4), dtype=np.uint8))


def _bag(directory: Path, batch: bool) -> Path:
    rng = np.random.default_rng(5)
    stamps = 10**12 + np.cumsum(rng.integers(1, 10**7, 3000))
    with Rosbag2McapWriter(directory, batch=batch, chunk_size=20_000,
                           flush_period_s=None) as writer:
        for part in np.array_split(np.arange(3000), 7):
            s, xyz = stamps[part], rng.normal(size=(part.size, 3))
            middle = int(s[s.size // 2])              # a status inside the block (analyze)
            writer.write_vector3_columns([('gear_phm/friction', s, xyz),
                                          ('gear_phm/counts', s, xyz * 2),
                                          ('gear_phm/health/rul', s[::4], xyz[::4])],
                                         between=[(middle, DiagnosticsOut(middle, (StatusOut(
                                             0, 'gear_phm: flap', 'mid', 'rig', ()),)))])
            writer.write_output(DiagnosticsOut(int(s[-1]), (StatusOut(
                0, 'gear_phm: flap', 'ok', 'rig', (('u', '0.1'),)),)))
    return directory


def test_rosbag2_writer_batch_and_library_give_the_same_messages(tmp_path: Path) -> None:
    bags = {batch: _bag(tmp_path / f'bag_{batch}', batch) for batch in (False, True)}
    seen = {}
    for batch, bag in bags.items():
        with open(next(bag.glob('*.mcap')), 'rb') as stream:
            reader = make_reader(stream)
            messages = [(c.topic, m.log_time, m.publish_time, m.sequence, m.data)
                        for _, c, m in reader.iter_messages()]
            statistics = reader.get_summary().statistics
        with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
            rosbags = [(c.topic, t, raw) for c, t, raw in reader.messages()]
        with BagReader(bag) as reader:
            ours = sum(len(batch_) for batch_ in reader.raw_batches(
                ['/gear_phm/friction', '/gear_phm/counts', '/gear_phm/health/rul',
                 '/diagnostics'], batch_size=500))
        seen[batch] = (messages, statistics, rosbags, ours)
        assert len(messages) == 3000 * 2 + sum(
            len(p[::4]) for p in np.array_split(np.arange(3000), 7)) + 2 * 7
        assert ours == len(messages) == len(rosbags)
        times = [m[1] for m in messages]
        assert times == sorted(times)           # each mid-block status among its neighbours
        middles = [i for i, m in enumerate(messages) if m[0] == '/diagnostics'][::2]
        assert all(messages[i - 1][1] == messages[i][1] < messages[i + 1][1] for i in middles)
    assert seen[True][0] == seen[False][0]
    assert seen[True][1] == seen[False][1]
    assert seen[True][2] == seen[False][2]


def test_analyze_columns_are_the_published_records() -> None:
    estimates = [FrictionEstimate(10**9 * (k + 1), 0.1 + k, 1e-5, (1e-4, 2e-7, 3e-9), 0.9 - k,
                                  0.8, 0.85, 0.01 * k, 0.02, 0.5, 100 + k, k, 1 + k % 2,
                                  operating_time=12.5 * k,
                                  measurement=math.nan if k == 1 else 0.1 + 1.01 * k,
                                  measurement_variance=math.nan if k == 1 else 1e-6 * (k + 1))
                 for k in range(4)]
    states = [HealthState(e.stamp_ns, k % 3, 'x', e.u, 0.01, e.eta_opposing, e.eta_aiding,
                          RulEstimate(100.0 - k, 50.0, math.inf, 'linear'), e.power_flow, 1, 0,
                          0.6, Trend())
              for k, e in enumerate(estimates) if k != 2]

    def columns_of(estimates: list[FrictionEstimate], states: list[HealthState]) -> list:
        """Return the columns analyze writes: the estimator's half, then the assessor's."""
        return (estimate_columns(estimates, EstimateHistory.of(estimates))
                + interfaces.vector3_columns(states, interfaces.HEALTH_LAYOUT))
    columns = columns_of(estimates, states)
    got = [Vector3Out(topic, int(s), *xyz) for topic, stamps, xyzs in columns
           for s, xyz in zip(stamps, xyzs.tolist())]
    expected = [r for e in estimates for r in estimate_outputs(e)] + \
        [r for s in states for r in health_outputs(s)]
    key = (lambda r: (r.topic, r.stamp_ns))
    # repr: NaN (no measurement at k = 1) equals itself
    got_text = [repr(r) for r in sorted(got, key=key)]
    assert got_text == [repr(r) for r in sorted(expected, key=key)]
    assert {r.topic for r in got} == {*interfaces.ESTIMATOR_TOPICS, interfaces.HEALTH_RUL,
                                      interfaces.HEALTH_EFFICIENCY}
    assert [r.x for r in got if r.topic == interfaces.OPERATING_TIME] == [0.0, 12.5, 25.0, 37.5]
    # a part of the batch (as the writing by parts slices the batch's columns): the columns
    # of that part's estimates and states alone
    part = columns_of(estimates[:2], states[:2])
    assert [topic for topic, _, _ in part] == [topic for topic, _, _ in columns]
    for (topic, stamps, xyz), (_, stamps_p, xyz_p) in zip(columns, part):
        assert stamps_p.tolist() == stamps[:2].tolist()
        np.testing.assert_array_equal(xyz_p, xyz[:2])   # NaN where NaN, else bit-equal


def _groups_bag(directory: Path, batch: bool) -> list[tuple[str, int, int, int, bytes]]:
    """Write groups across small chunks: a topic in two parts, a part of 3 messages a group.

    Returns (topic, log time, sequence, chunk count, payload) per message, in file order.
    """
    rng = np.random.default_rng(2)
    with Rosbag2McapWriter(directory, batch=batch, flush_period_s=None,
                           chunk_size=5000) as writer:
        for topic in ('a', 'b'):
            writer.add_topic(topic, 'geometry_msgs/msg/Vector3Stamped')
        for block in range(5):
            stamps = 10**9 + block * 10**6 + np.arange(37)
            writer.write_groups([
                ('a', stamps, rng.integers(0, 256, (37, 48), dtype=np.uint8)),
                ('b', np.repeat(stamps[:, None], 3, axis=1),
                 rng.integers(0, 256, (37, 3, 40), dtype=np.uint8)),
                ('a', stamps, rng.integers(0, 256, (37, 48), dtype=np.uint8))])
    with open(next(directory.glob('*.mcap')), 'rb') as stream:
        reader = make_reader(stream)
        starts = [i.message_start_time for i in reader.get_summary().chunk_indexes]
        return [(c.topic, m.log_time, m.sequence, len(starts), m.data)
                for _, c, m in reader.iter_messages(log_time_order=False)]


def test_write_groups_batch_equals_message_by_message(tmp_path: Path) -> None:
    batched, single = (_groups_bag(tmp_path / f'bag_{b}', b) for b in (True, False))
    assert batched == single and len(batched) == 5 * 37 * 5
    assert [m[2] for m in batched[:6]] == [0, 0, 1, 2, 1, 2]      # a, b b b, a, a ...
    assert batched[0][3] >= 10                                    # many chunks
