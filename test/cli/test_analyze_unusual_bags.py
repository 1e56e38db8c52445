"""Bags a user brings: unset header stamps (--stamp-source log), missing arrays, other joints.

A publisher that leaves ``header.stamp`` at 0 gave, before, an analysis with exit 0 and the
filter's initial state (u 0.05 +/- 0.5): every sample after the first was a duplicate stamp.
"""
from __future__ import annotations

import json
from pathlib import Path
import re

import numpy as np
import pytest

from gear_phm.cli.main import main
from gear_phm.estimation import EstimatorConfig, EstimatorPipeline
from gear_phm.estimation.summary import EstimatorSummary

HEALTHY = Path(__file__).resolve().parents[2] / 'bags' / 'healthy'
MESSAGES = 3000                 # 30 s of bags/healthy (100 Hz): a few dozen filter updates


def _variant(out: Path, change: str) -> Path:
    """Write the first MESSAGES JointStates of bags/healthy, changed, as an MCAP rosbag2."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import get_typestore, Stores
    store = get_typestore(Stores.ROS2_JAZZY)
    joint_state = store.types['sensor_msgs/msg/JointState']
    with AnyReader([HEALTHY], default_typestore=store) as reader, \
            Writer(out, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        [connection] = [c for c in reader.connections if c.topic == '/joint_states']
        target = writer.add_connection('/joint_states', joint_state.__msgtype__,
                                       typestore=store)
        for count, (_, log_ns, raw) in enumerate(reader.messages([connection])):
            if count == MESSAGES:
                break
            msg = reader.deserialize(raw, connection.msgtype)
            if change == 'zero stamps':
                msg.header.stamp.sec, msg.header.stamp.nanosec = 0, 0
            elif change == 'no effort':
                msg.effort = np.zeros(0)
            elif change == 'effort nan':                    # a torque sensor that fails
                msg.effort = np.full(msg.effort.size, np.nan)
            elif change == 'huge speed every 50th' and count % 50 == 0:
                msg.velocity = np.full(msg.velocity.size, 1e300)
            elif change == 'negative stamps':               # a clock before 1970
                msg.header.stamp.sec -= 1000
            elif change == 'motor torque in mN m':
                msg.effort = msg.effort * np.array([1000.0, 1.0])
            elif change.endswith('torque reversed'):        # a sensor read the other way
                k = msg.name.index(change.split()[0])
                msg.effort = msg.effort * np.where(np.arange(msg.effort.size) == k, -1.0, 1.0)
            if change == 'every message twice':
                writer.write(target, log_ns, store.serialize_cdr(msg, joint_state.__msgtype__))
            if change == 'split joints':        # two devices: one joint per message
                for k, name in enumerate(msg.name):
                    part = joint_state(header=msg.header, name=[name],
                                       position=msg.position[k:k + 1],
                                       velocity=msg.velocity[k:k + 1],
                                       effort=msg.effort[k:k + 1])
                    writer.write(target, log_ns + k,
                                 store.serialize_cdr(part, joint_state.__msgtype__))
                continue
            writer.write(target, log_ns, store.serialize_cdr(msg, joint_state.__msgtype__))
    return out


@pytest.fixture(scope='module')
def bags(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp('stamp_source')
    return {change: _variant(root / change.replace(' ', '_'), change)
            for change in ('unchanged', 'zero stamps', 'no effort', 'split joints',
                           'load torque reversed', 'motor torque reversed',
                           'motor torque in mN m', 'every message twice', 'effort nan',
                           'huge speed every 50th', 'negative stamps')}


def _analyze(bag: Path, out: Path, *extra: str) -> int:
    return main(['analyze', str(bag), '--ratio', '3.0', '--out', str(out), '--no-plot',
                 '--no-progress', *extra])


def test_unset_header_stamps_fail_clearly_and_log_times_analyse_them(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert _analyze(bags['zero stamps'], tmp_path / 'header') == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and error[0].startswith('gear-phm analyze: error:'), error
    assert 'the header stamps do not advance' in error[0]
    assert f'{MESSAGES - 1} of {MESSAGES - 1} samples repeat the stamp' in error[0]
    assert '--stamp-source log' in error[0]
    assert not (tmp_path / 'header').exists()               # no half-written output
    assert _analyze(bags['zero stamps'], tmp_path / 'log', '--stamp-source', 'log') == 0
    assert _analyze(bags['unchanged'], tmp_path / 'unchanged') == 0
    log = json.loads((tmp_path / 'log' / 'summary.json').read_text())
    header = json.loads((tmp_path / 'unchanged' / 'summary.json').read_text())
    # the sample bags are logged at their stamps: the same estimate either way
    assert log['filter_updates'] == header['filter_updates'] > 10
    assert log['u'] == pytest.approx(header['u'], rel=1e-9)
    assert abs(log['u'] - 0.05) < 0.005                     # bags/healthy: lever u = 0.05
    with pytest.raises(SystemExit) as refused:                # argparse's own refusal
        _analyze(bags['unchanged'], tmp_path / 'bad', '--stamp-source', 'receive')
    assert refused.value.code == 2 and 'invalid choice' in capsys.readouterr().err


def test_missing_effort_is_named_in_the_error(bags: dict[str, Path], tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    assert _analyze(bags['no effort'], tmp_path / 'out') == 2
    error = capsys.readouterr().err
    assert f'{MESSAGES} messages whose velocity or effort array is too short' in error
    assert 'nonfinite' not in error                         # only the reasons that occurred
    assert not (tmp_path / 'out').exists()


def test_joints_not_found_lists_the_joints_the_messages_name(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert _analyze(bags['unchanged'], tmp_path / 'rotor', '--motor-joint', 'rotor') == 2
    error = capsys.readouterr().err
    assert f'{MESSAGES} messages without one of the joint names' in error
    assert "the first messages name the joints ['motor', 'load']" in error
    assert 'one message' not in error
    assert _analyze(bags['split joints'], tmp_path / 'split') == 2
    error = capsys.readouterr().err
    assert "name the joints ['motor'] or ['load'] (both joints must be in one message" in error
    assert not (tmp_path / 'rotor').exists() and not (tmp_path / 'split').exists()


@pytest.mark.parametrize('joint', ['load', 'motor'])
def test_a_reversed_torque_sign_is_named_and_its_parameter_mends_it(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str],
        joint: str) -> None:
    """A torque read the other way: exit 2 naming the sign to flip; flipped, the same u."""
    bag = bags[f'{joint} torque reversed']
    assert _analyze(bag, tmp_path / 'as_is') == 2
    error = capsys.readouterr().err
    assert f"the {joint} torque's sign looks reversed" in error, error
    assert f'(--param {joint}_effort_sign=-1)' in error
    assert not (tmp_path / 'as_is').exists()
    assert _analyze(bag, tmp_path / 'mended', '--param', f'{joint}_effort_sign=-1') == 0
    assert _analyze(bags['unchanged'], tmp_path / 'unchanged') == 0
    mended, unchanged = (json.loads((tmp_path / name / 'summary.json').read_text())
                         for name in ('mended', 'unchanged'))
    assert mended['u'] == pytest.approx(unchanged['u'], rel=1e-9)
    assert mended['counts'] == unchanged['counts']
    assert mended['reversed_torque'] == unchanged['reversed_torque'] == ''


def test_a_ratio_the_speeds_contradict_is_refused(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """bags/healthy is R 3: its speeds refuse 5.0 and 1/3, and take 3.05 (within 2 %)."""
    for ratio, printed in (('5.0', '5'), ('0.3333', '0.3333')):
        assert main(['analyze', str(bags['unchanged']), '--ratio', ratio, '--out',
                     str(tmp_path / ratio), '--no-plot', '--no-progress']) == 2
        error = capsys.readouterr().err
        given = re.search(r'the speeds give ratio ([0-9.]+) ', error)
        assert given and float(given.group(1)) == pytest.approx(3.0, rel=2e-3), error
        assert f'the ratio parameter is {printed}:' in error and '(--ratio)' in error, error
        assert not (tmp_path / ratio).exists()
    assert main(['analyze', str(bags['unchanged']), '--ratio', '3.05', '--out',
                 str(tmp_path / 'close'), '--no-plot', '--no-progress']) == 0
    summary = json.loads((tmp_path / 'close' / 'summary.json').read_text())
    assert summary['speed_ratio'] == pytest.approx(3.0, rel=0.002)
    assert summary['ratio_check'] == ''


def test_torques_in_different_units_are_named(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A motor torque in mN m: its windows give out more energy than they take in."""
    assert _analyze(bags['motor torque in mN m'], tmp_path / 'out') == 2
    error = capsys.readouterr().err
    assert 'of the windows give out more energy than they take in' in error, error
    assert 'are both torques in N m' in error
    assert not (tmp_path / 'out').exists()
    assert _analyze(bags['unchanged'], tmp_path / 'unchanged') == 0
    summary = json.loads((tmp_path / 'unchanged' / 'summary.json').read_text())
    assert summary['windows_over_unity'] == 0 and summary['over_unity'] == ''


def test_every_message_twice_gives_the_same_estimate_and_counts_the_copies(
        bags: dict[str, Path], tmp_path: Path) -> None:
    """A copy carries nothing: the same estimate; each copy counts as a duplicate_stamp.

    The stamp screen does not cut the stream at the copies (before 2026-11-27 each copy ended
    a segment: such a bag analysed 2.6 times slower).
    """
    from gear_phm.estimation.stamps import Segment, StampScreen
    assert _analyze(bags['every message twice'], tmp_path / 'twice') == 0
    assert _analyze(bags['unchanged'], tmp_path / 'once') == 0
    twice, once = (json.loads((tmp_path / name / 'summary.json').read_text())
                   for name in ('twice', 'once'))
    for key in ('u', 'sigma_u', 'eta_opposing', 'eta_aiding', 'operating_time_s'):
        assert twice[key] == pytest.approx(once[key], rel=1e-9), key
    assert twice['samples_used'] == once['samples_used']
    assert twice['filter_updates'] == once['filter_updates']
    assert twice['counts']['duplicate_stamp'] == once['counts']['duplicate_stamp'] + MESSAGES
    assert twice['messages'] == 2 * once['messages']
    stamps = np.repeat(np.arange(1, 1001, dtype=np.int64) * 10_000_000, 2)
    steps = StampScreen(10, 500_000_000, 5_000_000_000).screen(stamps).steps
    segments = [step for step in steps if isinstance(step, Segment)]
    assert len(segments) == 1 and segments[0].index.size == 1000
    dropped = sum(step[1] for step in steps if isinstance(step, tuple)) \
        + segments[0].drops.size
    assert dropped == 1000


def test_estimator_status_names_stamps_that_do_not_advance() -> None:
    """The live estimator's status (the same code) says why there is no measurement."""
    pipeline = EstimatorPipeline(EstimatorConfig(ratio=3.0))
    n = 500
    ones = np.ones(n)
    pipeline.on_batch(np.zeros(n, dtype=np.int64), ones, ones, ones / 3.0, ones)
    status = pipeline.status('gear_phm estimator')
    assert status.level == 1
    assert status.message.startswith('no efficiency measurement yet: the header stamps do '
                                     'not advance'), status.message
    assert EstimatorSummary.from_dict(pipeline.summary()).stalled_stamps()
    # advancing stamps: no such message, whatever the measurement state
    fresh = EstimatorPipeline(EstimatorConfig(ratio=3.0))
    fresh.on_batch(np.arange(n, dtype=np.int64) * 10_000_000 + 1, ones, ones, ones / 3.0,
                   ones)
    assert not EstimatorSummary.from_dict(fresh.summary()).stalled_stamps()
    assert 'header stamps' not in fresh.status('gear_phm estimator').message


def test_no_measurement_at_all_is_an_error_not_the_filter_prior(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Every torque NaN: the analysis gave exit 0 and u 0.05 +/- 0.5, the filter's prior."""
    assert _analyze(bags['effort nan'], tmp_path / 'out') == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    assert 'no efficiency measurement' in lines[0] and f'nonfinite {MESSAGES}' in lines[0], lines
    assert not (tmp_path / 'out').exists()


def test_overflowing_values_are_dropped_as_nonfinite(bags: dict[str, Path],
                                                     tmp_path: Path) -> None:
    """1e300 rad/s: finite, but its power and kinetic energy overflow (a traceback before)."""
    assert _analyze(bags['huge speed every 50th'], tmp_path / 'huge') == 0
    assert _analyze(bags['unchanged'], tmp_path / 'base') == 0
    huge = json.loads((tmp_path / 'huge' / 'summary.json').read_text())
    base = json.loads((tmp_path / 'base' / 'summary.json').read_text())
    assert huge['counts']['nonfinite'] == MESSAGES // 50
    assert abs(huge['u'] - base['u']) < 3.0 * base['sigma_u']


def test_negative_header_stamps_are_named_and_log_times_analyse_them(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert _analyze(bags['negative stamps'], tmp_path / 'out') == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and 'header stamps before 1970' in lines[0], lines
    assert '--stamp-source log' in lines[0]
    assert _analyze(bags['negative stamps'], tmp_path / 'out', '--stamp-source', 'log') == 0
