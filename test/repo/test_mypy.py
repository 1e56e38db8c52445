"""Static types: mypy (strict, configured in setup.cfg [mypy]) over the gear_phm package."""
from pathlib import Path
import re
import subprocess
import sys

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.linter
def test_mypy() -> None:
    result = subprocess.run(
        [sys.executable, '-m', 'mypy', '--config-file', 'setup.cfg', 'gear_phm'],
        cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    checked = re.search(r'no issues found in (\d+) source files', result.stdout)
    assert checked, result.stdout
    modules = len(list((ROOT / 'gear_phm').rglob('*.py')))
    assert int(checked.group(1)) == modules, result.stdout    # every module was checked
