"""Start and stop the package's node executables as real subprocesses (integration tests)."""
from __future__ import annotations

from collections.abc import Callable
import os
from pathlib import Path
import signal
import subprocess
import sys
import time

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


def spawn(exe: str, *params: str, env: dict[str, str] | None = None,
          params_file: Path | None = None) -> subprocess.Popen:
    """Start ``exe`` from the venv with a parameters file and ``-p`` parameters.

    stderr is kept for the test.
    """
    args = [str(BIN / exe), '--ros-args']
    if params_file is not None:
        args += ['--params-file', str(params_file)]
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


def signalled_when(args: list[str], ready: Callable[[subprocess.Popen], bool], what: str,
                   signum: int, ready_within: float = 60.0, exit_within: float = 60.0
                   ) -> subprocess.CompletedProcess:
    """Run ``args``; send ``signum`` once ``ready(child)`` (``what``: for the error).

    AssertionError if the child exits first or is not ready within ``ready_within`` [s]; it
    is killed (and subprocess.TimeoutExpired raised) if it has not exited ``exit_within`` [s]
    after the signal.
    """
    child = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             env=os.environ.copy())
    try:
        deadline = time.monotonic() + ready_within
        while not ready(child):
            assert child.poll() is None, child.communicate()
            assert time.monotonic() < deadline, f'not {what} within {ready_within:g} s'
            time.sleep(0.01)
        child.send_signal(signum)
        out, err = child.communicate(timeout=exit_within)
    finally:
        if child.poll() is None:
            child.kill()
            child.communicate()
    return subprocess.CompletedProcess(child.args, child.returncode, out, err)


def signalled_when_staged(args: list[str], folder: Path, signum: int
                          ) -> subprocess.CompletedProcess:
    """Run ``args``; send ``signum`` once its hidden staging folder is in ``folder``.

    ``folder`` must hold nothing else then (the output is staged beside ``--out``, which is
    in ``folder``).
    """
    def staged(child: subprocess.Popen) -> bool:
        if not any(folder.iterdir()):         # the staging folder, once the options are checked
            return False
        assert [p.name.startswith('.') for p in folder.iterdir()] == [True]
        return True
    return signalled_when(args, staged, 'staged', signum)
