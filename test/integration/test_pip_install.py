"""A plain `pip install .` into a fresh venv (no .ci/setup, no ROS) runs `gear-phm analyze`.

setup.py must declare every runtime dependency of the offline CLI; rclpy is not one of them.
The versions are constrained to .ci/requirements.txt so that pip's cache serves them.
"""
from __future__ import annotations

import json
import os
from pathlib import Path
import shutil
import subprocess
import sys

import pytest

from helpers.shared import build_once

REPO = Path(__file__).resolve().parents[2]
BAG = REPO / 'bags' / 'wearing'
NOT_SOURCES = {'.venv', '.git', 'build', 'install', 'log', 'bags', 'out', '.hypothesis',
               '.pytest_cache', '.mypy_cache', '__pycache__'}


def _clean_env() -> dict[str, str]:
    """Environment without this checkout or the project venv on the import path."""
    env = {key: value for key, value in os.environ.items()
           if key not in ('PYTHONPATH', 'PYTHONHOME', 'VIRTUAL_ENV')}
    env['PYTHONNOUSERSITE'] = '1'            # no ~/.local packages standing in for a dep
    return env


def _ignore(directory: str, names: list[str]) -> set[str]:
    return {name for name in names if name in NOT_SOURCES or name.endswith('.egg-info')}


@pytest.fixture(scope='module')
def fresh_venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Venv (without system site-packages) holding gear_phm from `pip install <copy>`.

    Made once per test run (helpers.shared.build_once), however many workers ask.
    """
    return build_once(tmp_path_factory, 'pip_install', _make_venv) / 'venv'


def _make_venv(root: Path) -> None:
    source = root / 'gear_phm_src'           # a copy: pip's in-tree build writes build/
    shutil.copytree(REPO, source, ignore=_ignore)
    venv = root / 'venv'
    env = _clean_env()
    # No pip in the venv (ensurepip cost 3.5 s of CPU and its pip 4 s more than this one):
    # this environment's pip installs into it with --python, running under its interpreter.
    subprocess.run([sys.executable, '-m', 'venv', '--without-pip', str(venv)], check=True,
                   env=env, timeout=300)
    result = subprocess.run(
        [sys.executable, '-m', 'pip', '--python', str(venv / 'bin' / 'python'), 'install',
         '--quiet', '--no-compile', '--disable-pip-version-check',
         '-c', str(REPO / '.ci' / 'requirements.txt'), str(source)],
        capture_output=True, text=True, env=env, timeout=900)
    assert result.returncode == 0, result.stdout + result.stderr


@pytest.mark.long(40)                 # builds the venv (fixture)
def test_fresh_venv_has_no_ros(fresh_venv: Path) -> None:
    config = (fresh_venv / 'pyvenv.cfg').read_text()
    assert 'include-system-site-packages = false' in config
    result = subprocess.run([str(fresh_venv / 'bin' / 'python'), '-c', 'import rclpy'],
                            capture_output=True, text=True, env=_clean_env(), timeout=60)
    assert result.returncode != 0 and 'rclpy' in result.stderr


def test_pip_installed_cli_analyzes_a_sample_bag(fresh_venv: Path, tmp_path: Path) -> None:
    out = tmp_path / 'analysis'
    result = subprocess.run(
        [str(fresh_venv / 'bin' / 'gear-phm'), 'analyze', str(BAG), '--ratio', '3.0',
         '--out', str(out)],                   # progress bar and plot on: tqdm, matplotlib
        cwd=tmp_path, capture_output=True, text=True, env=_clean_env(), timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    summary = json.loads((out / 'summary.json').read_text())
    assert summary['samples_seen'] == 30000
    assert summary['u'] == pytest.approx(0.30, abs=0.01)     # true u at the bag's end: 0.30
    assert (out / 'analysis.png').stat().st_size > 0


def test_analyze_does_not_import_rclpy(tmp_path: Path) -> None:
    """Even where rclpy is installed (this venv), the offline CLI never imports it."""
    code = ('import sys\n'
            'from gear_phm.cli.main import main\n'
            f'status = main(["analyze", {str(BAG)!r}, "--ratio", "3.0", "--out", '
            f'{str(tmp_path / "out")!r}, "--no-plot", "--no-progress"])\n'
            'ros = sorted(m for m in sys.modules if m.split(".")[0] in '
            '("rclpy", "rcl_interfaces", "sensor_msgs", "geometry_msgs", "diagnostic_msgs"))\n'
            'print(status, ros)\n')
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                            timeout=600)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip().splitlines()[-1] == '0 []'
