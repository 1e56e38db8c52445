"""Docstrings checked with ament_pep257, as ros2/demos does.

The convention is ament's, with the summary on the first line of a multi-line docstring
(D212, as the whole tree writes it) instead of on the second (D213).
"""
from pathlib import Path

from ament_pep257.main import main
import pytest

ROOT = Path(__file__).resolve().parents[2]
PATHS = ['gear_phm', 'launch', 'test', 'bench', 'setup.py']

OPTIONS = ['--add-ignore', 'D213', '--add-select', 'D212']


@pytest.mark.linter
@pytest.mark.pep257
def test_pep257(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)
    rc = main(argv=[*PATHS, *OPTIONS])
    assert rc == 0, 'Found code style errors / warnings'


@pytest.mark.linter
@pytest.mark.pep257
def test_pep257_reports_a_bad_docstring(tmp_path: Path) -> None:
    bad = tmp_path / 'bad.py'
    bad.write_text('def f():\n    """\n    Summary on the second line\n    """\n')
    assert main(argv=[str(bad), *OPTIONS]) == 1
