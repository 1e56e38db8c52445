"""`colcon build` and `colcon test` of the package in a throw-away workspace.

The installed CLI must start, the launch and config files must be installed, and
`colcon test` must pass on a quick selection of the suite (:data:`COLCON_TEST_SELECTION`:
not the whole suite again, and not this module, which would build again within itself),
checked with `colcon test-result`.
"""
from __future__ import annotations

import os
from pathlib import Path
import re
import shutil
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

import pytest

from helpers.shared import build_once

REPO = Path(__file__).resolve().parents[2]
VENV_BIN = Path(sys.executable).parent
EXECUTABLES = ('publisher', 'estimator', 'diagnostics', 'gear-phm')
TOP_LEVEL_NOT_SOURCES = {'.venv', '.git', 'build', 'install', 'log', 'bags', 'out',
                         '.hypothesis', '.pytest_cache', '.mypy_cache'}
ANYWHERE_NOT_SOURCES = shutil.ignore_patterns('__pycache__', '*.egg-info')
#: What `colcon test` runs: static, fast modules (no DDS, no bags: the copy has none).
COLCON_TEST_SELECTION = ('test/repo/test_package_xml.py', 'test/repo/test_launch_files.py')


def _not_sources(directory: str, names: list[str]) -> set[str]:
    ignored = set(ANYWHERE_NOT_SOURCES(directory, names))
    if Path(directory) == REPO:
        ignored |= TOP_LEVEL_NOT_SOURCES.intersection(names)
    return ignored


@pytest.fixture(scope='module')
def workspace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Copy of the repo in <ws>/src/gear_phm, built with colcon from the venv.

    A copy, so egg-info never lands in the repo. Built once per test run
    (helpers.shared.build_once), however many workers ask.
    """
    return build_once(tmp_path_factory, 'colcon_ws', _build)


def _colcon_env(root: Path) -> dict[str, str]:
    """Return this environment, the venv first on PATH, without pytest's own variables."""
    env = {k: v for k, v in os.environ.items() if not k.startswith('PYTEST_')}
    env['PATH'] = f'{VENV_BIN}{os.pathsep}{os.environ.get("PATH", "")}'
    env['COLCON_LOG_PATH'] = str(root / 'log')
    return env


def _build(root: Path) -> None:
    shutil.copytree(REPO, root / 'src' / 'gear_phm', ignore=_not_sources)
    started = time.monotonic()
    result = subprocess.run(
        [str(VENV_BIN / 'colcon'), 'build', '--base-paths', 'src', '--build-base', 'build',
         '--install-base', 'install', '--event-handlers', 'console_direct-'],
        cwd=root, env=_colcon_env(root), capture_output=True, text=True, timeout=240)
    elapsed = time.monotonic() - started
    print(f'colcon build took {elapsed:.1f} s')
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'Summary: 1 package finished' in result.stdout


def _site_packages(install: Path) -> Path:
    found = sorted((install / 'lib').glob('python3*/site-packages'))
    assert len(found) == 1, found
    return found[0]


@pytest.mark.integration
def test_install_space_layout(workspace: Path) -> None:
    install = workspace / 'install' / 'gear_phm'
    for name in EXECUTABLES:
        script = install / 'lib' / 'gear_phm' / name
        assert script.is_file(), script
        assert os.access(script, os.X_OK), script
    assert (install / 'share' / 'ament_index' / 'resource_index' / 'packages'
            / 'gear_phm').is_file()
    assert (install / 'share' / 'gear_phm' / 'package.xml').read_text() == \
        (REPO / 'package.xml').read_text()
    share = install / 'share' / 'gear_phm'
    for name in ('gear_phm.launch.py', 'bench.launch.py'):
        assert (share / 'launch' / name).read_text() == (REPO / 'launch' / name).read_text()
    assert sorted(p.name for p in (share / 'config').glob('*.yaml')) == \
        sorted(p.name for p in (REPO / 'config').glob('*.yaml'))
    assert (share / 'config' / 'analyzers.yaml').is_file()
    package = _site_packages(install) / 'gear_phm'
    for module in ('models/lever.py', 'models/spur_gear.py', 'cli/main.py', 'cli/paper.py',
                   'paper/reproduce.py'):
        assert (package / module).is_file(), module
    assert not list(package.rglob('test_*.py'))


@pytest.mark.integration
def test_installed_cli_starts_from_the_install_space(workspace: Path) -> None:
    install = workspace / 'install' / 'gear_phm'
    site = _site_packages(install)
    env = dict(os.environ, PYTHONPATH=f'{site}{os.pathsep}{os.environ.get("PYTHONPATH", "")}')
    result = subprocess.run([str(install / 'lib' / 'gear_phm' / 'gear-phm'), '--help'],
                            env=env, capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith('usage: gear-phm')
    assert 'paper' in result.stdout
    # The installed copy is the one imported, not the working tree.
    where = subprocess.run([sys.executable, '-c', 'import gear_phm; print(gear_phm.__file__)'],
                           env=env, cwd=workspace, capture_output=True, text=True, timeout=60)
    assert where.returncode == 0, where.stderr
    assert Path(where.stdout.strip()).is_relative_to(site)


@pytest.mark.integration
@pytest.mark.long(20)                   # the build (fixture), then colcon test's own pytest
def test_colcon_test_passes_and_test_result_reads_it(workspace: Path) -> None:
    """`colcon test` with setup.cfg's pytest configuration (xdist, timeout) on a selection."""
    env = _colcon_env(workspace)
    started = time.monotonic()
    tested = subprocess.run(
        [str(VENV_BIN / 'colcon'), 'test', '--base-paths', 'src', '--build-base', 'build',
         '--install-base', 'install', '--packages-select', 'gear_phm',
         '--event-handlers', 'console_direct-', '--return-code-on-test-failure',
         '--pytest-args', *COLCON_TEST_SELECTION, '-n', '0'],
        cwd=workspace, env=env, capture_output=True, text=True, timeout=240)
    print(f'colcon test took {time.monotonic() - started:.1f} s')
    assert tested.returncode == 0, tested.stdout + tested.stderr
    assert 'Summary: 1 package finished' in tested.stdout
    report = ET.parse(workspace / 'build' / 'gear_phm' / 'pytest.xml').getroot()
    cases = report.findall('.//testcase')
    modules = {c.get('classname', '') for c in cases}        # --junit-prefix=gear_phm
    assert modules == {'gear_phm.' + m.removesuffix('.py').replace('/', '.')
                       for m in COLCON_TEST_SELECTION}
    failed = [c.get('name') for c in cases if c.find('failure') is not None
              or c.find('error') is not None]
    assert not failed and len(cases) >= 10, (failed, len(cases))
    result = subprocess.run(
        [str(VENV_BIN / 'colcon'), 'test-result', '--test-result-base', 'build', '--all'],
        cwd=workspace, env=env, capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stdout + result.stderr
    summary = re.search(r'Summary: (\d+) tests, (\d+) errors, (\d+) failures, (\d+) skipped',
                        result.stdout)
    assert summary, result.stdout
    total, errors, failures, skipped = map(int, summary.groups())
    assert (total, errors, failures) == (len(cases), 0, 0)
