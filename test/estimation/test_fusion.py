"""WindowFusion: closed energy windows into the filter, and the estimates it gives."""
from __future__ import annotations

import math

import pytest

from gear_phm.estimation import EnergyIntegrator, EstimatorConfig
from gear_phm.estimation.fusion import WindowFusion
from gear_phm.estimation.powerflow import classify
from gear_phm.estimation.quality import DataQuality
from gear_phm.estimation.reasons import ALL_REASONS
from gear_phm.estimation.windows import Measurement, Window
from gear_phm.models.lever import efficiencies
from helpers.plant import lever_plant

#: The lever plant of the tests: u = 0.1, 100 Hz.
CONFIG = EstimatorConfig(ratio=3.0, motor_torque_noise=0.05, load_torque_noise=0.05,
                         motor_inertia=0.01)
RUN = lever_plant(3, 60.0, 0.1, rate=100.0)


def _windows(config: EstimatorConfig = CONFIG) -> list[Window]:
    c = config
    integrator = EnergyIntegrator(c.window, c.sensor_timeout, c.motor_inertia, c.load_inertia,
                                  (c.motor_torque_noise, c.motor_speed_noise,
                                   c.load_torque_noise, c.load_speed_noise),
                                  min_duration=c.min_window)
    w_m, tau_m, w_l, tau_l = (RUN.motor_velocity, RUN.motor_effort, RUN.load_velocity,
                              RUN.load_effort)
    code = classify(tau_m * w_m, -tau_l * w_l, w_m, c.power_threshold, c.speed_threshold)
    return integrator.process(RUN.t, w_m, tau_m, w_l, tau_l, code, code > 0)


def test_fused_windows_learn_u_and_each_gives_its_estimate() -> None:
    fusion = WindowFusion(CONFIG)
    counts = dict.fromkeys(ALL_REASONS, 0)
    quality = DataQuality()
    seen: list[tuple[Measurement, bool]] = []
    windows = _windows()
    fused = [fusion.fuse(w, w.t_end, counts, quality, lambda m, ok: seen.append((m, ok)))
             for w in windows]
    taken = [f for f in fused if f is not None]
    assert len(windows) > 10 and len(taken) >= 0.8 * len(windows)
    assert len(seen) == quality.windows_measured == len(windows) - sum(
        counts[r] for r in ('short_window', 'low_energy', 'wrong_energy_sign', 'out_of_domain'))
    assert fusion.filter.updates == sum(ok for _, ok in seen)
    assert abs(float(fusion.filter.x[0]) - 0.1) < 0.01
    assert {f[3] for f in taken} <= {-0.5, 0.5}             # each window's direction share
    assert fusion.last_eta == seen[-1][0].eta
    estimate = fusion.estimate(123, 900, 40, 1, 50.0, taken[-1])
    assert (estimate.stamp_ns, estimate.samples_used, estimate.samples_rejected,
            estimate.power_flow, estimate.operating_time) == (123, 900, 40, 1, 50.0)
    assert estimate.u == float(fusion.filter.x[0])
    assert estimate.eta_opposing == efficiencies(estimate.u + fusion.filter.direction_bias(0),
                                                 3.0)[0]
    assert estimate.measurement == pytest.approx(
        taken[-1][0] + estimate.rate * (50.0 - taken[-1][2]), rel=1e-12)
    assert math.isnan(estimate.no_load_torque)              # no no-load model
    base = fusion.prediction_base()
    assert base.t == fusion.filter.t and base.fixed[0] == fusion.last_eta


def test_without_an_identified_no_load_loss_windows_are_held() -> None:
    config = CONFIG.replace(no_load_model=True)
    fusion = WindowFusion(config)
    counts = dict.fromkeys(ALL_REASONS, 0)
    windows = _windows(config)[:3]          # constant load: not identifiable at first
    assert [fusion.fuse(w, w.t_end, counts, DataQuality()) for w in windows] == [None] * 3
    assert counts['not_identifiable'] == 3 and fusion.filter.updates == 0
    assert set(fusion.no_load_summary(0.9)) >= {'no_load_torque', 'total_efficiency'}
