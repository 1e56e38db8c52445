"""``gear-phm simulate`` and the sample bags: determinism, readability, true parameters."""
from __future__ import annotations

import hashlib
import os
from pathlib import Path
import subprocess
import sys

from mcap.reader import make_reader
import numpy as np
import pytest
import yaml

from gear_phm.bagio import BagReader, Rosbag2McapWriter, TYPESTORE
from gear_phm.cli.main import main as gear_phm
from gear_phm.codec import decode_joint_states, joint_state_rows
from gear_phm.interfaces import stamp_to_ns, Vector3Out
from gear_phm.models import eta_opposing, u_from_eta_opposing
from gear_phm.simulation import (DutyCycle, recording, sample_times, simulate, SimulationConfig,
                                 Wear)
from helpers.bags import (ALL_SAMPLES_MAX_BYTES, bag_content, bag_differences, SAMPLE_MAX_BYTES,
                          SAMPLES)

REPO = Path(__file__).resolve().parents[2]
BAGS = REPO / 'bags'
GEAR_PHM = Path(sys.executable).parent / 'gear-phm'
TOPICS = {'/joint_states': 'sensor_msgs/msg/JointState',
          '/gear_phm/truth/friction': 'geometry_msgs/msg/Vector3Stamped',
          '/gear_phm/truth/efficiency': 'geometry_msgs/msg/Vector3Stamped'}

ARGS = ['--duration', '12', '--rate', '50', '--seed', '9', '--wear', 'linear',
        '--friction-initial', '0.05', '--friction-final', '0.25']


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def simulate_cli(out: Path, *args: str) -> int:
    return gear_phm(['simulate', '--out', str(out), *args])


@pytest.fixture(scope='module')
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp('cli') / 'run'
    assert simulate_cli(out, *ARGS) == 0
    return out


def test_byte_for_byte_deterministic(bag: Path, tmp_path: Path) -> None:
    assert simulate_cli(tmp_path / 'run', *ARGS) == 0      # same directory name, other place
    for name in ('metadata.yaml', 'run_0.mcap'):
        assert sha256(tmp_path / 'run' / name) == sha256(bag / name)
    assert simulate_cli(tmp_path / 'other', *ARGS[:-6], '--seed', '10', *ARGS[6:]) == 0
    assert sha256(tmp_path / 'other' / 'other_0.mcap') != sha256(bag / 'run_0.mcap')


def test_rosbags_reads_the_simulation_exactly(bag: Path) -> None:
    config = SimulationConfig(wear=Wear.reaching('linear', 0.05, 0.25, 12.0), seed=9)
    t = np.arange(600) * 20_000_000 * 1e-9        # the CLI's integer-nanosecond stamps
    np.testing.assert_allclose(t, sample_times(12.0, 50.0), rtol=0, atol=1e-12)
    expected = simulate(config, t)
    with BagReader(bag) as reader:
        assert reader.topics == TOPICS
        joints = list(reader.messages(['/joint_states']))
        truth = list(reader.messages(['/gear_phm/truth/friction']))
        efficiency = list(reader.messages(['/gear_phm/truth/efficiency']))
    assert len(joints) == len(truth) == len(efficiency) == 600
    stamps = np.array([stamp_to_ns(m.header.stamp) for _, _, m in joints])
    np.testing.assert_array_equal(stamps, np.arange(600) * 20_000_000)
    np.testing.assert_array_equal([t for _, t, _ in joints], stamps)   # log time = stamp
    assert all(list(m.name) == ['motor', 'load'] for _, _, m in joints)
    effort = np.array([m.effort for _, _, m in joints])
    velocity = np.array([m.velocity for _, _, m in joints])
    position = np.array([m.position for _, _, m in joints])
    np.testing.assert_array_equal(effort[:, 0], expected.effort_motor)
    np.testing.assert_array_equal(effort[:, 1], expected.effort_load)
    np.testing.assert_array_equal(velocity[:, 1], expected.velocity_load)
    np.testing.assert_array_equal(position[:, 0], expected.position_motor)
    np.testing.assert_array_equal([m.vector.x for _, _, m in truth], expected.u)
    np.testing.assert_array_equal([m.vector.y for _, _, m in truth], expected.friction)
    np.testing.assert_array_equal([m.vector.x for _, _, m in efficiency],
                                  expected.eta_opposing)
    np.testing.assert_array_equal([m.vector.y for _, _, m in efficiency],
                                  expected.eta_aiding)
    assert all(m.vector.z == 0.0 for _, _, m in efficiency)


def test_mcap_reader_reads_it(bag: Path) -> None:
    with open(bag / 'run_0.mcap', 'rb') as stream:
        reader = make_reader(stream)
        assert reader.get_header().profile == 'ros2'
        summary = reader.get_summary()
        assert summary.statistics.message_count == 1800
        assert {c.topic: c.message_encoding for c in summary.channels.values()} == \
            dict.fromkeys(TOPICS, 'cdr')
        assert {s.name: s.encoding for s in summary.schemas.values()} == \
            dict.fromkeys(set(TOPICS.values()), 'ros2msg')
        count, last = 0, -1
        for schema, channel, message in reader.iter_messages(topics=['/joint_states']):
            msg = TYPESTORE.deserialize_cdr(message.data, schema.name)
            assert stamp_to_ns(msg.header.stamp) == message.log_time > last
            last = message.log_time
            count += 1
        assert count == 600
        compressions = {c.compression for c in summary.chunk_indexes}
        assert compressions == {'zstd'}


def test_metadata_is_rosbag2_version_9(bag: Path) -> None:
    """Structural check of metadata.yaml against rosbag2 Jazzy (ros2 bag is not installed)."""
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['version'] == 9
    assert info['storage_identifier'] == 'mcap'
    assert info['relative_file_paths'] == ['run_0.mcap']
    assert info['message_count'] == 1800
    assert info['starting_time']['nanoseconds_since_epoch'] == 0
    assert info['duration']['nanoseconds'] == 599 * 20_000_000
    assert info['files'][0]['path'] == 'run_0.mcap'
    assert info['files'][0]['message_count'] == 1800
    assert info['compression_format'] == '' and info['compression_mode'] == ''
    topics = {t['topic_metadata']['name']: t for t in info['topics_with_message_count']}
    assert set(topics) == set(TOPICS)
    for name, entry in topics.items():
        meta = entry['topic_metadata']
        assert meta['type'] == TOPICS[name]
        assert meta['serialization_format'] == 'cdr'
        assert meta['type_description_hash'] == TYPESTORE.hash_rihs01(TOPICS[name])
        assert entry['message_count'] == 600


def test_truth_every_and_joint_names(tmp_path: Path) -> None:
    out = tmp_path / 'sparse'
    assert simulate_cli(out, '--duration', '2', '--rate', '100', '--truth-every', '10',
                        '--motor-joint', 'm', '--load-joint', 'l', '--start-time', '5') == 0
    with BagReader(out) as reader:
        assert reader.message_count('/joint_states') == 200
        assert reader.message_count('/gear_phm/truth/friction') == 20
        first = next(reader.messages(['/joint_states']))[2]
        assert list(first.name) == ['m', 'l']
        assert stamp_to_ns(first.header.stamp) == 5_000_000_000


@pytest.mark.parametrize('args, expected', [
    (['--rate', '-1'], '--rate must be > 0'),
    (['--duration', '0'], '--duration must be > 0'),
    (['--ratio', '0'], 'ratio must be in [1e-06, 1e+06]'),
    (['--friction-final', '0.3'], '--friction-final needs --wear linear, exponential or power'),
    (['--wear', 'linear', '--wear-rate', '1.0', '--duration', '10'], 'gearbox jams'),
    (['--plant', 'hypoid'], 'plant must be one of lever, spur, gear_train, planetary, worm'),
    (['--noise-effort-load', '-0.1'], 'noise_effort_load must be in [0, 1e+09] N m'),
])
def test_cli_errors_one_line_exit_2(tmp_path: Path, args: list[str], expected: str,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    assert gear_phm(['simulate', '--out', str(tmp_path / 'x'), *args]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith('gear-phm simulate: error:') and expected in lines[0], lines
    assert not (tmp_path / 'x').exists()


def test_cli_error_as_a_process_has_no_traceback(tmp_path: Path) -> None:
    done = subprocess.run([str(GEAR_PHM), 'simulate', '--out', str(tmp_path / 'x'),
                           '--rate', '-1'], capture_output=True, text=True, timeout=60,
                          env=os.environ.copy())
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        'gear-phm simulate: error: --rate must be > 0 Hz, got -1.0']


LIMIT = 'must end before 2147483648 s since the epoch (the int32 seconds of a ROS stamp'


@pytest.mark.filterwarnings('error')            # no RuntimeWarning line before the error
@pytest.mark.parametrize('args, expected', [
    (['--duration', '1e308'], f'--start-time + --duration {LIMIT}'),
    (['--start-time', '2147483600', '--duration', '100'], f'--start-time + --duration {LIMIT}'),
    (['--rate', '1e308'], '--rate must be <= 1e+09 Hz (stamps are integer nanoseconds)'),
    (['--start-time', '1e308'], '--start-time must be >= 0 and < 2147483648 s'),
    (['--start-time', '1e10'], '--start-time must be >= 0 and < 2147483648 s'),
    (['--fleet', '1', '--recordings', '2', '--gap', '1e308'],
     f'--start-time + --recordings x --duration + the gaps {LIMIT}'),
    (['--fleet', '2', '--recordings', '2', '--duration', '1', '--gap-spread', '1e6'],
     f'unit 0: --start-time + --recordings x --duration + the gaps {LIMIT}'),
    (['--travel', '1e308'], 'travel must be in [1e-09, 10000] rad, got 1e+308'),
    (['--load-inertia', '1e308'], 'load_inertia must be in [0, 1e+06] kg m^2'),
    (['--air-load-stiffness=-1e308'], 'air_load_stiffness must be in [-1e+09, 1e+09] N m/rad'),
    (['--extend-time', '1e308'], 'extend_time must be in [1e-06, 1e+06] s'),
    (['--bias-effort-load', '1e308'], 'bias_effort_load must be in [-1e+09, 1e+09] N m'),
    (['--wear', 'exponential', '--wear-rate', '10'],
     'the wear law gives a friction value of inf at --duration 120 s'),
    (['--duration', '1e-9'], 'gives no sample (duration x rate < 1): a bag needs at least one'),
    (['--rate', '1e-300'], 'gives no sample (duration x rate < 1)'),
    (['--fleet', '0', '--recordings', '3'], '--recordings: for a fleet only (add --fleet N'),
    (['--gap', '5', '--unit-spread', '0.1'], '--gap, --unit-spread: for a fleet only'),
    (['--fleet', '-1'], '--fleet and --recordings must be >= 1, got -1 and 1'),
    (['--fleet', '2', '--duration', '1', '--unit-spread', '1e6'],
     'unit 0: --unit-spread 1e+06 drew an unusable wear'),
])
def test_out_of_range_runs_are_refused_on_one_line(
        tmp_path: Path, args: list[str], expected: str,
        capsys: pytest.CaptureFixture[str]) -> None:
    """No OverflowError, no bag of NaN or of no sample, no ignored option, no warning line."""
    assert gear_phm(['simulate', '--out', str(tmp_path / 'x'), *args]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith('gear-phm simulate: error:') and expected in lines[0], lines
    assert list(tmp_path.iterdir()) == []


def test_a_run_ending_just_before_the_stamp_limit_is_written(tmp_path: Path) -> None:
    assert simulate_cli(tmp_path / 'x', '--start-time', '2147483546', '--duration', '100',
                        '--rate', '1') == 0
    with BagReader(tmp_path / 'x') as reader:
        stamps = [stamp_to_ns(m.header.stamp) for _, _, m in reader.messages(['/joint_states'])]
    assert len(stamps) == 100 and stamps[-1] == 2147483645 * 10**9


def test_a_non_finite_sample_is_never_written(tmp_path: Path) -> None:
    """The final guard: a configuration beyond float64 (built without the CLI's ranges)."""
    config = SimulationConfig(duty_cycle=DutyCycle(travel=1e308))
    with pytest.raises(ValueError, match=r'^the simulation gave position_motor = inf at t = '):
        recording.write_simulation(tmp_path / 'x', config, 10.0, 10.0)


def test_integer_options_take_an_integral_float(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """``--seed 1e1`` as 10, as the help prints ranges (e.g. [100, 1e+06]); 1.5 is refused."""
    assert simulate_cli(tmp_path / 'a' / 'x', *ARGS[:4], '--seed', '1e1') == 0
    assert simulate_cli(tmp_path / 'b' / 'x', *ARGS[:4], '--seed', '10') == 0
    assert bag_content(tmp_path / 'a' / 'x') == bag_content(tmp_path / 'b' / 'x')
    capsys.readouterr()
    with pytest.raises(SystemExit) as exit_info:
        simulate_cli(tmp_path / 'c', '--seed', '1.5')
    assert exit_info.value.code == 2
    assert "argument --seed: invalid integer: '1.5'" in capsys.readouterr().err


def test_refuses_a_non_empty_out_directory(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / 'keep.txt').write_text('data')
    assert simulate_cli(tmp_path) == 2
    assert 'exists and is not an empty directory' in capsys.readouterr().err
    assert (tmp_path / 'keep.txt').read_text() == 'data'


# --- sample bags --------------------------------------------------------------------------
# That bags/regenerate.sh reproduces them is checked where the README's command runs it
# (test_readme_commands.check_regenerate, with helpers.bags.regenerated_differences).

def test_sample_bags_layout_and_size() -> None:
    """Three single bags of at most 5 MiB, 3 fleet units of 5 recordings, 10 MiB in all."""
    for name in SAMPLES:
        size = sum(p.stat().st_size for p in (BAGS / name).iterdir())
        assert 0 < size <= SAMPLE_MAX_BYTES, (name, size)
    units = sorted((BAGS / 'fleet').iterdir())
    assert [unit.name for unit in units] == ['unit_00', 'unit_01', 'unit_02']
    assert [len(list(unit.glob('rec_*'))) for unit in units] == [5, 5, 5]
    total = sum(p.stat().st_size for p in BAGS.rglob('*') if p.is_file())
    assert total <= ALL_SAMPLES_MAX_BYTES, total


def test_bag_comparison_tolerates_only_last_bit_rounding(tmp_path: Path) -> None:
    """The bag comparison accepts a 1e-15 relative change of a float and nothing more."""
    def write(name: str, x: float, stamp_ns: int = 10**9, frame: str = '') -> Path:
        with Rosbag2McapWriter(tmp_path / name / 'bag', flush_period_s=None) as writer:
            writer.write_output(Vector3Out('gear_phm/truth/friction', 10**9, 0.25, 0.0, 0.0))
            writer.write_output(Vector3Out('gear_phm/truth/friction', stamp_ns, x, -1e-300,
                                           3.0, frame), t_ns=10**9)      # same log time
        return tmp_path / name / 'bag'

    reference = write('reference', 0.1 * 3)
    assert bag_differences(write('ulp', 0.3 * (1 + 1e-15)), reference) == []
    [difference] = bag_differences(write('far', 0.3 * (1 + 1e-9)), reference)
    assert difference.startswith('/gear_phm/truth/friction[1].vector.x: 0.3000000003')
    [difference] = bag_differences(write('stamp', 0.3, 10**9 + 1), reference)
    assert 'header.stamp' in difference
    assert bag_differences(write('frame', 0.3, frame='map'), reference) != []


def read_sample(name: str) -> tuple[dict, np.ndarray, np.ndarray]:
    """(joint batch columns, truth friction (n, 2), truth efficiency (n, 2))."""
    with BagReader(BAGS / name) as reader:
        raws = [raw for _, _, raw in reader.raw_messages(['/joint_states'])]
        friction = np.array([(m.vector.x, m.vector.y) for _, _, m
                             in reader.messages(['/gear_phm/truth/friction'])])
        efficiency = np.array([(m.vector.x, m.vector.y) for _, _, m
                               in reader.messages(['/gear_phm/truth/efficiency'])])
    batch = decode_joint_states(raws, 'motor', 'load')
    assert len(batch) == len(raws) and not batch.rejected_at
    return batch, friction, efficiency


def steady_energy_ratios(batch, efficiency: np.ndarray) -> list[tuple[int, float, float]]:
    """(phase 1|2, measured efficiency, mean true efficiency) per constant-speed stroke."""
    t = batch.stamp_ns * 1e-9
    _, velocity, acceleration = DutyCycle().load_motion(t)
    steady = (acceleration == 0.0) & (velocity != 0.0)
    edges = np.flatnonzero(np.diff(steady.astype(int)))
    bounds = np.r_[0, edges + 1, len(t)]
    out = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        if not steady[a]:
            continue
        assert (b - a) / 100.0 >= 1.0 - 1e-9          # each steady phase lasts >= 1 s
        e_motor = np.sum(batch.motor_effort[a:b] * batch.motor_velocity[a:b])
        e_load = np.sum(-batch.load_effort[a:b] * batch.load_velocity[a:b])
        if velocity[a] > 0:
            out.append((1, -e_load / e_motor, float(np.mean(efficiency[a:b, 0]))))
        else:
            out.append((2, -e_motor / e_load, float(np.mean(efficiency[a:b, 1]))))
    return out


def test_wearing_bag_reaches_end_of_life_and_power_ratio_tracks_truth() -> None:
    batch, friction, efficiency = read_sample('wearing')
    assert len(batch) == 30_000
    assert friction[0, 0] == pytest.approx(0.05)
    assert friction[-1, 0] == pytest.approx(0.30, rel=1e-3)
    assert np.all(np.diff(friction[:, 0]) > 0)
    assert efficiency[0, 0] == pytest.approx(eta_opposing(0.05, 3.0))
    below = np.flatnonzero(efficiency[:, 0] < 0.75)
    assert below.size and 200.0 < below[0] / 100.0 < 280.0     # end of life ~256 s
    ratios = steady_energy_ratios(batch, efficiency)
    errors = np.array([measured - true for _, measured, true in ratios])
    assert len(ratios) >= 100
    assert np.max(np.abs(errors)) < 0.01
    assert abs(np.mean(errors)) < 0.001
    # u recovered from the measured eta_D follows the truth
    first = [m for p, m, _ in ratios if p == 1][:3]
    last = [m for p, m, _ in ratios if p == 1][-3:]
    assert np.mean(u_from_eta_opposing(np.array(first), 3.0)) == pytest.approx(0.05, abs=0.01)
    assert np.mean(u_from_eta_opposing(np.array(last), 3.0)) == pytest.approx(0.29, abs=0.02)


def test_fault_and_healthy_bags() -> None:
    batch, friction, _ = read_sample('fault')
    t = batch.stamp_ns * 1e-9
    np.testing.assert_allclose(friction[t < 60.0, 0], 0.05)
    np.testing.assert_allclose(friction[t >= 60.0, 0], 0.20)
    batch, friction, efficiency = read_sample('healthy')
    np.testing.assert_allclose(friction[:, 0], 0.05)
    ratios = steady_energy_ratios(batch, efficiency)
    assert max(abs(m - e) for _, m, e in ratios) < 0.01


def test_power_law_wear_from_the_command_line(tmp_path: Path) -> None:
    """--wear power --wear-exponent 3: u = 0.05 + rate t^3, slow at first, then faster."""
    from gear_phm.bagio.series import read_vector_topic
    from gear_phm.interfaces import TRUTH_FRICTION
    out = tmp_path / 'power'
    assert simulate_cli(out, '--duration', '20', '--rate', '20', '--wear', 'power',
                        '--wear-exponent', '3', '--friction-initial', '0.05',
                        '--friction-final', '0.25') == 0
    times, values = read_vector_topic(out, TRUTH_FRICTION)
    t = times - times[0]
    np.testing.assert_allclose(values[:, 0], 0.05 + 0.2 * (t / 20.0) ** 3, rtol=1e-9)
    assert values[np.searchsorted(t, 10.0), 0] == pytest.approx(0.05 + 0.2 / 8.0)


# --- block writes against the message-by-message reference -------------------------------

def _time(stamp_ns: int) -> object:
    time = TYPESTORE.types['builtin_interfaces/msg/Time']
    return time(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)


@pytest.mark.parametrize('names, frame_id', [(['motor', 'load'], ''), (['a'], 'base_link'),
                                             (['motor_x', 'l', 'third'], 'ab')])
def test_joint_state_rows_equal_rosbags_serializer(names: list[str], frame_id: str) -> None:
    rng = np.random.default_rng(4)
    stamps = np.sort(rng.integers(0, 2**31 * 10**9, 30))
    columns = [rng.normal(size=(30, len(names))) for _ in range(3)]
    rows = joint_state_rows(stamps, names, *columns, frame_id=frame_id)
    joint_state = TYPESTORE.types['sensor_msgs/msg/JointState']
    header = TYPESTORE.types['std_msgs/msg/Header']
    for i in range(30):
        message = joint_state(header=header(stamp=_time(int(stamps[i])), frame_id=frame_id),
                              name=names, position=columns[0][i], velocity=columns[1][i],
                              effort=columns[2][i])
        assert rows[i].tobytes() == bytes(TYPESTORE.serialize_cdr(message, TOPICS[
            '/joint_states']))
    with pytest.raises(ValueError, match='int32'):
        joint_state_rows(np.array([2**31 * 10**9]), names, *(c[:1] for c in columns))


def _reference_simulation(out: Path, config: SimulationConfig, count: int, rate: float,
                          start_ns: int, truth_every: int) -> None:
    """Write with the message-by-message path ``simulate`` had before block writes.

    Rosbags message objects, rosbags' CDR serializer and mcap's Writer, one record at a time.
    """
    types = TYPESTORE.types
    result = simulate(config, np.round(np.arange(count) * (1e9 / rate)) * 1e-9)
    with Rosbag2McapWriter(out, flush_period_s=None) as writer:
        for topic, msgtype in TOPICS.items():
            writer.add_topic(topic, msgtype)
        for i in range(count):
            t_ns = start_ns + int(round(i * (1e9 / rate)))
            header = types['std_msgs/msg/Header'](stamp=_time(t_ns), frame_id='')
            writer.write('/joint_states', t_ns, types[TOPICS['/joint_states']](
                header=header, name=['motor', 'load'],
                position=np.array([result.position_motor[i], result.position_load[i]]),
                velocity=np.array([result.velocity_motor[i], result.velocity_load[i]]),
                effort=np.array([result.effort_motor[i], result.effort_load[i]])))
            if i % truth_every == 0:
                for topic, x, y in (('/gear_phm/truth/friction', result.u, result.friction),
                                    ('/gear_phm/truth/efficiency', result.eta_opposing,
                                     result.eta_aiding)):
                    writer.write(topic, t_ns, types[TOPICS[topic]](
                        header=header, vector=types['geometry_msgs/msg/Vector3'](
                            x=float(x[i]), y=float(y[i]), z=0.0)))


@pytest.mark.parametrize('truth_every, chunk', [(1, 20_000), (1, 997), (3, 997), (7, 1000),
                                                (2000, 997)])
def test_block_writes_equal_the_message_by_message_writer(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, truth_every: int, chunk: int) -> None:
    """The block-written bag equals the reference in every message and chunk.

    Payload bytes, times, sequences, chunk boundaries and statistics, across simulation
    chunks that split truth periods and MCAP chunks that split groups of messages.
    """
    config = SimulationConfig(wear=Wear.reaching('exponential', 0.05, 0.3, 8.0), seed=3)
    monkeypatch.setattr(recording, 'CHUNK', chunk)
    count = recording.write_simulation(tmp_path / 'blocks', config, 8.0, 1000.0,
                                       start_time=12.5, truth_every=truth_every)
    _reference_simulation(tmp_path / 'reference', config, count, 1000.0, 12_500_000_000,
                          truth_every)
    blocks, reference = bag_content(tmp_path / 'blocks'), bag_content(tmp_path / 'reference')
    assert len(blocks[0]['chunks']) >= 2 and count == 8000
    assert len(blocks[1]['/gear_phm/truth/friction']) == -(-count // truth_every)
    assert blocks[0]['files'] == ['blocks_0.mcap', 'metadata.yaml']
    blocks[0]['files'] = reference[0]['files']
    meta = blocks[0]['metadata']['rosbag2_bagfile_information']
    meta['files'][0]['path'] = meta['relative_file_paths'][0] = 'reference_0.mcap'
    assert blocks == reference


def test_a_run_needs_one_sample_at_least() -> None:
    from gear_phm.cli.main import CliError
    from gear_phm.cli.simulate import _check_count
    _check_count(1.0, 1.0, '--duration 1 s')                # exactly one sample
    _check_count(0.1, 10.0, '--duration 0.1 s')             # 1 up to rounding
    with pytest.raises(CliError, match=r'^--duration 0\.5 s at --rate 1 Hz gives no sample'):
        _check_count(0.5, 1.0, '--duration 0.5 s')
