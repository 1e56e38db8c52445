"""The MCAP project's conformance suite, ``../shared/mcap-conformance`` beside the checkout.

CI always has it. Where it is missing, every test that needs it fails with one clear message
(never a skip). ``MCAP_CONFORMANCE_DIR`` points at another copy (e.g. from a git worktree).
"""
from __future__ import annotations

import functools
import os
from pathlib import Path

import pytest

SUITE = Path(os.environ.get('MCAP_CONFORMANCE_DIR')
             or Path(__file__).resolve().parents[3] / 'shared' / 'mcap-conformance')
#: Files of the suite (``<case>/<case>-<features>.mcap``, each with its ``.json``).
COUNT = 416
MISSING = (f'the MCAP conformance suite is missing: expected {COUNT} files */*.mcap in {SUITE} '
           '(CI checks it out beside the repository as ../shared/mcap-conformance; '
           'MCAP_CONFORMANCE_DIR names another copy)')


@functools.cache
def files() -> tuple[Path, ...]:
    """Return the suite's .mcap files, sorted (none if the suite is missing)."""
    return tuple(sorted(SUITE.glob('*/*.mcap')))


def params() -> list:
    """Return one pytest parameter per file, or one that fails the test if the suite is missing."""
    return [pytest.param(path, id=path.stem) for path in files()] or [
        pytest.param(None, id='suite-missing')]


def require(path: Path | None = None) -> Path:
    """Return ``path`` (default: the suite's directory); fail the test if the suite is missing."""
    if len(files()) != COUNT:
        pytest.fail(f'{MISSING}; found {len(files())}', pytrace=False)
    return SUITE if path is None else path
