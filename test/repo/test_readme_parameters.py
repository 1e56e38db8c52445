"""The parameter tables (docs/parameters.md) and config/*.yaml against the nodes' own declarations.

docs/generate_parameter_tables.py constructs each node class in its own process (no graph)
and reads the declarations back through rclpy's public API.
"""
from __future__ import annotations

import json
from pathlib import Path
import re
import subprocess
import sys
from typing import Any

import pytest
import yaml

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / 'docs' / 'generate_parameter_tables.py'
NODES = ('publisher', 'estimator', 'diagnostics')


def generator(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True,
                          timeout=120, cwd=REPO)


@pytest.fixture(scope='module')
def declarations() -> dict[str, list[dict[str, Any]]]:
    done = generator('--json')
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def test_declarations_are_read_from_every_node(declarations: dict) -> None:
    assert tuple(declarations) == NODES
    names = {node: {row['name'] for row in rows} for node, rows in declarations.items()}
    assert {'mode', 'bag_path', 'wear', 'rate'} <= names['publisher']
    assert {'ratio', 'process_noise', 'window'} <= names['estimator']
    assert {'ratio', 'eta_opposing_min', 'record_path'} <= names['diagnostics']
    assert not any('use_sim_time' in n for n in names.values())       # rclpy's own
    ratio = next(r for r in declarations['estimator'] if r['name'] == 'ratio')
    assert ratio['default'] == 3.0 and ratio['low'] > 0.0 and ratio['text']


def test_readme_parameter_tables_are_current() -> None:
    done = generator('--check')
    assert done.returncode == 0, done.stdout + done.stderr


def test_check_names_a_stale_row(tmp_path: Path) -> None:
    readme = tmp_path / 'parameters.md'
    text = (REPO / 'docs' / 'parameters.md').read_text(encoding='utf-8')
    stale, count = re.subn(r'^\| `process_noise` \| `[^`]*` ', '| `process_noise` | `1e-99` ',
                           text, flags=re.M)
    assert count == 1
    readme.write_text(stale, encoding='utf-8')
    done = generator('--check', '--readme', str(readme))
    assert done.returncode == 1
    assert '1e-99' in done.stdout and 'stale' in done.stderr
    assert readme.read_text(encoding='utf-8') == stale                    # --check writes nothing
    assert generator('--readme', str(readme)).returncode == 0             # regenerates
    assert readme.read_text(encoding='utf-8') == text


def documented_keys(path: Path, node: str) -> tuple[dict[str, Any], set[str]]:
    """Return (the node's ros__parameters, the keys whose line has or follows a comment)."""
    values = yaml.safe_load(path.read_text(encoding='utf-8'))[node]['ros__parameters']
    commented, previous_is_comment = set(), False
    for line in path.read_text(encoding='utf-8').splitlines():
        key = re.match(r'^\s+(\w+):(.*)$', line)
        if key:
            rest = re.sub(r"'[^']*'|\"[^\"]*\"", '', key.group(2))      # '#' inside a string
            if '#' in rest or previous_is_comment:
                commented.add(key.group(1))
        previous_is_comment = line.lstrip().startswith('#')
    return values, commented


@pytest.mark.parametrize('node', NODES)
def test_config_file_documents_every_declared_parameter(declarations: dict, node: str) -> None:
    """Check that config/<node>.yaml lists each declared parameter, with a comment.

    Each is given as a value the node accepts (a double written as a double).
    """
    values, commented = documented_keys(REPO / 'config' / f'{node}.yaml', node)
    declared = {row['name']: row['default'] for row in declarations[node]}
    assert sorted(set(declared) - set(values)) == []
    assert sorted(set(values) - set(declared)) == []                  # no unknown keys
    assert sorted(set(declared) - commented) == []
    for name, default in declared.items():
        assert type(values[name]) is type(default), (name, values[name], default)


def test_readme_lists_exactly_the_diagnostics_keys_and_explains_the_new_ones() -> None:
    """The /diagnostics paragraph of docs/usage.md names STATUS_KEYS in order.

    The time-base keys have a bullet each.
    """
    from gear_phm.interfaces import STATUS_KEYS
    text = (REPO / 'docs' / 'usage.md').read_text(encoding='utf-8')
    start = text.index('Its KeyValue keys are exactly:')
    sentence = text[start:text.index('. Numbers', start)]
    assert tuple(re.findall(r'`(\w+)`', sentence)) == STATUS_KEYS
    for key in ('operating_time_s', 'rul_operating_s', 'rul_s', 'utilisation'):
        assert re.search(rf'^- `{key}`', text, flags=re.M), key
