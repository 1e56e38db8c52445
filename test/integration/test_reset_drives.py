"""With ``transmissions``: ``~/<drive>/reset`` resets one drive, ``~/reset`` all of them.

Only ``frame_id`` and ``use_sim_time`` change at run time; the rest is refused with a reason.

Both nodes as real processes over DDS, no stream needed: the counts on /diagnostics and the
responses show which drive was reset.
"""
from __future__ import annotations

from collections.abc import Iterator
import signal
import time

import pytest
import yaml

rclpy = pytest.importorskip('rclpy')
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402, I100
from rclpy.node import Node  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.parameter_client import AsyncParameterClient  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

from helpers.live import RELIABLE  # noqa: E402
from helpers.processes import spawn, stop  # noqa: E402

pytestmark = [pytest.mark.integration, pytest.mark.timeout(120)]
DRIVES = {'transmissions': ['a', 'b'],
          'a': {'motor_joint': 'ma', 'load_joint': 'la', 'ratio': 3.0},
          'b': {'motor_joint': 'mb', 'load_joint': 'lb', 'ratio': 12.0}}


@pytest.fixture(scope='module')
def graph(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Node, dict]]:
    folder = tmp_path_factory.mktemp('reset_drives')
    params = folder / 'drives.yaml'
    params.write_text(yaml.safe_dump({'/**': {'ros__parameters': DRIVES}}))
    procs = {'estimator': spawn('estimator', 'diagnostics_period:=0.2',
                                f'state_file:={folder / "e.json"}', params_file=params),
             'diagnostics': spawn('diagnostics', 'rate:=5.0',
                                  f'state_file:={folder / "d.json"}', params_file=params)}
    rclpy.init()
    node = Node('reset_drives_test')
    statuses: dict[str, dict[str, str]] = {}
    node.create_subscription(DiagnosticArray, '/diagnostics', lambda m: statuses.update(
        (s.name, {kv.key: kv.value for kv in s.values}) for s in m.status), RELIABLE)
    try:
        yield node, statuses
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        for proc in procs.values():
            assert stop(proc, signal.SIGINT) == 0, proc.stderr.read() if proc.stderr else ''


def wait(node: Node, condition, what: str, deadline: float = 30.0) -> None:
    end = time.monotonic() + deadline
    while time.monotonic() < end:
        if condition():
            return
        rclpy.spin_once(node, timeout_sec=0.05)
    raise AssertionError(f'timed out waiting for {what}')


def call(node: Node, service: str) -> Trigger.Response:
    client = node.create_client(Trigger, service)
    wait(node, client.service_is_ready, service)
    future = client.call_async(Trigger.Request())
    wait(node, future.done, f'{service} response')
    return future.result()


@pytest.mark.parametrize('node_name, status', [('estimator', 'gear_phm estimator: '),
                                               ('diagnostics', 'gear_phm: ')])
def test_each_drive_resets_alone_and_all_together(graph: tuple[Node, dict], node_name: str,
                                                  status: str) -> None:
    node, statuses = graph

    def resets() -> dict[str, int]:
        return {d: int(statuses.get(status + d, {}).get('resets', -1)) for d in 'ab'}
    wait(node, lambda: resets() == {'a': 0, 'b': 0}, f'{node_name} statuses')
    response = call(node, f'/{node_name}/b/reset')
    assert response.success and 'learning reset of b:' in response.message
    wait(node, lambda: resets() == {'a': 0, 'b': 1}, 'b reset alone')
    response = call(node, f'/{node_name}/reset')
    assert response.success and 'learning reset of a, b:' in response.message
    wait(node, lambda: resets() == {'a': 1, 'b': 2}, 'both reset')


def test_with_drives_only_the_clock_and_frame_id_change_at_run_time(
        graph: tuple[Node, dict]) -> None:
    node, _ = graph
    client = AsyncParameterClient(node, 'estimator')
    assert client.wait_for_services(timeout_sec=30.0)

    def set_one(name: str, value: object) -> object:
        future = client.set_parameters([Parameter(name, value=value)])
        wait(node, future.done, f'set {name}')
        return future.result().results[0]
    assert set_one('frame_id', 'bench').successful
    assert set_one('use_sim_time', False).successful
    result = set_one('gate_threshold', 12.0)
    assert not result.successful
    assert result.reason == ('gate_threshold: with transmissions the parameters are read at '
                             'start only; restart the node')
    result = set_one('a.window', 2.0)
    assert not result.successful and result.reason == \
        'Trying to set a read-only parameter: a.window.'
