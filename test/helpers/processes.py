"""Start and stop the package's node executables as real subprocesses (integration tests)."""
from __future__ import annotations

import os
from pathlib import Path
import signal
import subprocess
import sys

BIN = Path(sys.executable).parent


def udp_only_env() -> dict[str, str]:
    """Return this environment with Fast DDS on UDPv4 only (no shared-memory transport).

    For node processes that are killed with SIGKILL or exit at start-up: Fast DDS's shared
    memory keeps robust mutexes and port queues in /dev/shm, and a participant that dies while
    using them can leave a later one hanging (eProsima/Fast-DDS#1144). Once, in a fresh clone,
    a publisher started after the kill tests printed its start-up error and never exited; once,
    in a full run at load, a node refused at start-up did the same. The processes such a node
    talks to keep the default transports and reach it over UDP.
    """
    return {**os.environ, 'FASTDDS_BUILTIN_TRANSPORTS': 'UDPv4'}


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
