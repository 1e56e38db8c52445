"""The README's commands, run verbatim, so that the README cannot drift from the code.

Every ```bash block under the README headings in SECTIONS is split into commands (one per
line, backslash continuations joined; `&&` parts listed in NOT_RUN are left out, with their
reason). Each runs with ``bash -c`` in a fresh working directory that holds a copy of
``bags/`` and ``config/`` and a ``.venv`` link to the environment running this test, so that
``.venv/bin/...`` is ``Path(sys.executable).parent``. Outputs stay in that directory.

Commands that finish by themselves must exit 0. Node commands, which run until stopped, are
started together, watched until they publish what the README says they do, stopped with
SIGINT as the README says, and must exit 0.

The ``ros2`` lines of "Connect your rig" (```text blocks: ``ros2`` is not installed here) run
through stand-ins (:func:`rig_stand_in`): the same executables with the same arguments.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
import json
import math
import os
from pathlib import Path
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from typing import Any

import pytest

from gear_phm.bagio import BagReader
from helpers.bags import regenerated_differences

REPO = Path(__file__).resolve().parents[2]
README = REPO / 'README.md'
SECTIONS = ('Quick start', 'Live: three nodes over topics', 'Offline',
            'Bench: many drives in one stream')
#: `&&` parts of README commands that are not run, with the reason.
NOT_RUN = {
    'bash .ci/setup': 'creates .venv, in which this test suite already runs',
    '.venv/bin/python -m pytest -q': 'the test suite itself (recursion)',
}
#: Executables that run until stopped (a replay or a simulation without duration).
NODE_COMMANDS = re.compile(r'^\.venv/bin/(publisher|estimator|diagnostics|gear-phm monitor)\b')
ONE_SHOT_TIMEOUT = 300.0
NODE_TIMEOUT = 120.0


def readme_section(title: str) -> str:
    text = README.read_text(encoding='utf-8')
    match = re.search(rf'^## {re.escape(title)}\n(.*?)(?=^## |\Z)', text, re.M | re.S)
    assert match, f'README has no section "## {title}"'
    return match.group(1)


def readme_commands(title: str) -> list[str]:
    """Return the commands of the section's ```bash blocks, in order, without NOT_RUN parts."""
    commands = []
    for block in re.findall(r'^```bash\n(.*?)^```', readme_section(title), re.M | re.S):
        for line in block.replace('\\\n', ' ').splitlines():
            parts = [p.strip() for p in line.split(' && ')]
            kept = [p for p in parts if p and p not in NOT_RUN]
            if kept:
                commands.append(' && '.join(kept))
    return commands


@pytest.fixture
def workdir(tmp_path: Path) -> Path:
    """Make a fresh directory with copies of bags/ and config/ and .venv -> this environment."""
    for name in ('bags', 'config'):
        shutil.copytree(REPO / name, tmp_path / name)
    (tmp_path / '.venv').symlink_to(Path(sys.executable).parent.parent,
                                    target_is_directory=True)
    assert (tmp_path / '.venv' / 'bin' / 'gear-phm').exists()
    return tmp_path


def run_one_shot(command: str, cwd: Path) -> subprocess.CompletedProcess:
    done = subprocess.run(['bash', '-c', command], cwd=cwd, capture_output=True, text=True,
                          timeout=ONE_SHOT_TIMEOUT, env=os.environ.copy())
    assert done.returncode == 0, f'{command}\nexit {done.returncode}\n{done.stderr[-3000:]}'
    return done


# --- what each finishing command must leave behind -------------------------------------------

def check_quick_start_analyze(cwd: Path, done: subprocess.CompletedProcess) -> None:
    """Check the outputs and the health history that the quick start describes."""
    out = cwd / 'out' / 'wearing'
    printed = done.stdout + done.stderr
    assert re.search(r'u = 0\.\d+ \+/- ', printed), printed                  # the final estimate
    assert list(out.glob('*.mcap')) and (out / 'metadata.yaml').is_file()
    assert (out / 'analysis.png').stat().st_size > 20000
    first_seen = json.loads((out / 'summary.json').read_text())['health']['first_seen_ns']
    with BagReader(cwd / 'bags' / 'wearing') as bag:
        start_ns = bag.start_ns
    section = readme_section('Quick start')
    for level, claim in (('WARN', r'then WARN \((\d+) s\)'),
                         ('ERROR', r'then ERROR at end of life \((\d+) s')):
        match = re.search(claim, section)
        assert match, f'the quick start no longer states when {level} comes ({claim})'
        seen = (first_seen[level] - start_ns) * 1e-9
        assert abs(seen - int(match.group(1))) <= 1.0, (level, seen, match.group(1))
    assert first_seen['OK'] < first_seen['WARN'] < first_seen['ERROR']


def check_simulate(cwd: Path, done: subprocess.CompletedProcess) -> None:
    with BagReader(cwd / 'out' / 'run') as bag:
        assert bag.message_count('/joint_states') == 30000          # 300 s at 100 Hz
        assert '/gear_phm/truth/friction' in bag.topics


def check_analyze(cwd: Path, done: subprocess.CompletedProcess) -> None:
    summary = json.loads((cwd / 'out' / 'run-analysis' / 'summary.json').read_text())
    assert summary['messages'] == 30000 and math.isfinite(summary['u'])


def check_evaluate(cwd: Path, done: subprocess.CompletedProcess) -> None:
    assert 'alpha-lambda' in done.stdout + done.stderr
    result = json.loads((cwd / 'out' / 'run-analysis' / 'evaluation.json').read_text())
    # the analysis carries its RUL band and levels: evaluate scores both
    assert result['band_coverage']['predictions'] > 0
    assert [c['from'] for c in result['level_transitions']][:1] == ['OK']
    assert isinstance(result['error_before_eol'], bool)


def check_regenerate(cwd: Path, done: subprocess.CompletedProcess) -> None:
    """Check the in-place rewrite of the sample bags: the committed ones, by content.

    Structure, topics, stamps and strings exactly, floats within 1e-12 (bags/README.md); the
    three samples and every fleet recording and truth.yaml. This is the suite's one run of
    bags/regenerate.sh.
    """
    assert regenerated_differences(cwd / 'bags', REPO / 'bags') == []


#: (pattern of a README command, the check of its results).
def check_simulate_fleet(cwd: Path, done: subprocess.CompletedProcess) -> None:
    units = sorted(p.name for p in (cwd / 'out' / 'fleet').iterdir())
    assert units == ['unit_00', 'unit_01', 'unit_02'], units
    assert len(list((cwd / 'out' / 'fleet' / 'unit_00').glob('rec_*'))) == 4


def _check_fleet_table(out: Path, recordings: int) -> list[str]:
    rows = (out / 'fleet.csv').read_text().splitlines()
    assert rows[0].startswith('unit,recordings,operating_time_s,u,u_sigma,eta_opposing')
    assert len(rows) == 4 and all(f',{recordings},' in row for row in rows[1:]), rows
    assert (out / 'fleet.parquet').is_file() and (out / 'fleet.png').is_file()
    return rows


def check_sample_fleet(cwd: Path, done: subprocess.CompletedProcess) -> None:
    rows = _check_fleet_table(cwd / 'out' / 'fleet-analysis', 5)
    assert all(row.split(',')[0].startswith('unit_0') for row in rows[1:])
    assert not any('FAILED' in row for row in rows)


def check_fleet(cwd: Path, done: subprocess.CompletedProcess) -> None:
    _check_fleet_table(cwd / 'out' / 'my-fleet-analysis', 4)


#: The bench example's drives (config/bench.yaml).
BENCH_DRIVES = ('flap_l', 'spoiler_3', 'rudder')


def check_bench_simulate(cwd: Path, done: subprocess.CompletedProcess) -> None:
    with BagReader(cwd / 'out' / 'bench') as bag:
        assert bag.message_count('/joint_states') == 12000          # 120 s at 100 Hz
        for drive in BENCH_DRIVES:
            assert bag.message_count(f'/gear_phm/{drive}/truth/friction') == 12000


def check_bench_analyze(cwd: Path, done: subprocess.CompletedProcess) -> None:
    """Each drive's u is within 0.01 of its truth; its outputs and plot are there."""
    out = cwd / 'out' / 'bench-analysis'
    summary = json.loads((out / 'summary.json').read_text())
    assert summary['messages'] == 12000
    assert list(summary['transmissions']) == list(BENCH_DRIVES)
    with BagReader(cwd / 'out' / 'bench') as bag:
        truth = {drive: [m.vector.x for _, _, m in bag.messages(
            [f'/gear_phm/{drive}/truth/friction'])][-1] for drive in BENCH_DRIVES}
    with BagReader(out) as bag:
        topics = bag.topics
    for drive in BENCH_DRIVES:
        assert abs(summary['transmissions'][drive]['u'] - truth[drive]) < 0.01, drive
        assert f'/gear_phm/{drive}/friction' in topics
        assert (out / f'analysis_{drive}.png').stat().st_size > 20000
        assert f'{drive}: u = ' in done.stdout


CHECKS: tuple[tuple[str, Callable[[Path, subprocess.CompletedProcess], None]], ...] = (
    (r'^\.venv/bin/gear-phm simulate --transmissions config/bench\.yaml ',
     check_bench_simulate),
    (r'^\.venv/bin/gear-phm analyze out/bench --transmissions ', check_bench_analyze),
    (r'^\.venv/bin/gear-phm analyze bags/wearing .*--out out/wearing', check_quick_start_analyze),
    (r'^\.venv/bin/gear-phm simulate --out out/run ', check_simulate),
    (r'^\.venv/bin/gear-phm analyze out/run ', check_analyze),
    (r'^\.venv/bin/gear-phm evaluate out/run-analysis ', check_evaluate),
    (r'^bash bags/regenerate\.sh\b', check_regenerate),
    (r'^\.venv/bin/gear-phm simulate --fleet ', check_simulate_fleet),
    (r'^\.venv/bin/gear-phm fleet bags/fleet ', check_sample_fleet),
    (r'^\.venv/bin/gear-phm fleet out/fleet ', check_fleet),
)


#: The Offline section's finishing commands fall into independent chains (no chain reads what
#: another writes), each run in its own working directory, in README order within the chain:
#: (name, pattern of its commands); a command belongs to the first chain it matches.
OFFLINE_CHAINS = (
    ('run', r' out/run(-analysis)?(\s|$)'),
    ('regenerate', r'^bash bags/regenerate\.sh\b'),
    ('sample-fleet', r'^\.venv/bin/gear-phm fleet bags/fleet '),
    ('own-fleet', r' out/fleet(\s|$)'),
)


def chain_of(command: str) -> str | None:
    """Return the name of the Offline chain that ``command`` belongs to, if any."""
    return next((name for name, pattern in OFFLINE_CHAINS if re.search(pattern, command)),
                None)


def run_section_one_shots(title: str, cwd: Path, chain: str | None = None) -> list[str]:
    """Run the section's finishing commands in order (of ``chain`` only, if given), checked.

    Return the node commands, which run until stopped.
    """
    nodes = []
    for command in readme_commands(title):
        if NODE_COMMANDS.match(command):
            nodes.append(command)
            continue
        if chain is not None and chain_of(command) != chain:
            continue
        done = run_one_shot(command, cwd)
        for pattern, check in CHECKS:
            if re.search(pattern, command):
                check(cwd, done)
    return nodes


def test_readme_sections_hold_the_documented_commands() -> None:
    """The parser finds what the README shows; each check below matches a README command."""
    commands = {title: readme_commands(title) for title in SECTIONS}
    assert commands['Quick start'] and commands['Offline']
    assert all(not c.startswith('bash .ci/setup') for cs in commands.values() for c in cs)
    every = [c for cs in commands.values() for c in cs]
    for pattern, check in CHECKS:
        assert any(re.search(pattern, c) for c in every), f'{check.__name__}: {pattern}'
    assert sum(bool(NODE_COMMANDS.match(c)) for c in commands['Live: three nodes over topics']) \
        == 4
    # test_offline_commands runs every finishing command of Offline: each is in one chain
    one_shots = [c for c in commands['Offline'] if not NODE_COMMANDS.match(c)]
    assert [c for c in one_shots if chain_of(c) is None] == []
    assert sorted({chain_of(c) for c in one_shots}) == sorted(n for n, _ in OFFLINE_CHAINS)


def test_quick_start_commands(workdir: Path) -> None:
    assert run_section_one_shots('Quick start', workdir) == []


def test_bench_commands(workdir: Path) -> None:
    nodes = run_section_one_shots('Bench: many drives in one stream', workdir)
    assert len(nodes) == 3          # the live bench: test_bench_node_commands


@pytest.mark.parametrize('chain', [name for name, _ in OFFLINE_CHAINS])
def test_offline_commands(workdir: Path, chain: str) -> None:
    nodes = run_section_one_shots('Offline', workdir, chain)
    assert len(nodes) == 1          # the replay publisher: test_offline_node_commands


# --- commands that run until stopped ---------------------------------------------------------

class Seen:
    """What an in-process subscriber received: joint_states count, health status values."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.joint_states = 0
        self.health: list[dict[str, str]] = []
        #: values of the newest status of each name
        self.statuses: dict[str, dict[str, str]] = {}
        self.node: Any = None       # the listening node (its graph)

    def on_joint_state(self, msg: Any) -> None:
        with self.lock:
            self.joint_states += 1

    def on_diagnostics(self, msg: Any) -> None:
        with self.lock:
            self.health += [{kv.key: kv.value for kv in s.values} for s in msg.status
                            if s.name == 'gear_phm: gearbox']
            self.statuses.update({s.name: {kv.key: kv.value for kv in s.values}
                                  for s in msg.status})

    def estimate_reported(self) -> bool:
        with self.lock:
            return any(math.isfinite(float(v.get('u', 'nan'))) for v in self.health)


@contextmanager
def listening() -> Iterator[Seen]:
    """Subscribe to joint_states and /diagnostics in this process (own rclpy context)."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
    from sensor_msgs.msg import JointState

    context = rclpy.Context()
    rclpy.init(args=[], context=context)
    node = rclpy.create_node('readme_commands_listener', context=context)
    seen = Seen()
    seen.node = node
    node.create_subscription(JointState, 'joint_states', seen.on_joint_state,
                             qos_profile_sensor_data)
    node.create_subscription(DiagnosticArray, '/diagnostics', seen.on_diagnostics,
                             QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE))
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    thread = threading.Thread(target=executor.spin, daemon=True)
    thread.start()
    try:
        yield seen
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        thread.join(timeout=5.0)


def run_until_stopped(commands: list[str], cwd: Path, ready: Callable[[], bool],
                      what: str) -> None:
    """Start the commands together, wait for ``ready``, SIGINT them all, expect exit 0."""
    processes = [subprocess.Popen(['bash', '-c', c], cwd=cwd, stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True, env=os.environ.copy(),
                                  start_new_session=True) for c in commands]
    try:
        deadline = time.monotonic() + NODE_TIMEOUT
        while not ready():
            exited = [(c, p.poll()) for c, p in zip(commands, processes) if p.poll() is not None]
            assert not exited, f'exited before {what}: {exited}'
            assert time.monotonic() < deadline, f'no {what} within {NODE_TIMEOUT} s'
            time.sleep(0.1)
        for process in processes:
            os.killpg(process.pid, signal.SIGINT)
        for command, process in zip(commands, processes):
            _, stderr = process.communicate(timeout=60.0)
            assert process.returncode == 0, f'{command}\nexit {process.returncode}\n{stderr}'
    finally:
        for process in processes:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
                process.communicate()


@pytest.mark.integration
def test_offline_node_commands(workdir: Path) -> None:
    """The replay publisher publishes the bag's joint_states (it waits for this subscriber)."""
    commands = [c for c in readme_commands('Offline') if NODE_COMMANDS.match(c)]
    assert [c.split()[0] for c in commands] == ['.venv/bin/publisher']
    with listening() as seen:
        run_until_stopped(commands, workdir, lambda: seen.joint_states >= 100,
                          '100 joint_states messages')


@pytest.mark.integration
def test_bench_node_commands(workdir: Path) -> None:
    """The live bench: each node reports an estimate of every drive, one status each."""
    commands = [c for c in readme_commands('Bench: many drives in one stream')
                if NODE_COMMANDS.match(c)]
    assert [c.split()[0] for c in commands] == ['.venv/bin/publisher', '.venv/bin/estimator',
                                                '.venv/bin/diagnostics']

    def every_drive() -> bool:
        with seen.lock:
            return all(math.isfinite(float(seen.statuses.get(f'{prefix}{drive}', {}).get(
                'u', 'nan'))) for drive in BENCH_DRIVES
                for prefix in ('gear_phm: ', 'gear_phm estimator: '))
    with listening() as seen:
        run_until_stopped(commands, workdir, every_drive, 'an estimate of every drive')


@pytest.mark.integration
def test_live_commands(workdir: Path) -> None:
    """Start the three nodes as the README shows, then gear-phm monitor.

    Each reports an estimate on /diagnostics, stops cleanly on SIGINT, and monitor's
    recording is readable.
    """
    commands = readme_commands('Live: three nodes over topics')
    nodes = [c for c in commands if not c.startswith('.venv/bin/gear-phm monitor')]
    monitor = [c for c in commands if c.startswith('.venv/bin/gear-phm monitor')]
    assert len(nodes) == 3 and len(monitor) == 1
    with listening() as seen:
        run_until_stopped(nodes, workdir, seen.estimate_reported,
                          'estimate on /diagnostics from the three nodes')
    with listening() as seen:
        run_until_stopped(monitor, workdir, seen.estimate_reported,
                          'estimate on /diagnostics from gear-phm monitor')
    record = re.search(r'record_path:=(\S+)', monitor[0])
    assert record, monitor[0]
    with BagReader(workdir / record.group(1)) as bag:
        assert bag.message_count('/diagnostics') >= 1


def rig_recipes() -> list[list[str]]:
    """Return the words of each ``ros2`` line of the README's "Connect your rig"."""
    blocks = re.findall(r'^```text\n(.*?)^```', readme_section('Connect your rig'), re.M | re.S)
    return [line.split() for block in blocks for line in block.splitlines() if line.strip()]


def rig_stand_in(words: list[str]) -> str | None:
    """Return the command this repository runs for a ``ros2`` line (None: ``bag record``).

    ``ros2 run gear_phm X ARGS`` runs the console script X, as ``ros2 run`` does
    (test_launch_files checks that it is installed where ``ros2 run`` looks); ``ros2 bag play
    BAG --clock`` is the publisher's replay with ``publish_clock`` (the bag's joint_states and
    /clock); ``ros2 bag record`` cannot run here (no rosbag2): its topics are checked in the
    graph instead.
    """
    if words[:3] == ['ros2', 'run', 'gear_phm']:
        return ' '.join([f'.venv/bin/{words[3]}', *words[4:]])
    if words[:3] == ['ros2', 'bag', 'play'] and words[4:] == ['--clock']:
        return (f'.venv/bin/publisher --ros-args -p mode:=replay -p bag_path:={words[3]} '
                '-p publish_clock:=true')
    assert words[:3] == ['ros2', 'bag', 'record'] and words[3] == '-o', words
    return None


@pytest.mark.integration
def test_connect_your_rig_recipes(workdir: Path) -> None:
    """Play a bag with --clock to the nodes on use_sim_time; check what bag record records.

    The nodes report an estimate on /diagnostics; every topic of the ``bag record`` line is
    in the graph then, and the diagnostics node's recording is readable after SIGINT.
    """
    recipes = rig_recipes()
    commands = [c for c in map(rig_stand_in, recipes) if c is not None]
    [record] = [words[5:] for words in recipes if words[:3] == ['ros2', 'bag', 'record']]
    assert len(commands) == 3 and all('use_sim_time:=true' in c for c in commands[1:])
    with listening() as seen:
        def ready() -> bool:
            names = {name for name, _ in seen.node.get_topic_names_and_types()}
            return seen.estimate_reported() and set(record) <= names
        run_until_stopped(commands, workdir, ready, 'an estimate and every recorded topic')
    path = re.search(r'record_path:=(\S+)', commands[2])
    assert path, commands[2]
    with BagReader(workdir / path.group(1)) as bag:
        assert bag.message_count('/diagnostics') >= 1
