"""config/foxglove_layout.json plots topics that an analysis output holds.

``gear-phm analyze`` on bags/wearing (no plot), then every topic of the layout (its plots,
its user script's inputs, its Diagnostics panels) is in the output MCAP with the type the
layout reads, and the status the status panel selects is there under that hardware_id.
"""
from __future__ import annotations

import json
from pathlib import Path
import re
from typing import Any

import pytest

from gear_phm.bagio import BagReader
from gear_phm.cli.main import main
from gear_phm.interfaces import DIAGNOSTIC_ARRAY_TYPE, VECTOR3_STAMPED_TYPE

REPO = Path(__file__).resolve().parents[2]
LAYOUT = REPO / 'config' / 'foxglove_layout.json'
SCRIPT_PREFIX = '/studio_script/'


def _panels(node: Any) -> list[str]:
    """Return the panel ids a mosaic layout places."""
    if isinstance(node, str):
        return [node]
    return _panels(node['first']) + _panels(node['second'])


@pytest.fixture(scope='module')
def analysis(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp('layout') / 'out'
    assert main(['analyze', str(REPO / 'bags' / 'wearing'), '--ratio', '3.0', '--out',
                 str(out), '--no-progress', '--no-plot', '--eta-opposing-min', '0.7333',
                 '--warn-horizon', '0.0']) == 0
    return out


def test_layout_topics_are_in_the_analysis_output(analysis: Path) -> None:
    layout = json.loads(LAYOUT.read_text(encoding='utf-8'))
    panels = layout['configById']
    assert sorted(_panels(layout['layout'])) == sorted(panels)
    scripts = [node['sourceCode'] for node in layout['userNodes'].values()]
    script_inputs = {topic for code in scripts for topic in re.findall(
        r'"([^"]+)"', re.search(r'export const inputs = \[(.*?)\]', code).group(1))}
    script_outputs = {re.search(r'export const output = "([^"]+)"', code).group(1)
                      for code in scripts}
    plotted = {path['value'] for name, config in panels.items() if name.startswith('Plot!')
               for path in config['paths']}
    with BagReader(analysis) as bag:
        topics = bag.topics
        arrays = [m for _, _, m in bag.messages(['/diagnostics'])]
    vectors = set(script_inputs)
    for path in plotted:
        topic, field = path.split('.', 1)
        if topic.startswith(SCRIPT_PREFIX):
            assert topic in script_outputs and field in ('u', 'low', 'high'), path
        else:
            assert re.fullmatch(r'vector\.[xyz]', field), path
            vectors.add(topic)
    for topic in vectors:
        assert topics.get(topic) == VECTOR3_STAMPED_TYPE, (topic, sorted(topics))
    assert {'/gear_phm/friction', '/gear_phm/efficiency', '/gear_phm/health/rul'} <= vectors
    diagnostics = {config['topicToRender'] for name, config in panels.items()
                   if name.startswith('Diagnostic')}
    assert diagnostics == {'/diagnostics'} and topics['/diagnostics'] == DIAGNOSTIC_ARRAY_TYPE
    status = panels['DiagnosticStatusPanel!gear_phm']
    named = {(s.name, s.hardware_id) for array in arrays for s in array.status}
    assert (status['selectedName'], status['selectedHardwareId']) in named, named
