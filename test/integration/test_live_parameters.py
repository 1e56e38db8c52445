"""Parameters set at run time keep what the nodes learned; ``~/reset`` forgets on purpose.

Through the node executables (real processes, real DDS) and rclpy's parameter client, as
``ros2 param set`` does: an estimator fed a lever plant (u = 0.1) and the diagnostics node on
its outputs, both with a state file. One pair of node processes for the module; a test that
needs the learned state feeds the plant until it is learned (after a reset).
"""
from __future__ import annotations

from collections.abc import Iterator
import json
import math
from pathlib import Path
import subprocess
import time
from typing import Any

import pytest

rclpy = pytest.importorskip('rclpy')
from rclpy.parameter import Parameter, parameter_value_to_python  # noqa: E402, I100
from rclpy.parameter_client import AsyncParameterClient  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

from gear_phm.estimation import PARAMETERS as ESTIMATOR_PARAMETERS  # noqa: E402
from gear_phm.interfaces import FRICTION, stamp_to_ns  # noqa: E402
from gear_phm.nodes import diagnostics, estimator  # noqa: E402
from gear_phm.parameters import ParamSpec  # noqa: E402
from gear_phm.prognostics import PARAMETERS as HEALTH_PARAMETERS  # noqa: E402
from helpers.live import Driver, joint_state, publish_acked  # noqa: E402
from helpers.params import other_value  # noqa: E402
from helpers.plant import lever_plant  # noqa: E402
from helpers.processes import BIN, stop  # noqa: E402

pytestmark = [pytest.mark.integration, pytest.mark.timeout(240)]
#: The plant: u = 0.1, 100 Hz; one period of its duty cycle is 40 s.
RUN = lever_plant(3, 40.0, 0.1, rate=100.0)
ESTIMATOR_ARGS = ('ratio:=3.0', 'motor_torque_noise:=0.05', 'load_torque_noise:=0.05',
                  'motor_inertia:=0.01', 'diagnostics_period:=0.1', 'state_save_period:=0.3')
DIAGNOSTICS_ARGS = ('ratio:=3.0', 'rate:=10.0', 'state_save_period:=0.3')
ESTIMATOR_SPECS = {s.name: s for s in ESTIMATOR_PARAMETERS + estimator.NODE_PARAMETERS}
DIAGNOSTICS_SPECS = {s.name: s for s in HEALTH_PARAMETERS + diagnostics.NODE_PARAMETERS}


class Rig:
    """The two node processes, their state files and logs, and the test's driver node."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.state = {'estimator': folder / 'estimator.json',
                      'diagnostics': folder / 'diagnostics.json'}
        self.logs = {name: folder / f'{name}.log' for name in self.state}
        self.procs = {
            name: self._start(name, *args, f'state_file:={self.state[name]}')
            for name, args in (('estimator', ESTIMATOR_ARGS),
                               ('diagnostics', DIAGNOSTICS_ARGS))}
        self.driver = Driver('live_parameters_driver', outputs=(FRICTION,))
        node = self.driver.node
        self.clients = {name: AsyncParameterClient(node, name) for name in self.state}
        self.resets = {name: node.create_client(Trigger, f'/{name}/reset')
                       for name in self.state}
        self.next_ns = time.time_ns()        # the stamp of the next sample [ns]
        self.driver.wait(lambda: self.driver.pub.get_subscription_count() > 0
                         and self.status('estimator') and self.status('diagnostics')
                         and all(c.services_are_ready() for c in self.clients.values())
                         and all(c.service_is_ready() for c in self.resets.values()),
                         60.0, 'both nodes up')

    def _start(self, name: str, *params: str) -> subprocess.Popen:
        args = [str(BIN / name), '--ros-args']
        for param in params:
            args += ['-p', param]
        with open(self.logs[name], 'w', encoding='utf-8') as log:
            return subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT)

    def close(self) -> None:
        self.driver.close()
        for proc in self.procs.values():
            assert stop(proc) == 0

    # -- status and state -------------------------------------------------------------------
    def status(self, node: str) -> dict[str, str]:
        prefix = 'gear_phm estimator' if node == 'estimator' else 'gear_phm'
        return self.driver.latest(prefix)

    def fresh_status(self, node: str) -> dict[str, str]:
        """Return the node's status once two more have arrived (one made after this call).

        By count, not stamp: the diagnostics node stamps its status with its last input's.
        """
        prefix = 'gear_phm estimator' if node == 'estimator' else 'gear_phm'
        seen = len(self.driver.statuses.get(prefix, []))
        self.driver.wait(lambda: len(self.driver.statuses.get(prefix, [])) >= seen + 2, 20.0,
                         f'a {node} status')
        return self.status(node)

    def saved(self, node: str, after_ns: int = 0) -> dict[str, Any]:
        """Return the node's state document, once written after ``after_ns`` (file time)."""
        path = self.state[node]
        self.driver.wait(lambda: path.exists() and path.stat().st_mtime_ns > after_ns, 20.0,
                         f'{node} state saved')
        document: dict[str, Any] = json.loads(path.read_text(encoding='utf-8'))
        return document

    def stable_state(self, node: str) -> dict[str, Any]:
        """Return the node's saved state once two saves in a row hold the same state."""
        previous = self.saved(node)['state']
        for _ in range(20):
            current = self.saved(node, self.state[node].stat().st_mtime_ns)['state']
            if current == previous:
                return current
            previous = current
        raise AssertionError(f'the {node} state does not settle')

    # -- stream -----------------------------------------------------------------------------
    def feed(self, seconds: float, rate: float = 2000.0) -> int:
        """Publish ``seconds`` of the plant from its start, stamps going on; the last stamp."""
        n = int(round(seconds * 100.0))
        messages = [joint_state(self.next_ns + int(RUN.t[i % RUN.t.size] * 1e9)
                                + (i // RUN.t.size) * 40 * 10 ** 9,
                                RUN.motor_velocity[i % RUN.t.size],
                                RUN.motor_effort[i % RUN.t.size],
                                RUN.load_velocity[i % RUN.t.size],
                                RUN.load_effort[i % RUN.t.size]) for i in range(n)]
        publish_acked(self.driver, messages, rate)
        last = stamp_to_ns(messages[-1].header.stamp)
        self.next_ns = last + 10_000_000
        return last

    def learned(self) -> bool:
        values = self.status('estimator')
        return abs(float(values.get('u', 'nan')) - 0.1) < 0.01 \
            and float(values['sigma_u']) < 0.005

    def ensure_learned(self) -> None:
        """Feed the plant until u is learned, then pause until both states have settled."""
        for _ in range(3):
            if self.learned():
                break
            last = self.feed(40.0)
            self.driver.wait(lambda: self.saved('estimator')['state']['last_stamp'] == last,
                             20.0, 'the last sample in the estimator state')
        time.sleep(1.0)                          # past sensor_timeout: the timeout counted
        assert self.learned(), self.fresh_status('estimator')

    # -- parameters and services --------------------------------------------------------------
    def call(self, future: Any) -> Any:
        self.driver.wait(future.done, 20.0, 'a service call')
        return future.result()

    def get(self, node: str, names: list[str]) -> list[Any]:
        result = self.call(self.clients[node].get_parameters(names))
        return [parameter_value_to_python(value) for value in result.values]

    def set_one(self, node: str, name: str, value: Any) -> Any:
        """Set one parameter as ``ros2 param set`` does; the SetParametersResult."""
        return self.call(self.clients[node].set_parameters([Parameter(name, value=value)])
                         ).results[0]

    def live_names(self, node: str) -> list[str]:
        """Return the node's parameters that are not read-only, by its own descriptors."""
        names = self.call(self.clients[node].list_parameters()).result.names
        described = self.call(self.clients[node].describe_parameters(names)).descriptors
        return [d.name for d in described if not d.read_only]

    def reset(self, node: str) -> Any:
        return self.call(self.resets[node].call_async(Trigger.Request()))


@pytest.fixture(scope='module')
def rig(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Rig]:
    rig = Rig(tmp_path_factory.mktemp('live_parameters'))
    try:
        yield rig
    finally:
        rig.close()


def learned_values(status: dict[str, str], keys: tuple[str, ...]) -> tuple[float, ...]:
    return tuple(float(status[key]) for key in keys)


def set_each(rig: Rig, node: str, specs: dict[str, ParamSpec], keys: tuple[str, ...]
             ) -> list[str]:
    """Set each live parameter of ``node`` to another value; its learned values stay.

    ``keys``: the status keys of the learned state, compared within 1e-9 in the node's first
    status after each set. Returns the names set.
    """
    baseline = learned_values(rig.fresh_status(node), keys)
    names = [n for n in rig.live_names(node) if n != 'use_sim_time']
    assert set(names) <= set(specs), set(names) - set(specs)
    for name in names:
        current = rig.get(node, [name])[0]
        result = rig.set_one(node, name, other_value(specs[name], current))
        assert result.successful, (name, result.reason)
        values = learned_values(rig.fresh_status(node), keys)
        assert values == pytest.approx(baseline, abs=1e-9), name
    # use_sim_time: the node clock stops with no /clock; back to the system clock
    assert rig.set_one(node, 'use_sim_time', True).successful
    assert rig.set_one(node, 'use_sim_time', False).successful
    values = learned_values(rig.fresh_status(node), keys)
    assert values == pytest.approx(baseline, abs=1e-9)
    return names


def test_each_estimator_parameter_applies_live_and_keeps_u(rig: Rig) -> None:
    rig.ensure_learned()
    before = rig.stable_state('estimator')
    saved_at = rig.state['estimator'].stat().st_mtime_ns
    gate, frame_id, noise = rig.get('estimator', ['gate_threshold', 'frame_id',
                                                  'process_noise'])
    names = set_each(rig, 'estimator', ESTIMATOR_SPECS, ('u', 'sigma_u'))
    assert {'gate_threshold', 'publish_rate', 'frame_id', 'window', 'process_noise',
            'initial_u', 'sensor_timeout', 'motor_torque_noise'} <= set(names)
    assert not {'ratio', 'motor_joint', 'load_joint', 'motor_inertia', 'load_effort_sign',
                'state_file', 'batch_period'} & set(names)
    assert rig.get('estimator', ['gate_threshold', 'frame_id']) == [
        other_value(ESTIMATOR_SPECS['gate_threshold'], gate),
        other_value(ESTIMATOR_SPECS['frame_id'], frame_id)]
    # the periodic save after the changes writes the same learned state
    after = rig.saved('estimator', saved_at)['state']
    assert after['filter']['x'] == pytest.approx(before['filter']['x'], abs=1e-9)
    assert after['filter']['P'] == pytest.approx(before['filter']['P'], abs=1e-9)
    # what the new settings change on purpose: the process noise, the publish_rate grid
    assert after['filter']['process_noise'] == 1.5 * noise
    for key in ('process_noise', 'q_test'):
        after['filter'][key] = before['filter'][key]
    assert after['grid'] != before['grid']
    after['grid'] = before['grid']
    assert after == before


def test_no_jump_back_to_the_prior_on_a_running_stream(rig: Rig) -> None:
    rig.ensure_learned()
    first = len(rig.driver.messages[FRICTION])
    changes = [('gate_threshold', 12.0), ('publish_rate', 5.0), ('window', 0.8),
               ('frame_id', 'running'), ('motor_torque_noise', 0.06)]
    for name, value in changes:             # 2 s of stream between two sets, no pause
        rig.feed(2.0)
        assert rig.set_one('estimator', name, value).successful, name
    last = rig.feed(4.0)
    rig.driver.wait(lambda: rig.driver.stamps[FRICTION][-1] >= last - 10 ** 9, 20.0,
                    'outputs to the end')
    outputs = rig.driver.messages[FRICTION][first:]
    assert len(outputs) > 50
    worst = max(abs(m.vector.x - 0.1) for m in outputs)
    assert worst < 0.01 and max(m.vector.z for m in outputs) < 0.005, worst
    assert outputs[-1].header.frame_id == 'running'


def test_a_structural_parameter_is_refused_with_the_reason(rig: Rig) -> None:
    u = rig.fresh_status('estimator')['u']
    for node, name, value in [('estimator', 'ratio', 30.0), ('estimator', 'motor_joint', 'm'),
                              ('estimator', 'motor_inertia', 0.02),
                              ('estimator', 'load_effort_sign', -1),
                              ('estimator', 'transmissions', ['a']),
                              ('estimator', 'state_file', '/tmp/x.json'),
                              ('diagnostics', 'ratio', 30.0),
                              ('diagnostics', 'transmissions', ['a']),
                              ('diagnostics', 'record_path', '/tmp/rec')]:
        result = rig.set_one(node, name, value)
        assert not result.successful, (node, name)
        assert result.reason == f'Trying to set a read-only parameter: {name}.'
    assert rig.get('estimator', ['ratio']) == [3.0]
    assert rig.fresh_status('estimator')['u'] == u


def test_each_health_parameter_applies_live_and_keeps_the_history(rig: Rig) -> None:
    rig.ensure_learned()
    before = rig.stable_state('diagnostics')
    assert before['latest'] is not None and before['levels']['eta_healthy'] != 'nan'
    saved_at = rig.state['diagnostics'].stat().st_mtime_ns
    names = set_each(rig, 'diagnostics', DIAGNOSTICS_SPECS, ('u', 'u_sigma', 'eta_healthy'))
    assert {'eta_opposing_min', 'eta_warn', 'warn_horizon', 'stale_timeout', 'trend',
            'transmission_name', 'hardware_id'} <= set(names)
    assert not {'ratio', 'rate', 'record_path', 'state_file'} & set(names)
    after = rig.saved('diagnostics', saved_at)['state']
    for key in ('history', 'trend', 'crossing'):
        assert after['predictor'][key] == before['predictor'][key], key
    for key in ('levels', 'utilisation', 'divergence'):
        assert after[key] == before[key], key
    # the latest assessment: the same but for the end of life and WARN efficiency in force
    same = {'u_eol': 0, 'eta_warn': 0}
    assert {**after['latest'], **same} == {**before['latest'], **same}
    status = rig.fresh_status('diagnostics')
    assert float(status['eta_warn']) == rig.get('diagnostics', ['eta_warn'])[0]   # in force
    # learning goes on from the kept history
    rig.feed(10.0)
    rig.driver.wait(lambda: rig.saved('diagnostics')['state']['latest']['stamp_ns']
                    > before['latest']['stamp_ns'], 20.0, 'a new assessment')
    assert float(rig.status('diagnostics')['eta_healthy']) == float(status['eta_healthy'])


def test_reset_forgets_logs_and_counts(rig: Rig) -> None:
    rig.ensure_learned()
    prior, prior_sigma = rig.get('estimator', ['initial_u', 'initial_u_sigma'])
    resets = int(rig.status('estimator')['resets'])
    saved_at = rig.state['estimator'].stat().st_mtime_ns
    response = rig.reset('estimator')
    assert response.success and 'learning reset' in response.message
    status = rig.fresh_status('estimator')
    assert float(status['u']) == prior and float(status['sigma_u']) == pytest.approx(prior_sigma)
    assert int(status['resets']) == resets + 1
    state = rig.saved('estimator', saved_at)['state']          # written at once
    assert state['filter']['x'][0] == prior
    # the diagnostics node
    resets = int(rig.status('diagnostics')['resets'])
    response = rig.reset('diagnostics')
    assert response.success and 'learning reset' in response.message
    status = rig.fresh_status('diagnostics')
    assert int(status['resets']) == resets + 1 and math.isnan(float(status['eta_healthy']))
    assert rig.saved('diagnostics')['state']['latest'] is None
    for node in ('estimator', 'diagnostics'):
        lines = [line for line in rig.logs[node].read_text(encoding='utf-8').splitlines()
                 if f'/{node}/reset: learning reset' in line]
        assert len(lines) >= 1, rig.logs[node].read_text(encoding='utf-8')[-2000:]
    # and learns again from the prior
    rig.ensure_learned()
