"""The drives of one analysis in worker processes (gear_phm.offline.parallel, --jobs)."""
from __future__ import annotations

import json
from pathlib import Path
import subprocess
import sys

import numpy as np
import pytest

from gear_phm import interfaces
from gear_phm.bagio import BagReader
from gear_phm.cli.main import main
from gear_phm.offline import analyze_bag
from helpers.shared import build_once
from toplevel.test_transmissions import _make_bench, DRIVES  # noqa: I100, I201

GEAR_PHM = Path(sys.executable).parent / 'gear-phm'


@pytest.fixture(scope='module')
def bench(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Return toplevel/test_transmissions.py's three-drive bench, built once per run."""
    return build_once(tmp_path_factory, 'bench', _make_bench)


def _restarted(bench: Path, path: Path) -> None:
    """Write the bench bag with its second half stamped again from its start (a replay loop).

    The header stamps go back inside one batch: the analysis then writes each batch by parts,
    between its /diagnostics ticks.
    """
    from gear_phm.bagio import Rosbag2McapWriter
    from gear_phm.codec import decode_joint_states, joint_state_rows
    pairs = [(d['motor_joint'], d['load_joint']) for d in DRIVES.values()]
    with BagReader(bench / 'bag') as bag:
        messages = list(bag.raw_messages(['/joint_states']))
    log_times = np.array([t for _, t, _ in messages], dtype=np.int64)
    batches = [decode_joint_states([raw for _, _, raw in messages], *pair) for pair in pairs]
    stamps = batches[0].stamp_ns.copy()
    half = len(stamps) // 2
    stamps[half:] = stamps[:len(stamps) - half]

    def columns(kind: str) -> np.ndarray:
        return np.column_stack([getattr(b, f'{end}_{kind}') for b in batches
                                for end in ('motor', 'load')])
    with Rosbag2McapWriter(path, batch=True) as writer:
        writer.add_topic(interfaces.JOINT_STATES, interfaces.JOINT_STATE_TYPE)
        payloads = joint_state_rows(stamps, [j for pair in pairs for j in pair],
                                    columns('position'), columns('velocity'),
                                    columns('effort'))
        writer.write_groups([(interfaces.JOINT_STATES, log_times, payloads)])


def _outputs(out: Path) -> list[tuple]:
    """Return every message of an output bag in file order: (topic, log time [ns], content).

    Read by mcap's reader (file order, not log time order), deserialized by rosbags.
    Vector3Stamped: (stamp [ns], x, y, z); DiagnosticArray: each status's level, name,
    message, hardware_id and key/values.
    """
    from mcap.reader import make_reader
    from rosbags.typesys import get_typestore, Stores
    store = get_typestore(Stores.ROS2_JAZZY)
    rows: list[tuple] = []
    for path in sorted(out.glob('*.mcap')):
        with open(path, 'rb') as handle:
            for schema, channel, record in make_reader(handle).iter_messages(
                    log_time_order=False):
                message = store.deserialize_cdr(record.data, schema.name)
                if channel.topic == '/diagnostics':
                    content: tuple = tuple(
                        (int(s.level), s.name, s.message, s.hardware_id,
                         tuple((v.key, v.value) for v in s.values)) for s in message.status)
                else:
                    stamp = message.header.stamp
                    content = (stamp.sec * 10**9 + stamp.nanosec, message.vector.x,
                               message.vector.y, message.vector.z)
                rows.append((channel.topic, record.log_time, content))
    return rows


def _same_outputs(ours: list[tuple], theirs: list[tuple]) -> None:
    """Assert two output bags' messages equal: order, topics, stamps; floats within 1e-12."""
    assert [(t, n) for t, n, _ in ours] == [(t, n) for t, n, _ in theirs]
    for (topic, _, a), (_, _, b) in zip(ours, theirs):
        if topic != '/diagnostics':
            assert a[0] == b[0]
            np.testing.assert_allclose(a[1:], b[1:], rtol=1e-12, atol=0)
            continue
        assert [s[:4] for s in a] == [s[:4] for s in b]
        for s, t in zip(a, b):
            assert [k for k, _ in s[4]] == [k for k, _ in t[4]]
            for (key, x), (_, y) in zip(s[4], t[4]):
                try:
                    assert float(x) == pytest.approx(float(y), rel=1e-12, abs=0, nan_ok=True)
                except ValueError:
                    assert x == y, key


def _same_summary(ours: object, theirs: object) -> None:
    """Assert two summaries equal: the same keys and texts, numbers within 1e-12."""
    if isinstance(ours, dict) and isinstance(theirs, dict):
        assert list(ours) == list(theirs)
        for key in ours:
            _same_summary(ours[key], theirs[key])
    elif isinstance(ours, list) and isinstance(theirs, list):
        assert len(ours) == len(theirs)
        for a, b in zip(ours, theirs):
            _same_summary(a, b)
    elif isinstance(ours, float) or isinstance(theirs, float):
        assert ours == pytest.approx(theirs, rel=1e-12, abs=0, nan_ok=True)
    else:
        assert ours == theirs


@pytest.mark.long(15)
def test_jobs_split_the_drives_over_processes_with_the_same_results(
        bench: Path, tmp_path: Path) -> None:
    """``gear-phm analyze --jobs 2``: the drives in two worker processes, the same outputs.

    The bench bag and one whose stamps restart mid-batch (the writing by parts), read as one
    run, with the plots (drawn in the workers): message for message, the output bag, the
    summaries and the plots' pixels equal an analysis in one process
    (``analyze_bag(..., jobs=1)``).
    """
    restarted = tmp_path / 'restarted'
    _restarted(bench, restarted)
    bags = [bench / 'bag', restarted]
    split, whole = tmp_path / 'jobs2', tmp_path / 'jobs1'
    result = subprocess.run(
        [str(GEAR_PHM), 'analyze', *map(str, bags), '--transmissions',
         str(bench / 'bench.yaml'), '--jobs', '2', '--out', str(split), '--no-progress'],
        capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    analyze_bag(bags, transmissions=bench / 'bench.yaml', out=whole, jobs=1)
    from matplotlib.image import imread
    for name in DRIVES:
        ours, theirs = (imread(str(d / f'analysis_{name}.png')) for d in (split, whole))
        assert ours.shape == theirs.shape and ours.shape[0] > 400
        np.testing.assert_allclose(ours, theirs, atol=1e-6)
    ours = json.loads((split / 'summary.json').read_text())
    theirs = json.loads((whole / 'summary.json').read_text())
    assert (ours.pop('workers'), theirs.pop('workers')) == (2, 0)
    for summary in (ours, theirs):
        for key in ('seconds', 'samples_per_second', 'bag'):
            summary.pop(key)
            for drive in summary['transmissions'].values():
                drive.pop(key)
    _same_summary(ours, theirs)
    outputs = _outputs(split)
    _same_outputs(outputs, _outputs(whole))
    assert len(outputs) > 20000
    # the restart made the estimates' stamps go back, at the second bag and inside it
    stamps = [content[0] for topic, _, content in outputs
              if topic == '/gear_phm/rudder/friction']
    assert sum(b < a for a, b in zip(stamps, stamps[1:])) >= 2


FAILING = """
import contextlib, io, multiprocessing, os, sys
from pathlib import Path
from gear_phm.cli.main import main
from gear_phm.offline import AnalysisError, ParallelError, engine
bag, spec, out = sys.argv[1:4]
real_advance, real_write = engine.DriveRun.advance, engine.Stream.write_batch
MODE = ''
def advance(self, *args):
    if self.drive == 'rudder' and MODE == 'raise':
        raise AnalysisError('drive rudder: made to fail')
    if self.drive == 'rudder' and MODE == 'die':
        os._exit(3)
    return real_advance(self, *args)
def write(self, *args):                 # killed between two requests: the next send fails
    for process in getattr(self.drives, 'processes', []) if MODE == 'killed' else ():
        process.kill()
        process.join()
    return real_write(self, *args)
engine.DriveRun.advance, engine.Stream.write_batch = advance, write
def gone():
    left = os.listdir(Path(out).parent)
    assert not Path(out).exists() and not left, left
    assert not multiprocessing.active_children(), multiprocessing.active_children()
for MODE, error in (('raise', AnalysisError), ('die', ParallelError), ('killed', ParallelError)):
    try:
        engine.analyze_bag(bag, transmissions=spec, out=out, jobs=2, plot=False)
    except error as exc:
        print(MODE, type(exc).__name__, exc, flush=True)
    else:
        raise SystemExit(f'{MODE}: no error')
    gone()
MODE = 'die'
err = io.StringIO()
with contextlib.redirect_stderr(err):
    code = main(['analyze', bag, '--transmissions', spec, '--jobs', '2', '--out', out,
                 '--no-progress', '--no-plot'])
print(code, err.getvalue().strip(), flush=True)
gone()
"""


def test_a_failing_drive_worker_fails_the_analysis_and_leaves_nothing(
        bench: Path, tmp_path: Path) -> None:
    """A drive's error in its worker is the analysis's error; a dead worker, ParallelError.

    A worker that dies on a request, or was killed between two: ParallelError, and through
    ``gear-phm analyze`` a one-line error (exit 2). No output is left, no worker stays.
    """
    folder = tmp_path / 'outs'
    folder.mkdir()
    result = subprocess.run(
        [sys.executable, '-c', FAILING, str(bench / 'bag'), str(bench / 'bench.yaml'),
         str(folder / 'out')], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    gone = 'a drive worker process ended without answering (killed, or out of memory?)'
    assert result.stdout.splitlines() == [
        'raise AnalysisError drive rudder: made to fail', f'die ParallelError {gone}',
        f'killed ParallelError {gone}', f'2 gear-phm analyze: error: {gone}']


def test_jobs_must_be_zero_or_more(bench: Path, tmp_path: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'out'
    assert main(['analyze', str(bench / 'bag'), '--transmissions', str(bench / 'bench.yaml'),
                 '--jobs', '-1', '--out', str(out), '--no-progress']) == 2
    assert '--jobs must be 0 (one per core) or more, got -1' in capsys.readouterr().err
    assert not out.exists()
    with pytest.raises(ValueError, match='jobs must be an integer >= 0'):
        analyze_bag(bench / 'bag', transmissions=bench / 'bench.yaml', jobs=1.5, plot=False)


SPLIT_FAILING = """
import os, sys
from pathlib import Path
from gear_phm.offline import AnalysisError, ParallelError, engine
bag, out = sys.argv[1:3]
real_assess = engine.DriveRun.assess
MODE = ''
def assess(self, *args):
    if MODE == 'raise':
        raise AnalysisError('the assessor was made to fail')
    if MODE == 'die':
        os._exit(3)
    return real_assess(self, *args)
engine.DriveRun.assess = assess
for MODE, error in (('raise', AnalysisError), ('die', ParallelError)):
    try:
        engine.analyze_bag(bag, 3.0, motor_joint='pdu_l', load_joint='flap_l_out', out=out,
                           jobs=2, plot=False)
    except error as exc:
        print(MODE, type(exc).__name__, exc, flush=True)
    else:
        raise SystemExit(f'{MODE}: no error')
    assert not Path(out).exists()
"""


def test_one_drive_assesses_in_a_worker_with_the_same_results(
        bench: Path, tmp_path: Path) -> None:
    """One drive with ``--jobs 2``: its assessor in a worker process, the same outputs.

    The bench bag and one whose stamps restart mid-batch (the assessor's restart), read as one
    run, with the plot: message for message, the output bag, the summary and the plot's pixels
    equal an analysis in one process (``analyze_bag(..., jobs=1)``). The worker's error is the
    analysis's; a worker that dies is a ParallelError; nothing is left.
    """
    restarted = tmp_path / 'restarted'
    _restarted(bench, restarted)
    bags = [bench / 'bag', restarted]
    split, whole = tmp_path / 'jobs2', tmp_path / 'jobs1'
    result = subprocess.run(
        [str(GEAR_PHM), 'analyze', *map(str, bags), '--ratio', '3.0', '--motor-joint', 'pdu_l',
         '--load-joint', 'flap_l_out', '--jobs', '2', '--out', str(split), '--no-progress'],
        capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    analyze_bag(bags, 3.0, motor_joint='pdu_l', load_joint='flap_l_out', out=whole, jobs=1)
    from matplotlib.image import imread
    ours, theirs = (imread(str(d / 'analysis.png')) for d in (split, whole))
    assert ours.shape == theirs.shape and ours.shape[0] > 400
    np.testing.assert_allclose(ours, theirs, atol=1e-6)
    ours = json.loads((split / 'summary.json').read_text())
    theirs = json.loads((whole / 'summary.json').read_text())
    for summary in (ours, theirs):
        for key in ('seconds', 'samples_per_second', 'bag'):
            summary.pop(key)
    assert ours['health']['level'] in ('OK', 'WARN', 'ERROR')
    _same_summary(ours, theirs)
    outputs = _outputs(split)
    _same_outputs(outputs, _outputs(whole))
    stamps = [content[0] for topic, _, content in outputs if topic == '/gear_phm/health/rul']
    assert len(stamps) > 1000
    restarts = sum(b < a for a, b in zip(stamps, stamps[1:]))
    assert restarts >= 2, restarts          # at the second bag, and inside it
    folder = tmp_path / 'outs'
    folder.mkdir()
    result = subprocess.run([sys.executable, '-c', SPLIT_FAILING, str(bench / 'bag'),
                             str(folder / 'out')], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    gone = 'a drive worker process ended without answering (killed, or out of memory?)'
    assert result.stdout.splitlines() == [
        'raise AnalysisError the assessor was made to fail', f'die ParallelError {gone}']
    assert not list(folder.iterdir())
