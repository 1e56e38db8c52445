"""config/analyzers.yaml (diagnostic_aggregator) against the status names gear_phm publishes.

The names are read from real outputs: the /diagnostics that ``gear-phm analyze`` writes (the
nodes' code, one drive and a bench of three) and those of a running publisher node. Every
name must be matched by exactly one analyzer, and every analyzer must match some name.
Matching is diagnostic_aggregator's GenericAnalyzer::match (ros/diagnostics, ros2 branch):
``regex`` (std::regex_match: the whole name), ``expected`` and ``name`` (equal),
``startswith`` and ``find_and_remove_prefix`` (a prefix), ``contains`` (a part).
"""
from __future__ import annotations

from pathlib import Path
import re
import time

import pytest
import yaml

from gear_phm.bagio import BagReader
from gear_phm.cli.main import main

REPO = Path(__file__).resolve().parents[2]
ANALYZERS = REPO / 'config' / 'analyzers.yaml'
#: GenericAnalyzer's parameters (generic_analyzer.cpp).
GENERIC_KEYS = {'type', 'path', 'find_and_remove_prefix', 'remove_prefix', 'startswith',
                'contains', 'expected', 'name', 'regex', 'timeout', 'num_items',
                'discard_stale'}
GENERIC = 'diagnostic_aggregator/GenericAnalyzer'


def _analyzers() -> dict[str, dict]:
    document = yaml.safe_load(ANALYZERS.read_text(encoding='utf-8'))
    # The aggregator node is named `analyzers` (diagnostic_aggregator/src/aggregator.cpp).
    assert list(document) == ['analyzers']
    parameters = document['analyzers']['ros__parameters']
    assert isinstance(parameters['path'], str) and isinstance(parameters['pub_rate'], float)
    return {k: v for k, v in parameters.items() if isinstance(v, dict)}


def _matches(analyzer: dict, name: str) -> bool:
    """GenericAnalyzer::match."""
    if any(re.fullmatch(pattern, name) for pattern in analyzer.get('regex', [])):
        return True
    if name in analyzer.get('expected', []) or name in analyzer.get('name', []):
        return True
    prefixes = [*analyzer.get('startswith', []), *analyzer.get('find_and_remove_prefix', [])]
    if any(name.startswith(prefix) for prefix in prefixes):
        return True
    return any(part in name for part in analyzer.get('contains', []))


def _status_names(out: Path) -> set[str]:
    with BagReader(out) as bag:
        return {s.name for _, _, m in bag.messages(['/diagnostics']) for s in m.status}


@pytest.fixture(scope='module')
def analysis_names(tmp_path_factory: pytest.TempPathFactory) -> set[str]:
    """Return the status names of gear-phm analyze on bags/healthy and a simulated bench."""
    root = tmp_path_factory.mktemp('analyzers')
    single = root / 'single'
    assert main(['analyze', str(REPO / 'bags' / 'healthy'), '--ratio', '3.0', '--out',
                 str(single), '--no-plot', '--no-progress']) == 0
    bench_bag, bench = root / 'bench_bag', root / 'bench'
    transmissions = str(REPO / 'config' / 'bench.yaml')
    assert main(['simulate', '--transmissions', transmissions, '--out', str(bench_bag),
                 '--duration', '20', '--seed', '1']) == 0
    assert main(['analyze', str(bench_bag), '--transmissions', transmissions, '--out',
                 str(bench), '--no-plot', '--no-progress']) == 0
    single_names, bench_names = _status_names(single), _status_names(bench)
    assert single_names == {'gear_phm: gearbox', 'gear_phm estimator: estimator'}
    assert bench_names == {f'gear_phm{kind}: {drive}' for kind in ('', ' estimator')
                           for drive in ('flap_l', 'spoiler_3', 'rudder')}
    return single_names | bench_names


def test_every_analyzer_is_a_generic_analyzer_with_known_keys() -> None:
    analyzers = _analyzers()
    assert set(analyzers) == {'health', 'estimator', 'publisher'}
    for name, analyzer in analyzers.items():
        assert analyzer['type'] == GENERIC, name
        assert set(analyzer) <= GENERIC_KEYS, (name, set(analyzer) - GENERIC_KEYS)
        assert isinstance(analyzer['path'], str) and analyzer['path'], name


def test_every_analysis_status_name_is_matched_by_exactly_one_analyzer(
        analysis_names: set[str]) -> None:
    analyzers = _analyzers()
    found = {name: [a for a, analyzer in analyzers.items() if _matches(analyzer, name)]
             for name in sorted(analysis_names)}
    assert found == {name: ['estimator' if 'estimator' in name else 'health']
                     for name in sorted(analysis_names)}


def test_a_name_of_no_gear_phm_node_is_left_to_other() -> None:
    analyzers = _analyzers()
    for name in ('motor_driver: temperature', 'gear_phmX: a', 'joint_state_broadcaster'):
        assert not any(_matches(a, name) for a in analyzers.values()), name


@pytest.mark.integration
def test_the_running_publisher_s_status_is_matched_by_the_publisher_analyzer() -> None:
    pytest.importorskip('rclpy')
    from helpers.live import Driver
    from helpers.processes import spawn, stop

    driver = Driver('analyzers_probe', outputs=())
    names: set[str] = set()
    driver.on_diagnostics.append(lambda msg: names.update(s.name for s in msg.status))
    publisher = spawn('publisher', 'duration:=30.0', 'wait_for_subscribers:=0')
    try:
        deadline = time.monotonic() + 60.0
        driver.wait(lambda: any(n.startswith('gear_phm publisher') for n in names)
                    or publisher.poll() is not None or time.monotonic() > deadline,
                    70.0, 'a publisher status on /diagnostics')
    finally:
        code = stop(publisher)
        stderr = publisher.stderr.read() if publisher.stderr else ''
        driver.close()
    assert code == 0, stderr
    ours = sorted(n for n in names if n.startswith('gear_phm'))
    assert ours == ['gear_phm publisher: publisher'], (ours, stderr)
    analyzers = _analyzers()
    assert [a for a, analyzer in analyzers.items() if _matches(analyzer, ours[0])] \
        == ['publisher']
