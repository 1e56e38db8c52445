"""EstimatorPipeline.reconfigure keeps what was learned; reset forgets it on purpose."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gear_phm.estimation import EstimatorConfig, EstimatorPipeline, PARAMETERS
from gear_phm.parameters import ParamSpec
from helpers.params import other_value
from helpers.plant import lever_plant

#: The lever plant of the tests: u = 0.1, 100 Hz, the node test's noise figures.
CONFIG = EstimatorConfig(ratio=3.0, motor_torque_noise=0.05, load_torque_noise=0.05,
                         motor_inertia=0.01)
RUN = lever_plant(3, 80.0, 0.1, rate=100.0)
HALF = RUN.t.size // 2
LIVE = [spec for spec in PARAMETERS if not spec.read_only]


def feed(pipeline: EstimatorPipeline, part: slice) -> list:
    return pipeline.on_batch(RUN.stamp_ns[part], RUN.motor_velocity[part],
                             RUN.motor_effort[part], RUN.load_velocity[part],
                             RUN.load_effort[part])


def learned() -> EstimatorPipeline:
    pipeline = EstimatorPipeline(CONFIG)
    feed(pipeline, slice(0, HALF))
    return pipeline


def test_the_structural_settings_are_the_read_only_ones() -> None:
    assert [s.name for s in PARAMETERS if s.read_only] == [
        'ratio', 'motor_inertia', 'motor_effort_sign', 'load_effort_sign', 'no_load_model']


@pytest.mark.parametrize('spec', LIVE, ids=[s.name for s in LIVE])
def test_each_live_setting_keeps_the_learned_state(spec: ParamSpec) -> None:
    pipeline = learned()
    before = pipeline.to_state()
    u, p = pipeline.filter.x[0], pipeline.filter.P[0, 0]
    assert abs(u - 0.1) < 0.01 and p < 1e-4                     # learned, far from the prior
    config = CONFIG.replace(**{spec.name: other_value(spec, getattr(CONFIG, spec.name))})
    pipeline.reconfigure(config)
    assert pipeline.config == config
    assert pipeline.filter.x[0] == u and pipeline.filter.P[0, 0] == p
    after = pipeline.to_state()
    if spec.name == 'process_noise':        # replaces the learned q, nothing else
        assert after['filter']['process_noise'] == config.process_noise
        after['filter']['process_noise'] = before['filter']['process_noise']
        after['filter']['q_test'] = before['filter']['q_test']
    if spec.name == 'publish_rate':         # the grid continues at the new rate
        t_last = (before['last_stamp'] - before['origin_ns']) * 1e-9
        assert after['grid'] == math.floor(t_last * config.publish_rate)
        after['grid'] = before['grid']
    assert after == before
    # the stream goes on from the learned u: no jump back to the prior
    outputs = feed(pipeline, slice(HALF, None))
    assert outputs and all(abs(o.u - 0.1) < 0.02 for o in outputs), spec.name


def test_the_same_settings_change_nothing_downstream() -> None:
    plain, reconfigured = learned(), learned()
    reconfigured.reconfigure(CONFIG.replace())
    a, b = feed(plain, slice(HALF, None)), feed(reconfigured, slice(HALF, None))
    assert a == b and plain.to_state() == reconfigured.to_state()
    assert plain.status('s', 0) == reconfigured.status('s', 0)


def test_the_new_settings_take_effect() -> None:
    plain = learned()
    ten_hz = feed(plain, slice(HALF, None))
    # the gate at 0: every window after the change is gated, u stays; then re-initialises
    gated = learned()
    gated.reconfigure(CONFIG.replace(gate_threshold=0.0, max_consecutive_gated=1_000_000))
    u = gated.filter.x[0]
    updates = gated.filter.updates
    feed(gated, slice(HALF, None))
    assert gated.filter.updates == updates and gated.filter.x[0] == pytest.approx(u, abs=1e-3)
    assert gated.counts['gated'] > 10
    # publish_rate 10 -> 2 Hz: a fifth of the periodic outputs
    slow = learned()
    slow.reconfigure(CONFIG.replace(publish_rate=2.0))
    two_hz = feed(slow, slice(HALF, None))
    assert 0.15 < len(two_hz) / len(ten_hz) < 0.35
    # the noise figures of the windows that close from now on: 4x the sigma, 16x the variance
    noisy = learned()
    noisy.reconfigure(CONFIG.replace(motor_torque_noise=0.2, load_torque_noise=0.2))
    quiet = [o.measurement_variance for o in ten_hz if math.isfinite(o.measurement)]
    loud = [o.measurement_variance for o in feed(noisy, slice(HALF, None))
            if math.isfinite(o.measurement)]
    assert np.median(loud) > 8.0 * np.median(quiet)
    # min_energy beyond every window: all low_energy from here on
    starved = learned()
    low = starved.counts['low_energy']
    windows = starved.windows_used
    starved.reconfigure(CONFIG.replace(min_energy=1e9))
    feed(starved, slice(HALF, None))
    assert starved.windows_used == windows and starved.counts['low_energy'] > low + 10


@pytest.mark.parametrize('name, value', [('ratio', 30.0), ('motor_inertia', 0.02),
                                         ('load_effort_sign', -1)])
def test_a_structural_change_is_refused(name: str, value: object) -> None:
    pipeline = learned()
    before = pipeline.to_state()
    with pytest.raises(ValueError, match=f'cannot reconfigure {name}: the learned state'):
        pipeline.reconfigure(CONFIG.replace(**{name: value}))
    assert pipeline.config == CONFIG and pipeline.to_state() == before


def test_reset_goes_back_to_the_prior_and_learns_again() -> None:
    pipeline = learned()
    seen, used = pipeline.samples_seen, pipeline.samples_used
    pipeline.reset()
    assert pipeline.filter.x[0] == CONFIG.initial_u
    assert pipeline.filter.P[0, 0] == pytest.approx(CONFIG.initial_u_sigma ** 2)
    assert pipeline.samples_seen == seen and pipeline.samples_used == used    # counters stay
    outputs = feed(pipeline, slice(HALF, None))
    assert abs(outputs[-1].u - 0.1) < 0.01
