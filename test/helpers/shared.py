"""Expensive set-ups shared by the pytest-xdist workers of one test run."""
from __future__ import annotations

from collections.abc import Callable
import fcntl
import os
from pathlib import Path
import shutil

import pytest


def build_once(factory: pytest.TempPathFactory, name: str,
               build: Callable[[Path], None]) -> Path:
    """Return the directory ``name`` of this test run, made by ``build(directory)`` once.

    A module- or session-scoped fixture runs once per pytest-xdist worker that needs it; an
    expensive one (a fleet simulated, a venv installed, a colcon build) calls this so that
    the first worker builds and the others, blocked on an exclusive lock, reuse the result.
    The directory is in the run's temporary root, shared by its workers only (a serial run:
    its own base directory). A failed build leaves nothing: the next caller builds again.
    """
    base = factory.getbasetemp()
    root = base.parent if 'PYTEST_XDIST_WORKER' in os.environ else base
    directory, done = root / name, root / f'{name}.done'
    with open(root / f'{name}.lock', 'w') as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)           # released when the file is closed
        if not done.exists():
            if directory.exists():
                shutil.rmtree(directory)            # a build that failed half-way
            directory.mkdir()
            build(directory)
            done.touch()
    return directory
