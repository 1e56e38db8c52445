"""The worker processes of offline analysis (gear_phm.offline.parallel)."""
from __future__ import annotations

import subprocess
import sys

import pytest


NO_FORK = """
import threading
import rclpy
from gear_phm.offline.parallel import can_fork, drives_for, start_plotter
assert can_fork()
rclpy.init()                        # a DDS participant's native threads: no fork
assert not can_fork() and start_plotter() is None
assert drives_for([object(), object()], 2).workers == 0
assert drives_for([object()], 2).workers == 0    # one drive: its assessor stays here too
rclpy.shutdown()
stop = threading.Event()
thread = threading.Thread(target=stop.wait)
thread.start()                      # another Python thread: no fork
assert not can_fork()
stop.set()
thread.join()
assert can_fork()
print('ok')
"""


def test_no_fork_beside_other_threads_or_a_ros_context() -> None:
    """The plot process and drive workers are forked only from a process alone in it."""
    pytest.importorskip('rclpy')
    result = subprocess.run([sys.executable, '-c', NO_FORK], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0 and result.stdout == 'ok\n', result.stderr
