"""Test gear-phm simulate --fleet and gear-phm fleet.

Units run in parallel on Dask, bad units are reported, results are independent of the number
of workers.
"""
from __future__ import annotations

import csv
import functools
import json
import math
import os
from pathlib import Path
import shutil
import signal
import subprocess
import sys

import pytest

from helpers.processes import signalled_when_staged
from helpers.shared import build_once

GEAR_PHM = Path(sys.executable).parent / 'gear-phm'
REPO = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.timeout(600)


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(GEAR_PHM), *args], capture_output=True, text=True, timeout=500)


@pytest.fixture(scope='module')
def fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two recordings of three units, an empty and a broken unit, a per-unit ratio.

    Simulated once per test run (helpers.shared.build_once): two tests read it.
    """
    return build_once(tmp_path_factory, 'fleet', _make_fleet) / 'root'


def _make_fleet(directory: Path) -> None:
    root = directory / 'root'
    result = run('simulate', '--fleet', '3', '--recordings', '2', '--duration', '40',
                 '--gap', '86400', '--wear', 'linear', '--friction-initial', '0.05',
                 '--wear-rate', '1e-3', '--seed', '4', '--out', str(root))
    assert result.returncode == 0, result.stderr
    (root / 'unit_empty').mkdir()                                  # no recording
    broken = root / 'unit_broken'
    broken.mkdir()
    (broken / 'rec.mcap').write_bytes(b'\x89MCAP0\r\n' + b'\x00' * 100)   # corrupt bag
    # unit_02 is a gearbox of ratio 30, given in its unit.yaml (a per-unit option; its speeds
    # would refuse --ratio 3.0)
    result = run('simulate', '--fleet', '1', '--recordings', '2', '--duration', '40',
                 '--gap', '86400', '--wear', 'linear', '--friction-initial', '0.05',
                 '--wear-rate', '1e-3', '--seed', '5', '--ratio', '30.0', '--out',
                 str(directory / 'r30'))
    assert result.returncode == 0, result.stderr
    shutil.rmtree(root / 'unit_02')
    (directory / 'r30' / 'unit_00').rename(root / 'unit_02')
    (root / 'unit_02' / 'unit.yaml').write_text('ratio: 30.0\n')


#: The options of every fleet analysis of ``fleet`` here.
OPTIONS = ('--ratio', '3.0', '--eta-opposing-min', '0.7333', '--eta-warn', '0.8')


@pytest.fixture(scope='module')
def one_worker(fleet: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Return the directory of the fleet table of one local worker and that run's stderr.

    ``out`` holds the table (no unit outputs, no progress bar), ``stderr.txt`` the standard
    error. Run once per test run (helpers.shared.build_once): two tests compare with it.
    """
    return build_once(tmp_path_factory, 'fleet_one_worker',
                      functools.partial(_one_worker, fleet))


def _one_worker(fleet: Path, directory: Path) -> None:
    result = run('fleet', str(fleet), '--out', str(directory / 'out'), '--workers', '1',
                 '--no-progress', '--no-unit-outputs', '--no-plot', *OPTIONS)
    assert result.returncode == 0, result.stderr
    (directory / 'stderr.txt').write_text(result.stderr)


def read_rows(path: Path) -> dict[str, dict[str, str]]:
    with open(path / 'fleet.csv', newline='') as handle:
        return {row['unit']: row for row in csv.DictReader(handle)}


def test_fleet_table_bad_units_and_worker_independence(fleet: Path, one_worker: Path,
                                                       tmp_path: Path) -> None:
    one, two = one_worker / 'out', tmp_path / 'two'
    result = run('fleet', str(fleet), '--out', str(two), '--workers', '2', *OPTIONS)
    assert result.returncode == 0, result.stderr
    assert 'unit unit_broken: FAILED' in result.stderr and 'unit_empty: FAILED' in result.stderr
    # one task per unit: the table does not depend on the number of workers
    assert (one / 'fleet.csv').read_bytes() == (two / 'fleet.csv').read_bytes()
    assert (one / 'fleet.parquet').read_bytes() == (two / 'fleet.parquet').read_bytes()
    rows = read_rows(two)
    assert list(rows) == ['unit_00', 'unit_01', 'unit_02', 'unit_broken', 'unit_empty']
    assert rows['unit_empty']['reason'].startswith('no recording in')
    assert rows['unit_broken']['level'] == 'FAILED' and rows['unit_broken']['reason']
    for unit in ('unit_00', 'unit_01'):
        row = rows[unit]
        assert row['recordings'] == '2' and row['level'] in ('OK', 'WARN', 'ERROR')
        # about 40 s of life per recording, u near 0.05 + 1e-3 * 80 s of operation
        assert 0.09 < float(row['u']) < 0.2
        assert 55.0 < float(row['operating_time_s']) <= 80.0
        assert float(row['rul_p5_s']) <= float(row['rul_s']) <= float(row['rul_p95_s'])
        rul = [float(row[k]) for k in ('rul_operating_p5_s', 'rul_operating_s',
                                       'rul_operating_p95_s')]
        assert rul == sorted(rul)
        # a day idle between two 40 s recordings: the elapsed-time RUL is the operating one
        # over the utilisation (about 70 s of operation in 86 440 s)
        utilisation = float(row['utilisation'])
        assert utilisation == pytest.approx(float(row['operating_time_s']) / 86_440, rel=0.1)
        # seed 4: both units have a finite wear trend, so the conversion is always checked
        assert math.isfinite(rul[1]) and rul[1] > 0, row
        # the recent duty: the newest max(RUL, 60 s) of operation reach over the day, so
        # about the whole history's utilisation
        assert float(row['rul_s']) == pytest.approx(rul[1] / utilisation, rel=0.1)
        assert float(row['rul_p5_s']) == rul[0]          # as if it ran without a pause
    # unit_02 was analysed with its own ratio 30 (unit.yaml), the others with --ratio 3
    summary = json.loads((two / 'units' / 'unit_02' / 'summary.json').read_text())
    assert summary['config']['ratio'] == 30.0
    assert json.loads((two / 'units' / 'unit_01' / 'summary.json').read_text())[
        'config']['ratio'] == 3.0
    assert (two / 'fleet.png').stat().st_size > 10_000
    assert not (one / 'fleet.png').exists()                             # --no-plot
    assert [json.loads((run / 'fleet_run.json').read_text())['workers'] for run in (one, two)
            ] == [1, 2]
    assert sorted(p.name for p in one.iterdir()) == ['fleet.csv', 'fleet.parquet',
                                                     'fleet_run.json']
    assert (two / 'units' / 'unit_00' / 'summary.json').is_file()
    assert not (one / 'units').exists()
    import pyarrow.parquet as pq
    table = pq.read_table(two / 'fleet.parquet')
    assert table.column_names[:3] == ['unit', 'recordings', 'operating_time_s']
    assert table.num_rows == 5


def test_fleet_bad_root_is_one_line(tmp_path: Path) -> None:
    (tmp_path / 'empty').mkdir()
    result = run('fleet', str(tmp_path / 'empty'), '--ratio', '3', '--out', str(tmp_path / 'o'))
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        f'gear-phm fleet: error: fleet root {tmp_path / "empty"} has no unit folder '
        '(one sub-folder per unit)']


def test_simulate_fleet_gaps_regular_or_irregular(tmp_path: Path) -> None:
    """--gap sets every idle gap; --gap-spread scatters them log-normally around it."""
    import yaml
    starts = {}
    for spread in ('0', '1.0'):
        root = tmp_path / f'spread{spread}'
        result = run('simulate', '--fleet', '2', '--recordings', '6', '--duration', '2',
                     '--gap', '1000', '--gap-spread', spread, '--seed', '2', '--out',
                     str(root))
        assert result.returncode == 0, result.stderr
        starts[spread] = [yaml.safe_load((unit / 'truth.yaml').read_text())['recording_start_s']
                          for unit in sorted(root.iterdir())]
    for unit in starts['0']:
        assert [b - a for a, b in zip(unit, unit[1:])] == [1002.0] * 5
    gaps = [b - a - 2.0 for unit in starts['1.0'] for a, b in zip(unit, unit[1:])]
    assert min(gaps) > 0 and max(gaps) / min(gaps) > 3                # irregular
    assert starts['1.0'][0] != starts['1.0'][1]                        # each unit its own
    bad = run('simulate', '--fleet', '2', '--gap-spread', '-1', '--out', str(tmp_path / 'x'))
    assert bad.returncode == 2 and '--gap-spread' in bad.stderr


def test_fleet_runs_on_an_existing_scheduler(fleet: Path, one_worker: Path,
                                             tmp_path: Path) -> None:
    """``--scheduler ADDRESS`` runs the same job on a cluster the user already has.

    The cluster here is a real Dask scheduler with one worker process, started by the test;
    the table is byte for byte the one of a local run, and the progress bar counts units.
    """
    from dask.distributed import LocalCluster
    local, remote = one_worker / 'out', tmp_path / 'remote'
    assert 'fleet:' not in (one_worker / 'stderr.txt').read_text()      # --no-progress
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=None, local_directory=str(tmp_path / 'dask'),
                      scheduler_kwargs={'dashboard_address': ':0'}) as cluster:  # any port
        result = run('fleet', str(fleet), '--out', str(remote), '--scheduler',
                     cluster.scheduler_address, '--no-unit-outputs', '--no-plot', *OPTIONS)
        ran = sorted(cluster.scheduler.task_prefixes)
    assert ran and all(name.startswith('gear-phm-unit') for name in ran), ran
    assert result.returncode == 0, result.stderr
    assert (remote / 'fleet.parquet').read_bytes() == (local / 'fleet.parquet').read_bytes()
    assert (remote / 'fleet.csv').read_bytes() == (local / 'fleet.csv').read_bytes()
    assert 'fleet: 100%' in result.stderr and '5/5' in result.stderr     # five unit folders
    assert json.loads((remote / 'fleet_run.json').read_text())['workers'] == 1   # the cluster's


def test_fleet_bad_unit_yaml_fails_that_unit_only(tmp_path: Path) -> None:
    """A unit.yaml value of the wrong type, a reserved or conflicting key, or a binary file.

    Also values that contradict each other (eta_warn <= eta_opposing_min).

    Each makes its unit FAILED with the reason naming the file (and the key), before its
    recording (one of bags/fleet, linked) is read; the fleet completes.
    """
    root = tmp_path / 'root'
    files = {'topic': b'topic: 5\n', 'history': b'history: 0\n',
             'both': b'ratio: 3.0\ntransmissions:\n  a: {motor_joint: m, load_joint: l, '
                     b'ratio: 3.0}\n',
             'binary': b'\xff\xfe\x00\x89binary',
             'warn': b'eta_opposing_min: 0.7\neta_warn: 0.6\n'}
    for unit, text in files.items():
        (root / unit).mkdir(parents=True)
        (root / unit / 'rec_000').symlink_to(REPO / 'bags' / 'fleet' / 'unit_00' / 'rec_000')
        (root / unit / 'unit.yaml').write_bytes(text)
    out = tmp_path / 'out'
    result = run('fleet', str(root), '--out', str(out), '--ratio', '3', '--workers', '1',
                 '--no-progress', '--no-unit-outputs', '--no-plot')
    assert result.returncode == 0, result.stderr
    assert 'Traceback' not in result.stderr
    rows = read_rows(out)
    assert {unit: row['level'] for unit, row in rows.items()} == dict.fromkeys(
        sorted(files), 'FAILED')
    reasons = {unit: row['reason'] for unit, row in rows.items()}
    for unit in files:
        assert reasons[unit].startswith(f'{root / unit / "unit.yaml"}: '), reasons
    assert reasons['topic'].endswith('topic must be a string, got 5')
    assert "unknown option 'history'" in reasons['history']
    assert reasons['both'].endswith('with transmissions, each drive sets its own ratio, '
                                    'joints and names: drop ratio')
    assert reasons['binary'].endswith('not UTF-8 text')
    assert 'eta_warn must be > eta_opposing_min (0.7)' in reasons['warn']


def test_a_local_cluster_has_at_most_one_worker_per_unit(tmp_path: Path) -> None:
    """One unit and --workers 3: one worker process (two more would only start and idle)."""
    root = tmp_path / 'root'
    (root / 'unit_00').mkdir(parents=True)
    (root / 'unit_00' / 'rec_000').symlink_to(REPO / 'bags' / 'fleet' / 'unit_00' / 'rec_000')
    out = tmp_path / 'out'
    result = run('fleet', str(root), '--out', str(out), '--ratio', '3', '--workers', '3',
                 '--no-progress', '--no-unit-outputs', '--no-plot')
    assert result.returncode == 0, result.stderr
    run_info = json.loads((out / 'fleet_run.json').read_text())
    assert run_info['workers'] == 1 and run_info['units'] == 1, run_info
    assert read_rows(out)['unit_00']['level'] in ('OK', 'WARN', 'ERROR')


@pytest.mark.parametrize('args, message', [
    (('--ratio', '-5'), 'ratio must be in [1e-06, 1e+06], got -5.0'),
    (('--ratio', '0'), 'ratio must be in [1e-06, 1e+06], got 0.0'),
    (('--ratio', '3', '--eta-opposing-min', '5'), 'eta_opposing_min must be in [-1, 1], '
                                                  'got 5.0'),
    (('--eta-opposing-min', '5'), 'eta_opposing_min must be in [-1, 1], got 5.0'),
    (('--ratio', '3', '--scheduler', 'garbage'),
     'cannot connect to the Dask scheduler at garbage: missing port number in address '
     "'garbage'"),
    (('--ratio', '3', '--scheduler', 'tcp://127.0.0.1:1', '--scheduler-timeout', '1'),
     'cannot connect to the Dask scheduler at tcp://127.0.0.1:1: Timed out trying to connect '
     'to tcp://127.0.0.1:1 after 1 s'),
    (('--ratio', '3', '--scheduler-timeout', '0'), '--scheduler-timeout must be > 0 s, got 0.0'),
])
def test_fleet_bad_options_are_one_line_and_leave_nothing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], args: tuple[str, ...],
        message: str) -> None:
    """Checked before any unit runs: exit 2, one line, no --out and no staging folder."""
    from gear_phm.cli.main import main
    root = tmp_path / 'root'
    (root / 'unit_00').mkdir(parents=True)
    (root / 'unit_00' / 'rec.mcap').write_bytes(b'')
    assert main(['fleet', str(root), '--out', str(tmp_path / 'out'), *args]) == 2
    assert capsys.readouterr().err.splitlines() == [f'gear-phm fleet: error: {message}']
    assert sorted(p.name for p in tmp_path.iterdir()) == ['root']


def test_fleet_unwritable_out_is_one_line(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    """An --out under a file, too long a name, a read-only folder: exit 2, one line, nothing."""
    from gear_phm.cli.main import main
    root = tmp_path / 'root'
    (root / 'unit_00').mkdir(parents=True)
    (tmp_path / 'file').write_text('')
    assert main(['fleet', str(root), '--ratio', '3', '--out',
                 str(tmp_path / 'file' / 'out')]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f'gear-phm fleet: error: cannot write --out {tmp_path / "file" / "out"}: '
        f'{tmp_path / "file"} is not a directory']
    for name in ('x' * 250, 'x' * 300):      # the staging folder's name, --out's: too long
        long = tmp_path / name
        assert main(['fleet', str(root), '--ratio', '3', '--out', str(long)]) == 2
        assert capsys.readouterr().err.splitlines() == [
            f'gear-phm fleet: error: cannot write --out {long}: File name too long']
    assert sorted(p.name for p in tmp_path.iterdir()) == ['file', 'root']
    if os.geteuid() == 0:
        return                               # root writes into a read-only folder
    locked = tmp_path / 'locked'
    locked.mkdir(mode=0o555)
    try:
        assert main(['fleet', str(root), '--ratio', '3', '--out', str(locked / 'out')]) == 2
        assert capsys.readouterr().err.splitlines() == [
            f'gear-phm fleet: error: cannot write --out {locked / "out"}: Permission denied']
        assert list(locked.iterdir()) == []
    finally:
        locked.chmod(0o755)


def test_fleet_terminated_leaves_no_out(tmp_path: Path) -> None:
    """SIGTERM while the fleet runs: exit 143, one line, no --out and no staging folder."""
    folder = tmp_path / 'folder'
    folder.mkdir()
    done = signalled_when_staged([str(GEAR_PHM), 'fleet', str(REPO / 'bags' / 'fleet'),
                                  '--ratio', '3', '--out', str(folder / 'out'),
                                  '--no-progress'], folder, signal.SIGTERM)
    assert done.returncode == 143, done.stderr
    assert done.stderr.strip().splitlines() == ['gear-phm fleet: terminated']
    assert list(folder.iterdir()) == []


def test_the_options_default_to_a_local_cluster() -> None:
    import argparse

    from gear_phm.cli.fleet import add_arguments
    from gear_phm.offline.fleet import CONNECT_TIMEOUT
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    args = parser.parse_args(['units', '--out', 'o', '--scheduler-timeout', '2.5'])
    assert (args.root, args.out) == (Path('units'), Path('o'))
    assert (args.scheduler, args.workers, args.scheduler_timeout) == (None, None, 2.5)
    assert parser.parse_args(['u', '--out', 'o']).scheduler_timeout == CONNECT_TIMEOUT
    assert not (args.population_prior or args.no_unit_outputs or args.no_plot)
