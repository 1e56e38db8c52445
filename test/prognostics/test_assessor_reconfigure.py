"""HealthAssessor.reconfigure keeps the RUL history and levels; reset forgets them on purpose."""
from __future__ import annotations

import math

import pytest

from gear_phm.estimation.records import FrictionEstimate
from gear_phm.models.lever import efficiencies
from gear_phm.parameters import ParamSpec
from gear_phm.persistence import encode_float
from gear_phm.prognostics import HealthAssessor, HealthConfig, PARAMETERS
from gear_phm.status import OK, WARN
from helpers.params import other_value

CONFIG = HealthConfig(ratio=3.0, warn_horizon=600.0, level_dwell=0.0, mc_samples=500)
LIVE = [spec for spec in PARAMETERS if not spec.read_only]


def estimate(t: float) -> FrictionEstimate:
    """Linear wear u = 0.05 + 1.5e-4 t with a measurement each 10 s, half the time moving."""
    u = 0.05 + 1.5e-4 * t
    eta_d, eta_i = efficiencies(u, 3.0)
    return FrictionEstimate(int(t * 1e9), u, 1.5e-4, (1e-6, 0.0, 1e-12), eta_d, eta_i,
                            eta_d, 0.001, 1e-6, 1.0, samples_used=int(t), power_flow=1,
                            operating_time=0.5 * t, measurement=u, measurement_variance=1e-6,
                            direction_offset=0.0, measurement_direction=-0.5,
                            measurement_bias=0.0)


def run(assessor: HealthAssessor, start: float, stop: float) -> list:
    return [assessor.on_estimate(estimate(t)) for t in range(int(start), int(stop), 10)]


def learned(config: HealthConfig = CONFIG) -> HealthAssessor:
    assessor = HealthAssessor(config)
    run(assessor, 0, 1500)
    return assessor


def test_only_the_ratio_is_structural() -> None:
    assert [s.name for s in PARAMETERS if s.read_only] == ['ratio']


@pytest.mark.parametrize('spec', LIVE, ids=[s.name for s in LIVE])
def test_each_live_setting_keeps_the_history_and_the_levels(spec: ParamSpec) -> None:
    name = spec.name
    assessor = learned()
    before = assessor.to_state()
    assert before['levels']['eta_healthy'] != 'nan'               # learned
    config = CONFIG.replace(**{name: other_value(spec, getattr(CONFIG, name))})
    assessor.reconfigure(config)
    assert assessor.config == config
    after = assessor.to_state()
    assert after['predictor']['history'] == before['predictor']['history']
    assert after['levels'] == before['levels']
    # the latest state, with the end of life and WARN efficiency now in force
    assert after['latest']['u_eol'] == assessor.u_eol
    assert after['latest']['eta_warn'] == encode_float(assessor.levels.eta_warn)
    same = {'u_eol': 0, 'eta_warn': 0}
    assert {**after['latest'], **same} == {**before['latest'], **same}
    assert after['utilisation'] == before['utilisation']
    states = run(assessor, 1500, 1600)
    assert states[0].eta_healthy == assessor.levels.eta_healthy == pytest.approx(
        efficiencies(0.05, 3.0)[0], abs=0.01)
    assert math.isfinite(states[-1].rul.median) or states[-1].rul.model == 'none', name


def test_the_same_settings_change_nothing_downstream() -> None:
    plain, reconfigured = learned(), learned()
    reconfigured.reconfigure(CONFIG.replace())
    assert run(plain, 1500, 3000) == run(reconfigured, 1500, 3000)


def test_new_thresholds_take_effect_at_the_next_estimate() -> None:
    plain = learned()
    u_eol = plain.u_eol
    # a later end of life: u_eol up, the RUL refitted against it at once
    later = learned()
    later.reconfigure(CONFIG.replace(eta_opposing_min=0.3))
    assert later.u_eol > u_eol
    a, b = run(plain, 1500, 1510)[0], run(later, 1500, 1510)[0]
    assert b.u_eol == later.u_eol and b.rul_operating.median > a.rul_operating.median + 100.0
    # a WARN efficiency above the present one: WARN at once (level_dwell 0)
    warned = learned()
    eta_now = efficiencies(0.05 + 1.5e-4 * 1500, 3.0)[0]
    assert plain.latest is not None and plain.latest.level == OK
    warned.reconfigure(CONFIG.replace(eta_warn=min(eta_now + 0.05, 0.99)))
    state = run(warned, 1500, 1510)[0]
    assert state.level == WARN and state.eta_warn == pytest.approx(min(eta_now + 0.05, 0.99))


def test_a_ratio_change_is_refused() -> None:
    assessor = learned()
    before = assessor.to_state()
    with pytest.raises(ValueError, match='cannot reconfigure ratio'):
        assessor.reconfigure(CONFIG.replace(ratio=30.0))
    assert assessor.config == CONFIG and assessor.to_state() == before


def test_reset_forgets_the_history_and_learns_again() -> None:
    assessor = learned()
    assessor.reset()
    assert assessor.latest is None and math.isnan(assessor.levels.eta_healthy)
    assert len(assessor.predictor.history) == 0
    state = run(assessor, 1500, 1600)[-1]
    assert state.eta_healthy == pytest.approx(efficiencies(0.05 + 1.5e-4 * 1500, 3.0)[0],
                                              abs=0.01)
