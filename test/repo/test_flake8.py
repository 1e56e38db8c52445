"""flake8 with ament_flake8's plugins and configuration (setup.cfg [flake8]), as ros2/demos."""
from pathlib import Path

from ament_flake8.main import main_with_errors
import pytest

ROOT = Path(__file__).resolve().parents[2]
PATHS = ['gear_phm', 'launch', 'test', 'bench', 'setup.py']


@pytest.mark.flake8
@pytest.mark.linter
@pytest.mark.long(20)
def test_flake8(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)     # PATHS and setup.cfg are relative to the root
    rc, errors = main_with_errors(argv=['--config', 'setup.cfg', *PATHS])
    assert rc == 0, \
        'Found %d code style errors / warnings:\n' % len(errors) + '\n'.join(errors)


@pytest.mark.flake8
@pytest.mark.linter
def test_flake8_plugins_are_active(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A file breaking each plugin's rule is reported: the clean run above is not vacuous."""
    bad = tmp_path / 'bad.py'
    bad.write_text('"""Summary without a period\nand no blank line."""\n'
                   'import sys\n'
                   'import os\n'
                   'x = "double quotes"\n'
                   'y = dict(a=1)\n'
                   f'z = {"1" * 100}\n'
                   'print(sys, os, x, y, z)\n')
    monkeypatch.chdir(ROOT)
    rc, errors = main_with_errors(argv=['--config', 'setup.cfg', str(bad)])
    codes = {error.split(': ')[1].split()[0] for error in errors if ': ' in error}
    assert rc == 1
    # pydocstyle, import order, quotes, comprehensions, pycodestyle's 99 columns
    assert {'D400', 'I100', 'Q000', 'C408', 'E501'} <= codes, errors
