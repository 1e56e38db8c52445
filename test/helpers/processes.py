"""Start and stop the package's node executables as real subprocesses (integration tests)."""
from __future__ import annotations

import os
from pathlib import Path
import signal
import subprocess
import sys

BIN = Path(sys.executable).parent


def spawn(exe: str, *params: str, env: dict[str, str] | None = None) -> subprocess.Popen:
    """Start ``exe`` from the venv with ``-p`` parameters; stderr is kept for the test."""
    args = [str(BIN / exe), '--ros-args']
    for param in params:
        args += ['-p', param]
    return subprocess.Popen(args, env=env or os.environ.copy(), stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)


def stop(proc: subprocess.Popen, sig: int = signal.SIGINT) -> int:
    """Send ``sig`` if it still runs and return its exit code.

    A process that has not exited 20 s later is killed (its code is then negative).
    """
    if proc.poll() is None:
        proc.send_signal(sig)
        try:
            return proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
    return proc.wait()
