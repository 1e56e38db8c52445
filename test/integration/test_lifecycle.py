"""The estimator and the diagnostics node are managed nodes, driven by lifecycle_msgs services.

Both node executables as real processes with ``autostart:=false``, and a real rclpy client
of ``~/change_state`` and ``~/get_state`` in the test process, as a lifecycle manager (nav2's,
``ros2 lifecycle set``) does. One process pair for the module and one scenario through the
states: unconfigured -> configure refused (a parameter set that breaks a cross-field rule) ->
configure -> inactive (no subscription, nothing published) ->
activate (estimates, statuses) -> deactivate (state files saved with the last sample, the
recording a complete bag that rosbags and mcap's reader read; nothing published) ->
activate again (the recording's next file), deactivate (both files in the bag) -> activate
with the next file impossible (ERROR on /diagnostics) -> SIGINT. On the way: the header stamp
is the node's clock, hardware_id the drive's name.
"""
from __future__ import annotations

from collections.abc import Iterator
import json
from pathlib import Path
import signal
import time
from typing import Any

import pytest

rclpy = pytest.importorskip('rclpy')
from lifecycle_msgs.msg import Transition  # noqa: E402, I100
from lifecycle_msgs.srv import ChangeState, GetState  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.parameter_client import AsyncParameterClient  # noqa: E402

from gear_phm.interfaces import DIAGNOSTICS, FRICTION, HEALTH_EFFICIENCY, stamp_to_ns  # noqa: E402
from helpers.live import Driver, joint_state, publish_acked, publish_paced  # noqa: E402
from helpers.plant import lever_plant  # noqa: E402
from helpers.processes import spawn, stop  # noqa: E402

pytestmark = [pytest.mark.integration, pytest.mark.timeout(180)]
#: u = 0.1 at 100 Hz, 12 s of stamps (published faster than real time).
RUN = lever_plant(5, 12.0, 0.1, rate=100.0)
NODES = ('estimator', 'diagnostics')


class Manager:
    """The two processes and the test's lifecycle clients (the driver node's)."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.state = {name: folder / f'{name}.json' for name in NODES}
        self.bag = folder / 'rec'
        self.procs = {
            'estimator': spawn('estimator', 'autostart:=false', 'ratio:=3.0',
                               'motor_inertia:=0.01', 'diagnostics_period:=0.1',
                               f'state_file:={self.state["estimator"]}'),
            'diagnostics': spawn('diagnostics', 'autostart:=false', 'ratio:=3.0', 'rate:=10.0',
                                 f'state_file:={self.state["diagnostics"]}',
                                 f'record_path:={self.bag}')}
        self.driver = Driver('lifecycle_manager', outputs=(FRICTION, HEALTH_EFFICIENCY))
        self.driver.hardware_ids = {}
        self.driver.on_diagnostics.append(lambda msg: self.driver.hardware_ids.update(
            (status.name, status.hardware_id) for status in msg.status))
        node = self.driver.node
        self.change = {n: node.create_client(ChangeState, f'/{n}/change_state') for n in NODES}
        self.get = {n: node.create_client(GetState, f'/{n}/get_state') for n in NODES}
        self.driver.wait(lambda: all(c.service_is_ready() for c in (*self.change.values(),
                                                                    *self.get.values())),
                         60.0, 'the lifecycle services')
        self.next_ns = time.time_ns() + 3600 * 10**9     # samples an hour ahead of the clock
        self.codes: dict[str, int] = {}

    def call(self, client: Any, request: Any) -> Any:
        future = client.call_async(request)
        self.driver.wait(future.done, 30.0, f'{client.srv_name} response')
        return future.result()

    def state_of(self, name: str) -> str:
        return str(self.call(self.get[name], GetState.Request()).current_state.label)

    def transition(self, name: str, transition: int) -> bool:
        request = ChangeState.Request()
        request.transition.id = transition
        return bool(self.call(self.change[name], request).success)

    def set_parameter(self, name: str, parameter: str, value: float) -> bool:
        """Set a parameter through the node's own service; whether it was taken."""
        client = AsyncParameterClient(self.driver.node, name)
        self.driver.wait(client.services_are_ready, 30.0, f'{name} parameter services')
        future = client.set_parameters([Parameter(parameter, value=value)])
        self.driver.wait(future.done, 30.0, f'{name} set_parameters')
        return bool(future.result().results[0].successful)

    def feed(self, seconds: float, acked: bool = True) -> int:
        """Publish ``seconds`` of the plant (stamps go on) at up to 2000 messages a second.

        ``acked``: as fast as the nodes take it in (:func:`publish_acked`); else paced.
        Returns the last stamp [ns].
        """
        n = int(round(seconds * 100.0))
        size = RUN.t.size
        messages = [joint_state(self.next_ns + i * 10**7, RUN.motor_velocity[i % size],
                                RUN.motor_effort[i % size], RUN.load_velocity[i % size],
                                RUN.load_effort[i % size]) for i in range(n)]
        if acked:
            publish_acked(self.driver, messages, 2000.0)
        else:
            publish_paced(self.driver, messages, 2000.0)
        last = stamp_to_ns(messages[-1].header.stamp)
        self.next_ns = last + 10**7
        return last

    def published(self) -> int:
        """Messages received so far: statuses of either node and estimator/health outputs."""
        d = self.driver
        return sum(len(v) for v in d.statuses.values()) + sum(len(v) for v in d.messages.values())

    def quiet(self, seconds: float = 1.0) -> None:
        """Nothing arrives from the nodes for ``seconds`` (10 status periods of each)."""
        before = self.published()
        self.driver.spin(seconds)
        assert self.published() == before, 'an inactive node published'

    def saved(self, name: str) -> dict[str, Any]:
        document: dict[str, Any] = json.loads(self.state[name].read_text(encoding='utf-8'))
        return document

    def close(self) -> dict[str, int]:
        """Stop the processes (SIGINT) and return their exit codes; once."""
        if not self.codes:
            self.driver.close()
            self.codes = {name: stop(proc, signal.SIGINT) for name, proc in self.procs.items()}
        return self.codes


@pytest.fixture(scope='module')
def manager(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Manager]:
    rig = Manager(tmp_path_factory.mktemp('lifecycle'))
    try:
        yield rig
    finally:
        rig.close()


def _messages(bag: Path) -> dict[str, int]:
    """Messages per topic (no leading '/') as rosbags reads the bag (the files listed)."""
    from rosbags.highlevel import AnyReader
    counts: dict[str, int] = {}
    with AnyReader([bag]) as reader:
        for connection, _, _ in reader.messages():
            topic = connection.topic.lstrip('/')
            counts[topic] = counts.get(topic, 0) + 1
    return counts


def _mcap_count(path: Path) -> int:
    from mcap.reader import make_reader
    with open(path, 'rb') as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None, f'{path}: no summary'
        return sum(1 for _ in reader.iter_messages()) if summary.statistics.message_count \
            else 0


def test_managed_through_the_lifecycle_services(manager: Manager) -> None:
    driver = manager.driver
    assert [manager.state_of(n) for n in NODES] == ['unconfigured'] * 2
    # configure validates the parameters as a whole: min_window >= window fails it
    assert manager.set_parameter('estimator', 'min_window', 2.0)
    assert not manager.transition('estimator', Transition.TRANSITION_CONFIGURE)
    assert manager.state_of('estimator') == 'unconfigured'
    assert manager.set_parameter('estimator', 'min_window', 0.2)
    assert all(manager.transition(n, Transition.TRANSITION_CONFIGURE) for n in NODES)
    assert [manager.state_of(n) for n in NODES] == ['inactive'] * 2
    # inactive: no subscription exists, nothing is published, not even /diagnostics
    manager.feed(1.0, acked=False)
    manager.quiet()
    assert driver.pub.get_subscription_count() == 0
    assert not manager.bag.joinpath('metadata.yaml').exists()

    assert all(manager.transition(n, Transition.TRANSITION_ACTIVATE) for n in NODES)
    assert [manager.state_of(n) for n in NODES] == ['active'] * 2
    driver.wait(lambda: driver.pub.get_subscription_count() > 0, 30.0, 'the subscription')
    last = manager.feed(6.0)
    driver.wait(lambda: len(driver.messages[HEALTH_EFFICIENCY]) > 0
                and driver.latest('gear_phm estimator') and driver.latest('gear_phm'),
                60.0, 'estimates and statuses')
    driver.wait(lambda: int(driver.latest('gear_phm estimator').get('messages_received', 0))
                >= 600, 60.0, 'the estimator to take the stream in')

    assert all(manager.transition(n, Transition.TRANSITION_DEACTIVATE) for n in NODES)
    assert [manager.state_of(n) for n in NODES] == ['inactive'] * 2
    # deactivate saved the state: the estimator's with the newest sample (its buffer was
    # processed), the diagnostics node's with the estimates it assessed
    assert manager.saved('estimator')['state']['last_stamp'] == last
    assert manager.saved('diagnostics')['saved_stamp_ns'] is not None
    # ... and finished the recording's file: a complete bag
    counts = _messages(manager.bag)
    assert counts.get(DIAGNOSTICS.lstrip('/'), 0) >= 1 and counts.get(HEALTH_EFFICIENCY, 0) >= 1
    assert _mcap_count(manager.bag / 'rec_0.mcap') == sum(counts.values())
    manager.feed(1.0, acked=False)
    manager.quiet()
    assert driver.pub.get_subscription_count() == 0

    # active again: the recording goes on in the bag's next file, finished at deactivate
    assert all(manager.transition(n, Transition.TRANSITION_ACTIVATE) for n in NODES)
    driver.wait(lambda: driver.pub.get_subscription_count() > 0, 30.0, 'the subscription')
    seen = len(driver.messages[HEALTH_EFFICIENCY])
    manager.feed(3.0)
    driver.wait(lambda: len(driver.messages[HEALTH_EFFICIENCY]) > seen, 60.0, 'new estimates')
    assert manager.transition('diagnostics', Transition.TRANSITION_DEACTIVATE)
    later = _messages(manager.bag)
    assert later[HEALTH_EFFICIENCY] > counts[HEALTH_EFFICIENCY]
    assert _mcap_count(manager.bag / 'rec_1.mcap') == sum(later.values()) - sum(counts.values())

    # the conventions of /diagnostics (diagnostic_updater's): the header stamp is the node's
    # clock, not the samples' (which run ahead of it here); hardware_id the drive's name
    health, estimator = driver.latest('gear_phm'), driver.latest('gear_phm estimator')
    assert int(health['_stamp_ns']) <= time.time_ns() < driver.stamps[HEALTH_EFFICIENCY][-1]
    assert int(estimator['_stamp_ns']) <= time.time_ns()
    assert driver.hardware_ids == {'gear_phm: gearbox': 'gearbox',
                                   'gear_phm estimator: estimator': 'gearbox'}

    # a recording that fails is an ERROR: the next file cannot be made (a folder is there)
    (manager.bag / 'rec_2.mcap').mkdir()
    assert manager.transition('diagnostics', Transition.TRANSITION_ACTIVATE)
    manager.feed(1.0)
    driver.wait(lambda: 'recording failed' in driver.latest('gear_phm').get('_message', ''),
                30.0, 'the recording error on /diagnostics')
    assert driver.latest('gear_phm')['_level'] == b'\x02'
    assert manager.close() == {'estimator': 0, 'diagnostics': 0}
    # each node logs one line when it is ready: at each activation
    ready = {name: [line for line in proc.stderr.read().splitlines() if ']: ready: ' in line]
             for name, proc in manager.procs.items()}
    assert [len(ready['estimator']), len(ready['diagnostics'])] == [2, 3], ready
    assert ready['estimator'][0].endswith(
        'ready: estimating from /joint_states (motor/load joints motor/load), state file '
        f'{manager.state["estimator"]}')
    assert _messages(manager.bag) == later        # the bag as the last deactivate left it
