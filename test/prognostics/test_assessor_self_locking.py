"""Self-locking in the health assessment: by design it is no fault; worn into, WARN or EOL."""
from __future__ import annotations

import math

import numpy as np

from gear_phm.estimation import FrictionEstimate
from gear_phm.models.lever import efficiencies
from gear_phm.prognostics import HealthAssessor, HealthConfig, HealthState
from gear_phm.prognostics.end_of_life import end_of_life_u
from gear_phm.status import ERROR, OK, WARN


def _estimate(t: float, u: float, ratio: float, sigma: float = 0.002) -> FrictionEstimate:
    eta_d, eta_i = efficiencies(u, ratio)
    return FrictionEstimate(int(round(t * 1e9)), u, 0.0, (sigma ** 2, 0.0, 1e-14),
                            eta_opposing=eta_d, eta_aiding=eta_i, innovation=0.0,
                            innovation_variance=1e-6, nis=1.0)


def _run(config: HealthConfig, us: np.ndarray) -> tuple[list[HealthState], HealthAssessor]:
    """One estimate a second at the friction values ``us``."""
    assessor = HealthAssessor(config)
    states = [assessor.on_estimate(_estimate(float(k), float(u), config.ratio))
              for k, u in enumerate(us)]
    assert all(state is not None for state in states)
    return [state for state in states if state is not None], assessor


def test_a_gearbox_self_locking_by_design_is_healthy() -> None:
    # a worm-like R 40 drive with u 1.2: eta_I = 40 (1 - 1.2) / 41.2 = -0.194 from the start
    ratio = 40.0
    assert efficiencies(1.2, ratio)[1] < 0.0
    for must in (False, True):
        config = HealthConfig(ratio=ratio, eta_opposing_min=0.3, must_back_drive=must,
                              mc_samples=200)
        states, assessor = _run(config, np.full(60, 1.2))
        assert {s.level for s in states} == {OK}, states[-1].message
        assert assessor.self_locking_when_healthy is True
        last = states[-1]
        assert last.rul.median == math.inf and last.rul_operating.p5 == math.inf
        assert last.eol_rule == 'eta_opposing_min'
        assert last.u_eol == end_of_life_u(ratio, 0.3, False)[0]      # 40 0.7 / 13 = 2.154
        assert abs(last.u_eol - 28.0 / 13.0) < 1e-12
        assert 'self-locking when healthy (by design)' in last.message
        # the judgement survives a restart
        restored = HealthAssessor(config)
        restored.from_state(assessor.to_state())
        assert restored.self_locking_when_healthy is True
        assert restored.latest is not None and restored.latest.eol_rule == 'eta_opposing_min'


def test_wear_into_self_locking_warns_unless_the_drive_must_back_drive() -> None:
    # R 3, u from 0.5 to 1.3 at 0.002/s: eta_I crosses 0 (u 1) at 250 s; eta_opposing_min 0.2
    # is u 1.5, never reached. eta_warn and warn_horizon out of the way.
    us = 0.5 + 0.002 * np.arange(400)
    base = HealthConfig(ratio=3.0, eta_opposing_min=0.2, eta_warn=0.21, warn_horizon=0.0,
                        mc_samples=200)
    states, assessor = _run(base, us)
    levels = [s.level for s in states]
    assert ERROR not in levels
    first = levels.index(WARN)
    # entered once u - 1.645 sigma >= 1 (u 1.0033, 252 s) has held for level_dwell 5 s
    assert 255 <= first <= 259, first
    assert set(levels[first:]) == {WARN} and set(levels[:first]) == {OK}
    assert states[first].message.startswith('now self-locking: cannot be back-driven')
    assert assessor.self_locking_when_healthy is False
    assert states[-1].eol_rule == 'eta_opposing_min' and abs(states[-1].u_eol - 1.5) < 1e-12

    states, _ = _run(base.replace(must_back_drive=True), us)
    levels = [s.level for s in states]
    assert WARN not in levels
    first = levels.index(ERROR)
    assert 255 <= first <= 259, first
    assert states[first].message.startswith(
        'end of life (self_locking, must_back_drive): now self-locking, cannot be back-driven')
    assert {s.eol_rule for s in states} == {'self_locking'}
    assert {s.u_eol for s in states} == {1.0}
    assert math.isfinite(states[first - 10].rul.median)       # the RUL ran to u = 1


def test_the_status_names_the_end_of_life_rule_that_applied() -> None:
    us = 0.05 + 0.002 * np.arange(200)                      # to 0.448; eta_opposing_min 0.7333
    config = HealthConfig(eta_opposing_min=0.7333, warn_horizon=0.0, mc_samples=200)
    states, _ = _run(config, us)
    error = next(s for s in states if s.level == ERROR)
    assert error.message.startswith('end of life (eta_opposing_min)'), error.message
    assert {s.eol_rule for s in states} == {'eta_opposing_min'}
    states, _ = _run(config.replace(u_max=0.2), us)
    error = next(s for s in states if s.level == ERROR)
    assert error.message.startswith('end of life (u_max)') and error.eol_rule == 'u_max'
