"""Test the ratio set on the estimator and on the diagnostics node.

A mismatch is an ERROR with its reason, not a silently wrong end of life.
"""
from __future__ import annotations

import pytest

from gear_phm.estimation import FrictionEstimate
from gear_phm.models import efficiencies
from gear_phm.prognostics import HealthAssessor, HealthConfig
from gear_phm.status import ERROR, OK


def _estimate(u: float, estimator_ratio: float) -> FrictionEstimate:
    eta_d, eta_i = efficiencies(u, estimator_ratio)
    return FrictionEstimate(10**9, u, 0.0, (1e-6, 0.0, 1e-12), eta_d, eta_i)


def test_same_ratio_is_ok_and_mismatch_names_both_ratios() -> None:
    assessor = HealthAssessor(HealthConfig(ratio=30.0))
    assert assessor.on_estimate(_estimate(0.1, 30.0)).level == OK
    state = HealthAssessor(HealthConfig(ratio=30.0)).on_estimate(_estimate(0.1, 3.0))
    assert state.level == ERROR
    assert 'ratio mismatch' in state.message and 'ratio 3' in state.message
    assert 'ratio is 30' in state.message


@pytest.mark.parametrize('other', [29.97, 3.0, 300.0])
def test_mismatch_seen_from_a_tenth_of_a_percent(other: float) -> None:
    state = HealthAssessor(HealthConfig(ratio=30.0)).on_estimate(_estimate(0.2, other))
    assert state.level == ERROR and f'{other:.6g}' in state.message


@pytest.mark.integration
def test_diagnostics_node_reports_a_ratio_mismatch_with_the_estimator() -> None:
    rclpy = pytest.importorskip('rclpy')
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.node import Node

    from gear_phm.interfaces import DIAGNOSTICS
    from gear_phm.nodes.common import OUTPUT_QOS
    from helpers.diagnostics import Feeder, start, wait_for
    rclpy.init()
    node = Node('ratio_check_test')
    proc = start('ratio:=30.0', 'eta_opposing_min:=0.5', 'eta_warn:=0.6')  # Feeder uses R = 3
    try:
        arrays: list[DiagnosticArray] = []
        node.create_subscription(DiagnosticArray, DIAGNOSTICS, arrays.append, OUTPUT_QOS)
        feeder = Feeder(node)
        wait_for(node, lambda: feeder.matched() and arrays, 20.0, 'discovery')
        feeder.publish()
        feeder.publish()
        wait_for(node, lambda: any(b'\x02' == a.status[0].level and 'ratio mismatch'
                                   in a.status[0].message for a in arrays), 20.0,
                 'ERROR ratio mismatch')
        message = next(a.status[0].message for a in arrays if 'ratio mismatch'
                       in a.status[0].message)
        assert 'ratio is 30' in message
    finally:
        proc.terminate()
        assert proc.wait(timeout=30) == 0
        node.destroy_node()
        rclpy.try_shutdown()
