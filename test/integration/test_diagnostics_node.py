"""Diagnostics node as a real subprocess over DDS.

Keys, levels, STALE, parameter checks, recording closed on SIGTERM, and recovery of the
recording after kill -9.
"""
from __future__ import annotations

import math
from pathlib import Path
import signal
import time

import pytest

rclpy = pytest.importorskip('rclpy')
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402, I100
from geometry_msgs.msg import Vector3Stamped  # noqa: E402
from mcap.reader import make_reader  # noqa: E402
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue  # noqa: E402
from rcl_interfaces.srv import GetParameters, SetParameters  # noqa: E402
from rclpy.node import Node  # noqa: E402

from gear_phm.bagio import BagReader, recover  # noqa: E402
from gear_phm.interfaces import (DIAGNOSTICS, ESTIMATOR_TOPICS, HEALTH_RUL,  # noqa: E402
                                 LEGACY_ESTIMATOR_TOPICS, OPERATING_TIME, stamp_to_ns)
from gear_phm.nodes.common import OUTPUT_QOS  # noqa: E402
from gear_phm.nodes.diagnostics import silent_among_others  # noqa: E402
from helpers.diagnostics import Feeder, start, wait_for  # noqa: E402
from helpers.processes import stop  # noqa: E402

pytestmark = [pytest.mark.integration, pytest.mark.timeout(120)]
KEYS = ['u', 'u_sigma', 'eta_opposing', 'eta_aiding', 'rul_s', 'rul_p5_s', 'rul_p95_s',
        'power_flow', 'samples_used', 'samples_rejected',
        'samples_missing', 'operating_time_s', 'rul_operating_s', 'rul_operating_p5_s',
        'rul_operating_p95_s', 'utilisation',
        'eta_healthy', 'eta_warn', 'resets']


@pytest.fixture(scope='module')
def ros():
    rclpy.init()
    node = Node('diagnostics_test')
    yield node
    node.destroy_node()
    rclpy.try_shutdown()


def assessed(array: DiagnosticArray) -> int:
    """Return the estimates the status counts (used and rejected)."""
    values = {kv.key: kv.value for kv in array.status[0].values}
    return int(values.get('samples_used', 0)) + int(values.get('samples_rejected', 0))


#: stale_timeout of the levels test [s]
STALE = 3.0


def test_levels_keys_stale_parameters_and_clean_close(ros: Node, tmp_path: Path) -> None:
    record = tmp_path / 'rec'
    # stale_timeout 3 s (the helper's 0.5 s, overridden): a feeder starved for more than 0.5 s
    # on a loaded machine (load 8-10) made the node STALE while it was still being fed
    proc = start(f'record_path:={record}', 'record_inputs:=true', f'stale_timeout:={STALE}')
    try:
        arrays: list[DiagnosticArray] = []
        sub = ros.create_subscription(DiagnosticArray, DIAGNOSTICS, arrays.append, OUTPUT_QOS)
        outputs: list[int] = []
        rul = ros.create_subscription(Vector3Stamped, HEALTH_RUL,
                                      lambda m: outputs.append(stamp_to_ns(m.header.stamp)),
                                      OUTPUT_QOS)
        feeder = Feeder(ros)
        wait_for(ros, lambda: feeder.matched() and arrays and rul.get_publisher_count() > 0,
                 20.0, 'discovery')
        # OK 'waiting for data' from start-up until the first input (STALE only once input
        # has been seen and stopped, below)
        assert arrays[-1].status[0].level == b'\x00', arrays[-1].status[0]
        assert arrays[-1].status[0].message == 'waiting for data'
        # cross-field check in the on-set callback: eta_warn below eta_opposing_min
        client = ros.create_client(SetParameters, '/diagnostics/set_parameters')
        assert client.wait_for_service(timeout_sec=10.0)
        request = SetParameters.Request(parameters=[Parameter(
            name='eta_warn', value=ParameterValue(type=ParameterType.PARAMETER_DOUBLE,
                                                  double_value=0.4))])
        future = client.call_async(request)
        wait_for(ros, future.done, 10.0, 'set_parameters')
        result = future.result().results[0]
        assert not result.successful and 'eta_warn must be > eta_opposing_min' in result.reason
        for k in range(400):                                # 0 .. 3990 s: EOL at 3667 s
            feeder.publish()
            rclpy.spin_once(ros, timeout_sec=0.005)
            # at most 50 updates ahead of the node's outputs, so that its input queue (depth
            # 100) never overflows however loaded the machine (397 of 400 were recorded once)
            wait_for(ros, lambda: len(outputs) >= k - 50, 30.0, 'the node keeping up')
        # the header stamp is the node's clock (diagnostic_updater's): the status of the last
        # estimate is the one that counts 400
        wait_for(ros, lambda: assessed(arrays[-1]) == 400, 10.0, 'last estimate on /diagnostics')
        assert abs(stamp_to_ns(arrays[-1].header.stamp) - time.time_ns()) < 30e9
        status = arrays[-1].status[0]
        assert status.name == 'gear_phm: left_aileron' and status.hardware_id == 'gb-7'
        assert [kv.key for kv in status.values] == KEYS
        assert status.level == b'\x02' and 'end of life' in status.message
        values = {kv.key: kv.value for kv in status.values}
        assert float(values['u']) == pytest.approx(0.05 + 1.5e-4 * 3990.0)
        assert values['rul_s'] == '0.0' and values['samples_used'] == '400'
        assert float(values['operating_time_s']) == 0.5 * 3990.0
        assert float(values['utilisation']) == pytest.approx(0.5)
        # the RUL in elapsed time is twice that in operating time (utilisation 0.5; the recent
        # duty's, to where its look-back starts between two updates)
        parsed = [{kv.key: float(kv.value) for kv in a.status[0].values} for a in arrays]
        finite = [v for v in parsed if 0.0 < v.get('rul_operating_s', 0.0) < math.inf]
        assert len(finite) >= 10
        assert all(v['rul_s'] == pytest.approx(2.0 * v['rul_operating_s'], rel=1e-2)
                   for v in finite)
        # every array received up to the last estimate's, not only those sampled while the
        # loop above published (under load, ERROR arrived after it)
        levels = [a.status[0].level for a in arrays]
        changes = [i for i, lv in enumerate(levels) if i == 0 or lv != levels[i - 1]]
        seen = [levels[i] for i in changes]
        # never STALE while fed; on failure, each change's stamp [s] and message (one run
        # under the full suite's load saw OK, WARN, OK, WARN, ERROR; not reproduced alone
        # or under 2 CPU burners)
        assert seen == [b'\x00', b'\x01', b'\x02'], [
            (lv, stamp_to_ns(arrays[i].header.stamp) * 1e-9, arrays[i].status[0].message)
            for lv, i in zip(seen, changes)]
        stopped = time.monotonic()
        wait_for(ros, lambda: arrays[-1].status[0].level == b'\x03', STALE + 5.0, 'STALE')
        assert time.monotonic() - stopped < STALE + 0.5     # timeout + 10 status periods
        ros.destroy_subscription(sub)
        ros.destroy_subscription(rul)
        assert stop(proc, signal.SIGTERM) == 0
    finally:
        stop(proc, signal.SIGKILL)                        # only if still running
    assert (record / 'metadata.yaml').exists()
    with BagReader(record) as bag:
        counts = {t: bag.message_count(t) for t in bag.topics}
    assert counts['/gear_phm/health/rul'] == 400
    assert counts['/gear_phm/friction'] == 400 and counts['/diagnostics'] > 10
    assert counts['/' + OPERATING_TIME] == 400
    with open(next(record.glob('*.mcap')), 'rb') as stream:
        reader = make_reader(stream)
        schemas = {s.name: s.encoding for s in reader.get_summary().schemas.values()}
        assert schemas['diagnostic_msgs/msg/DiagnosticArray'] == 'ros2msg'
        assert sum(1 for _ in reader.iter_messages(topics=['/gear_phm/health/rul'])) == 400


def test_only_eta_opposing_min_set_eta_warn_derived(ros: Node) -> None:
    """eta_opposing_min 0.9 alone (above the old fixed eta_warn 0.6) starts.

    The healthy eta_D is learned from the first estimate (u 0.05, eta_D 0.93651; sigma_u 1e-3
    is within 10 % of u_eol - u = 0.031): eta_warn 0.9 + 0.25 (0.93651 - 0.9) = 0.90913
    (the old rule gave 0.925), crossed at u 0.0731, 154 s.
    """
    proc = start('eta_opposing_min:=0.9', 'warn_horizon:=0.0')
    try:
        arrays: list[DiagnosticArray] = []
        sub = ros.create_subscription(DiagnosticArray, DIAGNOSTICS, arrays.append, OUTPUT_QOS)
        feeder = Feeder(ros)
        wait_for(ros, lambda: feeder.matched() and arrays, 20.0, 'discovery')
        client = ros.create_client(GetParameters, '/diagnostics/get_parameters')
        assert client.wait_for_service(timeout_sec=10.0)
        future = client.call_async(GetParameters.Request(names=['eta_warn', 'warn_horizon']))
        wait_for(ros, future.done, 10.0, 'get_parameters')
        eta_warn, warn_horizon = future.result().values
        assert math.isnan(eta_warn.double_value) and warn_horizon.double_value == 0.0
        statuses = []
        for k in range(30):              # u 0.05 + 1.5e-4 t: eta_warn at 154 s, EOL at 207 s
            feeder.publish()
            wait_for(ros, lambda: assessed(arrays[-1]) == k + 1, 10.0,
                     f'estimate {k} on /diagnostics')
            statuses.append(arrays[-1].status[0])
        ros.destroy_subscription(sub)
        assert stop(proc, signal.SIGTERM) == 0
    finally:
        stop(proc, signal.SIGKILL)                        # only if still running
    levels = [s.level for s in statuses]
    changes = [i for i in range(1, 30) if levels[i] != levels[i - 1]]
    # committed after the 5 s dwell: the second 10-s estimate past each threshold; end of
    # life once u - 1.645 sigma_u (sigma_u 1e-3) is past u_eol: 11 s after u, one more step
    assert [(i, levels[i]) for i in changes] == [(17, b'\x01'), (23, b'\x02')], levels
    eta_healthy = (3.0 - 0.05) / (3.0 * 1.05)
    eta_warn = 0.9 + 0.25 * (eta_healthy - 0.9)
    assert statuses[17].message == f'eta_D {(3.0 - 0.0755) / (3.0 * 1.0755):.4g} < ' \
                                   f'{eta_warn:.4g}'                          # t 170 s
    assert 'end of life (eta_opposing_min)' in statuses[23].message
    values = {kv.key: kv.value for kv in statuses[-1].values}
    assert values['operating_time_s'] == '145.0' and values['utilisation'] == '0.5'
    assert float(values['eta_healthy']) == pytest.approx(eta_healthy, rel=1e-9)
    assert float(values['eta_warn']) == pytest.approx(eta_warn, rel=1e-9)


def test_kill_9_recording_is_recoverable(ros: Node, tmp_path: Path,
                                         sigkill_safe_env: dict[str, str]) -> None:
    record = tmp_path / 'rec9'
    proc = start(f'record_path:={record}', 'record_flush_period:=0.5', env=sigkill_safe_env)
    try:
        received: list[tuple[float, int]] = []
        sub = ros.create_subscription(
            Vector3Stamped, HEALTH_RUL,
            lambda m: received.append((time.monotonic(), stamp_to_ns(m.header.stamp))),
            OUTPUT_QOS)
        feeder = Feeder(ros)
        wait_for(ros, lambda: feeder.matched() and sub.get_publisher_count() > 0, 20.0,
                 'discovery')
        # traffic until 30 outputs were received more than 1.5 s ago (so at least two flush
        # periods have passed over them), then kill at once; a fixed 3 s of traffic left no
        # file at all when a loaded machine (4 agents on 2 cores) delayed the node's start
        deadline = time.monotonic() + 60.0
        while not (len(received) > 30 and time.monotonic() - received[30][0] > 1.5):
            assert time.monotonic() < deadline, f'{len(received)} outputs in 60 s'
            feeder.publish()
            rclpy.spin_once(ros, timeout_sec=0.01)
        killed = time.monotonic()
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
        ros.destroy_subscription(sub)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert not (record / 'metadata.yaml').exists()
    [mcap_file] = record.glob('*.mcap')
    killed_bytes = mcap_file.read_bytes()
    older = {s for t, s in received if t < killed - 1.0}    # flush period 0.5 s + slack
    assert len(older) > 20
    result = recover(record)
    assert result.messages > 0 and result.backups == [record / f'{mcap_file.name}.orig']
    assert (record / f'{mcap_file.name}.orig').read_bytes() == killed_bytes
    assert [d.what for _, d in result.dropped] in (['end of file'], ['tail'])   # only the end
    with BagReader(record) as bag:
        name = bag.resolve_topic(HEALTH_RUL)
        stamps = [stamp_to_ns(m.header.stamp) for _, _, m in bag.messages([name])]
    assert older <= set(stamps), f'{len(older - set(stamps))} messages older than 1 s lost'
    # what is lost is the newest data only (the test may have missed a first message, so
    # compare the other way): every received message not recovered is newer than all that are
    missing = {s for _, s in received} - set(stamps)
    assert len(set(stamps)) == len(stamps) and stamps == sorted(stamps)
    assert not missing or min(missing) > stamps[-1], (len(missing), len(stamps))
    with open(mcap_file, 'rb') as stream:
        mcap_count = sum(1 for _ in make_reader(stream, validate_crcs=True).iter_messages(
            topics=[name]))
    assert mcap_count == len(stamps)


def test_assembler_keeps_stamp_order_and_waits_for_a_topic_that_comes_late() -> None:
    """A current estimator's update whose operating time comes after the next updates' topics.

    Under load the node took update 1's gear_phm/operating_time (which carries the window
    measurement, y and z) after update 2 was complete: update 1 went without it, and its
    measurement was missing from the RUL's history. It now waits, and the updates come out
    in stamp order; after STRAGGLER_LAG later complete updates it goes without (counted).
    """
    from types import SimpleNamespace

    from gear_phm.nodes.transport import EstimateAssembler, STRAGGLER_LAG
    assembler = EstimateAssembler()
    every = tuple(ESTIMATOR_TOPICS)
    others = tuple(t for t in every if t != OPERATING_TIME)

    def feed(stamp_ns: int, topics: tuple[str, ...], x: float = 0.1) -> list:
        out = []
        for topic in topics:
            out += assembler.add(topic, stamp_ns, SimpleNamespace(x=x, y=0.2, z=1e-6))
        return out

    assert [e.stamp_ns for e in feed(1, every, 7.0)] == [1]         # operating time seen
    assert feed(2, others) == []
    assert feed(3, every) == []                  # complete, but 2 still waits for its own
    late = feed(2, (OPERATING_TIME,), 8.0)
    assert [(e.stamp_ns, e.operating_time) for e in late] == [(2, 8.0), (3, 0.1)]
    assert assembler.dropped == {}
    # a topic that never comes: the update goes without it after STRAGGLER_LAG later ones
    assert feed(4, others) == []
    for stamp in range(5, 5 + STRAGGLER_LAG):
        assert feed(stamp, every) == []
    out = feed(5 + STRAGGLER_LAG, every)
    assert [e.stamp_ns for e in out] == list(range(4, 6 + STRAGGLER_LAG))
    assert math.isnan(out[0].operating_time) and out[1].operating_time == 0.1
    assert assembler.dropped == {'partial_update': 1}


def test_assembler_takes_older_streams_and_waits_for_operating_time() -> None:
    """Five topics (an older estimator) complete an update once LEGACY_LAG later ones have them.

    The first update of a current estimator waits for its gear_phm/operating_time (whatever
    the order of arrival, within LEGACY_LAG updates) and carries its x as the operating time
    [s]; from then on every update needs it.
    """
    from types import SimpleNamespace

    from gear_phm.nodes.transport import EstimateAssembler, LEGACY_LAG
    assert LEGACY_LAG == 3
    assembler = EstimateAssembler()

    def feed(stamp_ns: int, topics: tuple[str, ...]) -> list:
        out = []
        for k, topic in enumerate(topics):
            out += assembler.add(topic, stamp_ns, SimpleNamespace(x=0.1 + k, y=0.0, z=1e-6))
        return out

    assert feed(1, LEGACY_ESTIMATOR_TOPICS) == []           # may still get operating time
    assert feed(2, LEGACY_ESTIMATOR_TOPICS) == []           # still may (a current estimator
    assert feed(3, LEGACY_ESTIMATOR_TOPICS) == []           # sends it before update 2)
    assert feed(4, LEGACY_ESTIMATOR_TOPICS[:1]) == []       # a later topic: still may
    old = feed(4, LEGACY_ESTIMATOR_TOPICS[1:])              # 3 later updates: 1 is complete
    assert [e.stamp_ns for e in old] == [1] and math.isnan(old[0].operating_time)
    first = feed(2, (OPERATING_TIME,))                      # arrived last, not dropped
    assert [(e.stamp_ns, e.operating_time) for e in first] == [(2, 0.1)]
    assert feed(5, LEGACY_ESTIMATOR_TOPICS) == []           # now every update waits for it
    done = assembler.add(OPERATING_TIME, 3, SimpleNamespace(x=42.0, y=0.0, z=0.0))
    assert [(e.stamp_ns, e.operating_time) for e in done] == [(3, 42.0)]
    assert assembler.dropped == {}
    # a current estimator whose first operating time the node takes after the next updates'
    # other topics (separate subscriptions, taken in turn): the first update still gets it
    for ahead in (LEGACY_ESTIMATOR_TOPICS[:3], LEGACY_ESTIMATOR_TOPICS):
        assembler = EstimateAssembler()
        assert feed(1, LEGACY_ESTIMATOR_TOPICS) == []
        assert feed(2, ahead) == [] and feed(3, ahead) == []
        late = assembler.add(OPERATING_TIME, 1, SimpleNamespace(x=5.0, y=0.0, z=0.0))
        assert [(e.stamp_ns, e.operating_time) for e in late] == [(1, 5.0)]
        assert assembler.dropped == {}


def test_a_silent_drive_is_warn_among_others_then_stale() -> None:
    """A drive of many: WARN while silent and the others' input goes on, STALE at the timeout.

    From the silence, the others' silence and how far the drive's stamps are behind theirs
    (the 8-drive live test shows it on a bench, where load can skip the WARN).
    """
    never = lambda: 0.0         # noqa: E731  (stamps level with the others')
    late = lambda: 1.5          # noqa: E731  (1.5 s of stamps behind)
    timeout = 4.0
    assert not silent_among_others(1.9, timeout, 0.1, late)      # too short a silence
    assert silent_among_others(2.0, timeout, 0.1, late)           # behind the others' stamps
    assert not silent_among_others(2.0, timeout, 1.0, late)       # theirs not fresh either
    assert not silent_among_others(2.9, timeout, 0.1, never)      # level: a slow executor
    assert silent_among_others(3.0, timeout, 0.9, never)          # 3/4 of it, others fresh
    assert not silent_among_others(3.5, timeout, 1.0, never)      # everybody is silent
    assert not silent_among_others(4.0, timeout, 0.1, late)       # STALE now
