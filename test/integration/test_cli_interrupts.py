"""CLI outputs are whole or absent: a failed, interrupted or terminated run leaves nothing.

``gear-phm simulate`` and ``analyze`` write into a hidden staging folder beside ``--out`` and
rename it into place once complete; an error, Ctrl-C (SIGINT, exit 130) or SIGTERM (exit 143)
removes it.
"""
from __future__ import annotations

import functools
from pathlib import Path
import signal
import sys
import time
from typing import Any

import pytest

from gear_phm import stopping
from gear_phm.cli.main import main as gear_phm
from gear_phm.simulation import recording
from helpers.processes import signalled_when, signalled_when_staged

GEAR_PHM = Path(sys.executable).parent / 'gear-phm'


def test_a_run_too_large_for_the_disk_is_refused_early_and_leaves_nothing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # 2e14 samples (until 2033 at 100 kHz): petabytes on any disk; refused once the first
    # megabytes project that
    started = time.monotonic()
    assert gear_phm(['simulate', '--out', str(tmp_path / 'x'), '--duration', '2e9',
                     '--rate', '1e5']) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith('gear-phm simulate: error: cannot write') \
        and '200,000,000,000,000 samples would take about' in lines[0] \
        and 'GB are free' in lines[0], lines
    assert list(tmp_path.iterdir()) == []                  # no bag, no staging folder
    assert time.monotonic() - started < 60.0                # not after filling the disk


def test_a_write_failing_midway_leaves_no_half_written_bag(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    write_chunk = recording.write_chunk
    chunks = []

    def failing(*args: Any) -> None:
        chunks.append(1)
        if len(chunks) == 3:
            raise OSError(28, 'No space left on device')
        write_chunk(*args)
    monkeypatch.setattr(recording, 'write_chunk', failing)
    (tmp_path / 'x').mkdir()                                # an empty --out is allowed
    assert gear_phm(['simulate', '--out', str(tmp_path / 'x'), '--duration', '700']) == 2
    assert len(chunks) == 3                                 # two chunks were written
    assert 'cannot write' in capsys.readouterr().err
    assert [p.name for p in tmp_path.iterdir()] == ['x']    # the empty --out, as it was
    assert list((tmp_path / 'x').iterdir()) == []


@pytest.fixture(scope='module')
def long_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """300,000 samples at 1 kHz: a few seconds of analysis."""
    out = tmp_path_factory.mktemp('interrupts') / 'bag'
    assert gear_phm(['simulate', '--out', str(out), '--duration', '300', '--rate', '1000',
                     '--seed', '3']) == 0
    return out


@pytest.mark.parametrize('command, signum, code, word', [
    ('analyze', signal.SIGINT, 130, 'interrupted'),
    ('analyze', signal.SIGTERM, 143, 'terminated'),
    ('simulate', signal.SIGTERM, 143, 'terminated'),
])
def test_a_stopped_run_exits_with_the_signal_and_leaves_nothing(
        long_bag: Path, tmp_path: Path, command: str, signum: int, code: int,
        word: str) -> None:
    out = tmp_path / 'out'
    args = (['analyze', str(long_bag), '--ratio', '3.0', '--out', str(out), '--no-progress']
            if command == 'analyze' else
            ['simulate', '--out', str(out), '--duration', '20000', '--rate', '1000'])
    done = signalled_when_staged([str(GEAR_PHM), *args], tmp_path, signum)
    assert done.returncode == code, done.stderr
    assert done.stderr.strip().splitlines() == [f'gear-phm {command}: {word}']
    assert list(tmp_path.iterdir()) == []
    deadline = time.monotonic() + 10.0           # analyze's plot process ended with it
    while _running_with(str(out)):
        assert time.monotonic() < deadline, _running_with(str(out))
        time.sleep(0.05)


def test_a_recorded_stop_is_raised_at_the_next_chunk_or_batch(
        long_bag: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """The stop a signal recorded is raised again by the loops.

    A handler's exception swallowed where it landed (an import) let simulate run to its end
    and exit 0 under load.
    """
    monkeypatch.setattr(stopping, '_requested', [functools.partial(SystemExit, 143)])
    with pytest.raises(SystemExit) as caught:
        gear_phm(['simulate', '--out', str(tmp_path / 'sim'), '--duration', '60'])
    assert caught.value.code == 143
    monkeypatch.setattr(stopping, '_requested', [KeyboardInterrupt])
    assert gear_phm(['analyze', str(long_bag), '--ratio', '3.0', '--out', str(tmp_path / 'an'),
                     '--no-progress']) == 130
    assert capsys.readouterr().err.strip().splitlines() == ['gear-phm analyze: interrupted']
    assert list(tmp_path.iterdir()) == []


def test_a_stop_while_the_staging_folder_is_made_leaves_nothing(
        long_bag: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """A signal landing just after the staging folder exists, before its caller holds it.

    The folder was left behind (a CI run: SIGINT sent as soon as the folder appeared).
    """
    make = Path.mkdir

    def signalled(self: Path, *args: Any, **kwargs: Any) -> None:
        make(self, *args, **kwargs)
        if self.name.startswith('.an.'):
            raise KeyboardInterrupt                     # as gear-phm's SIGINT handler does
    monkeypatch.setattr(Path, 'mkdir', signalled)
    assert gear_phm(['analyze', str(long_bag), '--ratio', '3.0', '--out', str(tmp_path / 'an'),
                     '--no-progress']) == 130
    assert capsys.readouterr().err.strip().splitlines() == ['gear-phm analyze: interrupted']
    assert list(tmp_path.iterdir()) == []


def _children(pid: int) -> list[int]:
    """Return the processes whose parent is ``pid`` (from /proc)."""
    found = []
    for stat in Path('/proc').glob('[0-9]*/stat'):
        try:
            fields = stat.read_text().rsplit(')', 1)[1].split()
        except (OSError, IndexError):
            continue                            # ended meanwhile
        if int(fields[1]) == pid:
            found.append(int(stat.parent.name))
    return found


def _running_with(text: str) -> list[int]:
    """Return the processes whose command line holds ``text``."""
    found = []
    for cmdline in Path('/proc').glob('[0-9]*/cmdline'):
        try:
            if text.encode() in cmdline.read_bytes():
                found.append(int(cmdline.parent.name))
        except OSError:
            continue
    return found


@pytest.mark.skipif(not Path('/proc/self/stat').exists(), reason='reads /proc')
def test_an_interrupted_many_drive_run_ends_its_workers_and_leaves_nothing(
        tmp_path: Path) -> None:
    """SIGINT to ``gear-phm analyze --transmissions --jobs 2`` once both workers run.

    Exit 130 with the one line, no output, and no worker left (a forked worker carries its
    parent's command line, which names the unique output folder). The same for SIGTERM to
    one drive's run, its assessor in a worker (exit 143).
    """
    import yaml
    spec = tmp_path / 'bench.yaml'
    spec.write_text(yaml.safe_dump({'transmissions': {
        f'd{i}': {'motor_joint': f'm{i}', 'load_joint': f'l{i}', 'ratio': 3.0 + i,
                  'simulation': {'wear': 'linear', 'friction_initial': 0.05,
                                 'wear_rate': 1e-4}} for i in range(3)}}))
    assert gear_phm(['simulate', '--transmissions', str(spec), '--duration', '120', '--rate',
                     '1000', '--out', str(tmp_path / 'bag')]) == 0
    folder = tmp_path / 'outs'
    folder.mkdir()
    out = folder / 'interrupted_many_drives'
    done = signalled_when(
        [str(GEAR_PHM), 'analyze', str(tmp_path / 'bag'), '--transmissions', str(spec),
         '--jobs', '2', '--out', str(out), '--no-progress', '--no-plot'],
        lambda child: len(_children(child.pid)) >= 2, 'both workers forked', signal.SIGINT)
    assert done.returncode == 130, done.stderr
    assert done.stderr.strip().splitlines() == ['gear-phm analyze: interrupted']
    assert list(folder.iterdir()) == []
    _ended(out)
    # one drive of it, its assessor in a worker beside the plot process: SIGTERM
    out = folder / 'terminated_one_drive'
    done = signalled_when(
        [str(GEAR_PHM), 'analyze', str(tmp_path / 'bag'), '--ratio', '3.0', '--motor-joint',
         'm0', '--load-joint', 'l0', '--jobs', '2', '--out', str(out), '--no-progress'],
        lambda child: len(_children(child.pid)) >= 2, 'assessor and plot process forked',
        signal.SIGTERM)
    assert done.returncode == 128 + signal.SIGTERM, done.stderr
    assert done.stderr.strip().splitlines() == ['gear-phm analyze: terminated']
    assert list(folder.iterdir()) == []
    _ended(out)


def _ended(out: Path) -> None:
    """Wait until no process holds ``out`` in its command line (forked workers do)."""
    deadline = time.monotonic() + 10.0           # the workers end with their pipes
    while _running_with(str(out)):
        assert time.monotonic() < deadline, _running_with(str(out))
        time.sleep(0.05)


def test_a_recorded_stop_is_raised_at_the_commit_and_nothing_is_committed(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A stop swallowed after the last loop's check: the commit raises it.

    A fleet's SIGTERM landed in an import's callback (a full-suite run): the fleet then ran to
    its end, committed its output and exited 0.
    """
    from gear_phm.staging import Staged
    target = tmp_path / 'out'
    with pytest.raises(SystemExit) as caught:
        with Staged(target, OSError, folder=True) as staged:
            (staged.path / 'summary.json').write_text('{}')
            monkeypatch.setattr(stopping, '_requested', [functools.partial(SystemExit, 143)])
            staged.commit()
    assert caught.value.code == 143
    assert list(tmp_path.iterdir()) == []


def test_a_swallowed_recorded_stop_is_not_printed_other_unraisables_are(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The CLI's unraisable hook: a handler's stop swallowed in a callback prints nothing.

    It is raised again later, and the user sees the one line of the stop; before, 'Exception
    ignored in ...' and a traceback came with it.
    """
    from types import SimpleNamespace
    from gear_phm.cli.main import quiet_stop
    seen: list[object] = []
    hook = quiet_stop(seen.append)
    stop = SimpleNamespace(exc_value=SystemExit(143))
    hook(stop)
    assert seen == [stop]                       # no stop recorded: not ours
    monkeypatch.setattr(stopping, '_requested', [functools.partial(SystemExit, 143)])
    hook(stop)
    hook(SimpleNamespace(exc_value=KeyboardInterrupt()))
    other = SimpleNamespace(exc_value=ValueError('a finalizer failed'))
    hook(other)
    assert seen == [stop, other]
