"""Many transmissions in one JointState stream (issue 25), through the entry points.

``gear-phm simulate --transmissions`` writes a three-drive bench bag once; ``gear-phm analyze
--transmissions`` reads it once, and each drive must equal a single-drive run on the same bag
(``--ratio`` and that drive's joints). Bad files are refused with the reason; ``gear-phm
fleet`` writes one row per (unit, drive).
"""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path
import shutil
import subprocess
import sys

import numpy as np
import pytest
import yaml

from gear_phm import interfaces
from gear_phm.bagio import BagReader
from gear_phm.bagio.writer import vector3_stamped_from_cdr
from gear_phm.cli.main import main
from gear_phm.offline import analyze_bag
from gear_phm.transmissions import load_transmissions, TransmissionsError
from helpers.shared import build_once

GEAR_PHM = Path(sys.executable).parent / 'gear-phm'

#: Three drives: different ratios, wear laws and sensors; flap_l sets its own eta_opposing_min.
DRIVES = {
    'flap_l': {'motor_joint': 'pdu_l', 'load_joint': 'flap_l_out', 'ratio': 3.0,
               'eta_opposing_min': 0.7,
               'simulation': {'wear': 'linear', 'friction_initial': 0.05, 'wear_rate': 1e-3}},
    'spoiler_3': {'motor_joint': 'spl3_motor', 'load_joint': 'spl3_out', 'ratio': 5.0,
                  'simulation': {'wear': 'linear', 'friction_initial': 0.04,
                                 'wear_rate': 5e-4}},
    'rudder': {'motor_joint': 'rud_motor', 'load_joint': 'rud_out', 'ratio': 2.0,
               'window': 0.5, 'simulation': {'wear': 'constant', 'friction_initial': 0.1,
                                             'noise_effort_load': 0.02}},
}

DURATION = 60.0

#: The transmissions file, drives in this order.
BENCH_FILE = yaml.safe_dump({'transmissions': DRIVES}, sort_keys=False)

#: The global option of the analyses: every drive but flap_l takes it.
GLOBAL_ETA_MIN = '0.6'


def _make_bench(directory: Path) -> None:
    (directory / 'bench.yaml').write_text(BENCH_FILE)
    assert main(['simulate', '--transmissions', str(directory / 'bench.yaml'), '--duration',
                 str(DURATION), '--out', str(directory / 'bag')]) == 0


@pytest.fixture(scope='module')
def bench(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Return a directory with bench.yaml and bag/, a simulated three-drive bench."""
    return build_once(tmp_path_factory, 'bench', _make_bench)


def _vectors(out: Path, topic: str) -> np.ndarray:
    """Return (stamp [ns], x, y, z) rows of a Vector3Stamped topic of an output bag."""
    with BagReader(out) as bag:
        return np.array([vector3_stamped_from_cdr(raw)
                         for _, _, raw in bag.raw_messages([topic])], dtype=float)


def test_simulated_bench_has_all_joints_in_one_stream_and_truth_per_drive(bench: Path) -> None:
    with BagReader(bench / 'bag') as bag:
        assert bag.message_count('/joint_states') == 6000              # 60 s at 100 Hz
        for drive in DRIVES:
            assert bag.message_count(f'/gear_phm/{drive}/truth/friction') == 6000
        _, _, message = next(iter(bag.messages(['/joint_states'])))
    assert list(message.name) == [j for d in DRIVES.values()
                                  for j in (d['motor_joint'], d['load_joint'])]
    truth = _vectors(bench / 'bag', '/gear_phm/flap_l/truth/friction')
    assert truth[-1, 1] == pytest.approx(0.05 + 1e-3 * (DURATION - 0.01), rel=1e-9)


def test_one_pass_equals_single_drive_runs(bench: Path, tmp_path: Path) -> None:
    """Each drive's outputs equal a single-drive run's within 1e-9 relative.

    Not to the last bit: the one pass hands the estimator batches of many chunks, a single run
    one chunk at a time (to keep today's results exactly), and the sums differ in rounding.
    """
    out = tmp_path / 'bench'
    assert main(['analyze', str(bench / 'bag'), '--transmissions', str(bench / 'bench.yaml'),
                 '--eta-opposing-min', GLOBAL_ETA_MIN, '--out', str(out),
                 '--no-progress']) == 0
    summary = json.loads((out / 'summary.json').read_text())
    assert summary['messages'] == 6000 and list(summary['transmissions']) == list(DRIVES)
    for name, drive in DRIVES.items():
        single = tmp_path / name
        eta_min = str(drive.get('eta_opposing_min', GLOBAL_ETA_MIN))
        params = [f'--param=window={drive["window"]}'] if 'window' in drive else []
        assert main(['analyze', str(bench / 'bag'), '--ratio', str(drive['ratio']),
                     '--motor-joint', str(drive['motor_joint']), '--load-joint',
                     str(drive['load_joint']), '--eta-opposing-min', eta_min, *params,
                     '--out', str(single), '--no-progress', '--no-plot']) == 0
        alone = json.loads((single / 'summary.json').read_text())
        mine = summary['transmissions'][name]
        assert set(mine) == set(alone)                                 # same keys
        for key in ('filter_updates', 'samples_used', 'samples_seen', 'config'):
            assert mine[key] == alone[key], key
        for key in ('u', 'sigma_u', 'eta_opposing', 'operating_time_s'):
            assert mine[key] == pytest.approx(alone[key], rel=1e-9, abs=0), key
        assert mine['health']['trend']['u_eol'] == alone['health']['trend']['u_eol']
        assert mine['health']['level'] == alone['health']['level']
        for topic in (interfaces.FRICTION, interfaces.HEALTH_RUL):
            ours = _vectors(out, '/' + interfaces.drive_topic(name, topic))
            theirs = _vectors(single, '/' + topic)
            assert ours.shape == theirs.shape and len(ours) > 100
            # atol for du/dt of a drive that does not wear (-2.35e-8 1/s differed by 3.5e-17,
            # 1.5e-9 relative): 1e-12 1/s is 1e-9 of u per 1000 s, far below any wear rate
            np.testing.assert_allclose(ours, theirs, rtol=1e-9, atol=1e-12)
        truth = _vectors(bench / 'bag', f'/gear_phm/{name}/truth/friction')[-1, 1]
        assert abs(mine['u'] - truth) < 0.01, (name, mine['u'], truth)
        assert (out / f'analysis_{name}.png').stat().st_size > 20000
    # flap_l's own eta_opposing_min and the global one give different ends of life
    u_eol = {n: summary['transmissions'][n]['health']['trend']['u_eol'] for n in DRIVES}
    assert u_eol['flap_l'] == pytest.approx(0.9 / 3.1)   # eta_D = 0.7 at R = 3
    assert u_eol['spoiler_3'] == pytest.approx(2.0 / 4.0)  # eta_D = 0.6 at R = 5
    with BagReader(out) as bag:
        arrays = [m for _, _, m in bag.messages(['/diagnostics'])]
    assert len(arrays) >= DURATION - 1
    names = [(s.name, s.hardware_id) for s in arrays[-1].status]
    for drive in DRIVES:
        assert names.count((f'gear_phm: {drive}', drive)) == 1
        assert sum(n == f'gear_phm estimator: {drive}' for n, _ in names) == 1


def test_api_and_node_parameters_file_give_the_same_drives(bench: Path, tmp_path: Path
                                                           ) -> None:
    """Give analyze_bag a node parameters file, or records and a global option: same drives.

    The file has flat and nested keys in two nodes; ``transmissions`` takes either.
    """
    params = {
        'estimator': {'ros__parameters': {
            'transmissions': list(DRIVES), 'rate': 1.0,
            **{f'{n}.{k}': v for n, d in DRIVES.items() for k, v in d.items()
               if k not in ('simulation', 'eta_opposing_min')}}},
        'diagnostics': {'ros__parameters': {
            'transmissions': list(DRIVES), 'eta_opposing_min': float(GLOBAL_ETA_MIN),
            'flap_l': {'eta_opposing_min': 0.7}}},
    }
    path = tmp_path / 'params.yaml'
    path.write_text(yaml.safe_dump(params, sort_keys=False))
    from_file = analyze_bag(bench / 'bag', transmissions=path, plot=False, history=None)
    drives = load_transmissions(bench / 'bench.yaml')
    from_records = analyze_bag(bench / 'bag', transmissions=drives, plot=False, history=None,
                               eta_opposing_min=float(GLOBAL_ETA_MIN))
    assert list(from_file.transmissions) == list(DRIVES)
    for name in DRIVES:
        a, b = from_file.transmissions[name], from_records.transmissions[name]
        np.testing.assert_array_equal(a.estimates.u, b.estimates.u)
        assert a.summary.health.trend == b.summary.health.trend


BAD = {
    'unknown drive key': ({'flap_l': {**DRIVES['flap_l'], 'gear_teeth': 12}},
                          "drive flap_l: unknown key(s) ['gear_teeth']"),
    'missing joint': ({'flap_l': {'motor_joint': 'pdu_l', 'ratio': 3.0}},
                      'drive flap_l: missing load_joint'),
    'duplicate joint': ({'flap_l': DRIVES['flap_l'],
                         'flap_r': {'motor_joint': 'pdu_l', 'load_joint': 'flap_r_out',
                                    'ratio': 3.0}},
                        "joint 'pdu_l' is used by flap_l and flap_r"),
    'bad ratio': ({'flap_l': {**DRIVES['flap_l'], 'ratio': 0.0}},
                  'drive flap_l: ratio must be in [1e-06, 1e+06], got 0.0'),
    'empty list': ({}, 'transmissions is empty'),
    'bad simulation key': ({'flap_l': {**DRIVES['flap_l'], 'simulation': {'wear': 'fast'}}},
                           'drive flap_l: wear must be one of'),
}


@pytest.mark.parametrize('case', list(BAD))
def test_bad_transmissions_files_are_refused_with_the_reason(
        case: str, bench: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    drives, reason = BAD[case]
    path = tmp_path / 'bad.yaml'
    path.write_text(yaml.safe_dump({'transmissions': drives}))
    out = tmp_path / 'out'
    assert main(['analyze', str(bench / 'bag'), '--transmissions', str(path), '--out',
                 str(out), '--no-progress']) == 2
    err = capsys.readouterr().err
    assert f'{path}: ' in err and reason in err, err
    assert not out.exists()
    assert main(['simulate', '--transmissions', str(path), '--duration', '1', '--out',
                 str(out)]) == 2
    assert reason in capsys.readouterr().err


def test_single_transmission_options_stay_and_do_not_mix(
        bench: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = str(tmp_path / 'out')
    bag = str(bench / 'bag')
    assert main(['analyze', bag, '--out', out]) == 2                   # neither
    assert 'give --ratio (one transmission) or --transmissions' in capsys.readouterr().err
    assert main(['analyze', bag, '--ratio', '3', '--transmissions',
                 str(bench / 'bench.yaml'), '--out', out]) == 2        # both
    assert main(['analyze', bag, '--transmissions', str(bench / 'bench.yaml'),
                 '--motor-joint', 'pdu_l', '--out', out]) == 2
    assert '--motor-joint: with --transmissions' in capsys.readouterr().err
    # the single-transmission summary keeps its layout: no transmissions key
    assert main(['analyze', bag, '--ratio', '3', '--motor-joint', 'pdu_l', '--load-joint',
                 'flap_l_out', '--out', out, '--no-plot', '--no-progress']) == 0
    summary = json.loads((Path(out) / 'summary.json').read_text())
    assert 'transmissions' not in summary and math.isfinite(summary['u'])
    with BagReader(Path(out)) as bag_out:
        assert '/gear_phm/friction' in bag_out.topics
        assert not any('flap_l' in topic for topic in bag_out.topics)


def test_fleet_writes_one_row_per_unit_and_drive(bench: Path, tmp_path: Path) -> None:
    root = tmp_path / 'fleet'
    for unit in ('unit_a', 'unit_b'):
        shutil.copytree(bench / 'bag', root / unit / 'rec_000')
    (root / 'unit_a' / 'unit.yaml').write_text(BENCH_FILE)
    (root / 'unit_b' / 'unit.yaml').write_text(yaml.safe_dump(
        {'motor_joint': 'pdu_l', 'load_joint': 'flap_l_out'}))
    result = subprocess.run([str(GEAR_PHM), 'fleet', str(root), '--ratio', '3.0', '--out',
                             str(tmp_path / 'out'), '--workers', '1', '--no-progress',
                             '--no-unit-outputs'],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    with open(tmp_path / 'out' / 'fleet.csv', newline='') as handle:
        rows = {row['unit']: row for row in csv.DictReader(handle)}
    assert list(rows) == ['unit_a/flap_l', 'unit_a/spoiler_3', 'unit_a/rudder', 'unit_b']
    assert not any(row['level'] == 'FAILED' for row in rows.values())
    # the same recording and joints: the same estimate, in a drive of many or alone
    assert float(rows['unit_a/flap_l']['u']) == pytest.approx(float(rows['unit_b']['u']),
                                                              rel=1e-9, abs=0)
    assert (tmp_path / 'out' / 'fleet.png').is_file()


def test_a_drive_whose_joints_vanish_counts_them_alone(bench: Path, tmp_path: Path) -> None:
    """Cut rudder's joints from the second half of the stream: rudder alone counts them.

    It counts missing_joint for each of those messages; flap_l and spoiler_3 equal their
    analysis of the whole bag.
    """
    from gear_phm.bagio import Rosbag2McapWriter
    from gear_phm.codec import decode_joint_states, joint_state_rows
    cut = tmp_path / 'cut'
    pairs = [(d['motor_joint'], d['load_joint']) for d in DRIVES.values()]
    with BagReader(bench / 'bag') as bag:
        messages = list(bag.raw_messages(['/joint_states']))
    log_times = np.array([t for _, t, _ in messages], dtype=np.int64)
    batches = [decode_joint_states([raw for _, _, raw in messages], *pair) for pair in pairs]
    names = [joint for pair in pairs for joint in pair]

    def columns(kind: str, keep: int) -> np.ndarray:
        return np.column_stack([getattr(b, f'{end}_{kind}') for b in batches
                                for end in ('motor', 'load')])[:, :keep]
    half = len(messages) // 2
    with Rosbag2McapWriter(cut, batch=True) as writer:
        writer.add_topic(interfaces.JOINT_STATES, interfaces.JOINT_STATE_TYPE)
        for rows, keep in ((slice(0, half), len(names)), (slice(half, None), 4)):
            payloads = joint_state_rows(batches[0].stamp_ns[rows], names[:keep],
                                        columns('position', keep)[rows],
                                        columns('velocity', keep)[rows],
                                        columns('effort', keep)[rows])
            writer.write_groups([(interfaces.JOINT_STATES, log_times[rows], payloads)])
    whole = analyze_bag(bench / 'bag', transmissions=bench / 'bench.yaml', plot=False)
    analysis = analyze_bag(cut, transmissions=bench / 'bench.yaml', plot=False)
    counts = {n: a.summary.estimator.counts for n, a in analysis.transmissions.items()}
    assert counts['rudder'].get('missing_joint') == len(messages) - half
    assert analysis.transmissions['rudder'].summary.estimator.samples_seen == half
    for name in ('flap_l', 'spoiler_3'):
        assert counts[name].get('missing_joint', 0) == 0
        assert analysis.transmissions[name].summary.estimator.u == pytest.approx(
            whole.transmissions[name].summary.estimator.u, rel=1e-9, abs=0)


def test_evaluate_scores_each_drive_against_its_own_truth(tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]
                                                          ) -> None:
    """Two drives that wear out at different times: each is scored against its own end of life."""
    spec = tmp_path / 'worn.yaml'
    spec.write_text(yaml.safe_dump({'transmissions': {
        'aileron': {'motor_joint': 'ail_m', 'load_joint': 'ail_l', 'ratio': 3.0,
                    'eta_opposing_min': 0.7,
                    'simulation': {'wear': 'linear', 'friction_initial': 0.05,
                                   'wear_rate': 5e-3}},
        'elevator': {'motor_joint': 'elv_m', 'load_joint': 'elv_l', 'ratio': 2.0,
                     'eta_opposing_min': 0.7,
                     'simulation': {'wear': 'linear', 'friction_initial': 0.05,
                                    'wear_rate': 4e-3}}}}, sort_keys=False))
    bag, out = tmp_path / 'bag', tmp_path / 'analysis'
    assert main(['simulate', '--transmissions', str(spec), '--duration', '60', '--out',
                 str(bag)]) == 0
    assert main(['analyze', str(bag), '--transmissions', str(spec), '--out', str(out),
                 '--no-plot', '--no-progress']) == 0
    capsys.readouterr()
    assert main(['evaluate', str(out), '--truth', str(bag), '--transmissions', str(spec)]) == 0
    printed = capsys.readouterr().out
    assert 'drive aileron:' in printed and 'drive elevator:' in printed
    eol = {}
    for drive, u_eol in (('aileron', 0.9 / 3.1), ('elevator', 0.6 / 2.4)):
        result = json.loads((out / f'evaluation_{drive}.json').read_text())
        assert result['drive'] == drive and result['u_eol'] == pytest.approx(u_eol)
        eol[drive] = result['t_eol_s']
        assert result['predictions'] > 0
    # true u = 0.05 + rate t reaches u_eol at t = (u_eol - 0.05) / rate (stamps from 0)
    assert eol['aileron'] == pytest.approx((0.9 / 3.1 - 0.05) / 5e-3, abs=0.02)
    assert eol['elevator'] == pytest.approx((0.6 / 2.4 - 0.05) / 4e-3, abs=0.02)


def test_a_drive_named_twice_in_the_mapping_is_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A name given twice is refused (PyYAML would keep the last): the drive is named."""
    path = tmp_path / 'twice.yaml'
    path.write_text('transmissions:\n'
                    '  flap_l: {motor_joint: m1, load_joint: l1, ratio: 3.0}\n'
                    '  flap_l: {motor_joint: m2, load_joint: l2, ratio: 4.0}\n')
    with pytest.raises(TransmissionsError,
                       match=rf"^{path}: line 3: 'flap_l' is given twice in one mapping"):
        load_transmissions(path)
    assert main(['simulate', '--transmissions', str(path), '--duration', '1', '--out',
                 str(tmp_path / 'out')]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'flap_l' is given twice" in err[0], err
    assert not (tmp_path / 'out').exists()
    # a key twice inside a drive too; YAML merge keys (<<) may still be overridden
    path.write_text('transmissions:\n'
                    '  flap_l: {motor_joint: m1, load_joint: l1, ratio: 3.0, ratio: 4.0}\n')
    with pytest.raises(TransmissionsError, match="'ratio' is given twice"):
        load_transmissions(path)
    path.write_text('base: &base {motor_joint: m1, load_joint: l1, ratio: 3.0}\n'
                    'transmissions:\n'
                    '  flap_l: {<<: *base, ratio: 4.0}\n')
    with pytest.raises(TransmissionsError, match='unknown top-level key'):
        load_transmissions(path)


def test_exponent_numbers_without_a_dot_are_floats(tmp_path: Path) -> None:
    """``1e-3`` (YAML 1.2; a string to PyYAML's YAML 1.1 resolver) is the number 0.001."""
    path = tmp_path / 'dotless.yaml'
    path.write_text('transmissions:\n'
                    '  flap_l: {motor_joint: m1, load_joint: l1, ratio: 3E+1,\n'
                    '           simulation: {wear: linear, wear_rate: 1e-3,'
                    ' friction_initial: 5e-2}}\n'
                    '  flap_r: {motor_joint: m2, load_joint: l2, ratio: 1.5e1}\n')
    flap_l, flap_r = load_transmissions(path)
    assert flap_l.ratio == 30.0 and flap_r.ratio == 15.0
    assert flap_l.simulation == {'wear': 'linear', 'wear_rate': 0.001, 'friction_initial': 0.05}
    path.write_text('transmissions:\n  1e3: {motor_joint: m1, load_joint: l1, ratio: 3}\n')
    with pytest.raises(TransmissionsError, match=r'drive name 1000\.0 must be a letter'):
        load_transmissions(path)


def test_simulate_refuses_ratio_with_transmissions(
        bench: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Each drive has its own ratio: --ratio would be ignored."""
    assert main(['simulate', '--transmissions', str(bench / 'bench.yaml'), '--ratio', '5',
                 '--duration', '1', '--out', str(tmp_path / 'out')]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ['gear-phm simulate: error: --transmissions sets each drive: drop --ratio']


def _idle_bench(bench: Path, out: Path, idle: set[str]) -> Path:
    """Write bench's bag again with the ``idle`` drives' speeds and torques all zero."""
    from gear_phm.bagio import Rosbag2McapWriter
    from gear_phm.codec import decode_joint_states, joint_state_rows
    with BagReader(bench / 'bag') as bag:
        messages = list(bag.raw_messages(['/joint_states']))
    log_times = np.array([t for _, t, _ in messages], dtype=np.int64)
    names = [joint for d in DRIVES.values() for joint in (d['motor_joint'], d['load_joint'])]
    batches = [decode_joint_states([raw for _, _, raw in messages], d['motor_joint'],
                                   d['load_joint']) for d in DRIVES.values()]
    moving = [name not in idle for name in DRIVES for _ in (0, 1)]

    def columns(kind: str) -> np.ndarray:
        values = np.column_stack([getattr(b, f'{end}_{kind}') for b in batches
                                  for end in ('motor', 'load')])
        return values if kind == 'position' else values * np.array(moving, dtype=float)
    with Rosbag2McapWriter(out, batch=True) as writer:
        writer.add_topic(interfaces.JOINT_STATES, interfaces.JOINT_STATE_TYPE)
        payloads = joint_state_rows(batches[0].stamp_ns, names, columns('position'),
                                    columns('velocity'), columns('effort'))
        writer.write_groups([(interfaces.JOINT_STATES, log_times, payloads)])
    return out


def test_a_drive_that_never_moves_is_stale_alone_and_all_idle_is_an_error(
        bench: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A bench drive without a single measurement: its summary says so, level STALE.

    The others' results stand (the one-pass analysis was refused as a whole, once the
    filter's prior stopped passing for an estimate); no drive measured: exit 2.
    """
    bag = _idle_bench(bench, tmp_path / 'idle', {'rudder'})
    assert main(['analyze', str(bag), '--transmissions', str(bench / 'bench.yaml'), '--out',
                 str(tmp_path / 'out'), '--no-plot', '--no-progress']) == 0
    err = capsys.readouterr().err
    assert 'rudder: no efficiency measurement (' in err and 'zero_speed' in err, err
    drives = json.loads((tmp_path / 'out' / 'summary.json').read_text())['transmissions']
    assert drives['rudder']['health']['level'] == 'STALE'
    assert drives['rudder']['no_measurement'].startswith(f'{drives["rudder"]["samples_seen"]}')
    whole = analyze_bag(bench / 'bag', transmissions=bench / 'bench.yaml', plot=False)
    for name in ('flap_l', 'spoiler_3'):
        assert 'no_measurement' not in drives[name]
        assert drives[name]['u'] == pytest.approx(whole.transmissions[name].summary.estimator.u,
                                                  rel=1e-9, abs=0)
    none = _idle_bench(bench, tmp_path / 'none', set(DRIVES))
    assert main(['analyze', str(none), '--transmissions', str(bench / 'bench.yaml'), '--out',
                 str(tmp_path / 'none_out'), '--no-plot', '--no-progress']) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and 'no efficiency measurement, no drive has one; drive flap_l:' \
        in lines[0], lines
    assert not (tmp_path / 'none_out').exists()
