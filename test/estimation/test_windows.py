"""Energy windows (gear_phm.estimation.windows): inertia term, short windows (pure, seeded)."""
from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np

from gear_phm.estimation.powerflow import classify
from gear_phm.estimation.windows import EnergyIntegrator, to_measurement
from helpers.plant import lever_plant


def test_energy_window_removes_rotor_inertia_bias() -> None:
    run = lever_plant(3, 60.0, 0.1, noise=(0, 0, 0, 0), motor_inertia=0.05)
    code = classify(run.motor_effort * run.motor_velocity,
                    -run.load_effort * run.load_velocity, run.motor_velocity, 0.01, 0.01)
    results = {}
    for inertia in (0.0, 0.05):
        integ = EnergyIntegrator(1.0, 0.5, motor_inertia=inertia)
        windows = integ.process(run.t, run.motor_velocity, run.motor_effort, run.load_velocity,
                                run.load_effort, code, code > 0)
        meas = [to_measurement(w, 3.0, 0.2, 0.01, 1e-6) for w in windows]
        results[inertia] = np.array([m.u for m in meas if not isinstance(m, str)])
    assert np.max(np.abs(results[0.05] - 0.1)) < 2e-4
    assert np.max(np.abs(results[0.0] - 0.1)) > 5e-3      # uncorrected: biased per window


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 2**32 - 1), st.lists(st.integers(1, 400), min_size=1, max_size=6),
       st.sampled_from([0.005, 0.02, 0.2]))
def test_dropping_short_windows_early_equals_rejecting_them_later(
        seed: int, cuts: list[int], min_duration: float) -> None:
    """The integrator's shortcut (short one-segment windows are only counted) is exact.

    It gives the same windows and counts as building every window and rejecting the short ones
    afterwards, for any batch split. Phases flicker, with gaps, so most segments are short.
    """
    rng = np.random.default_rng(seed)
    n = 1200
    t = np.cumsum(rng.choice([0.001, 0.001, 0.001, 0.02], n))
    code = rng.choice([-1, 0, 1, 1, 1, 2, 2, 3], n)
    code = np.where(rng.random(n) < 0.9, np.repeat(code[::7], 7)[:n], code)
    w_m, w_l = rng.normal(5.0, 1.0, n), rng.normal(-1.5, 0.5, n)
    tau_m, tau_l = rng.normal(1.0, 0.2, n), rng.normal(2.5, 0.2, n)
    bounds = sorted({0, n, *[int(c) % n for c in np.cumsum(cuts)]})

    def windows(integrator: EnergyIntegrator) -> list:
        out = []
        for a, b in zip(bounds[:-1], bounds[1:]):
            out += [(w.code, w.t_start, w.t_end, w.samples, w.motor_energy, w.load_energy)
                    for w in integrator.process(t[a:b], w_m[a:b], tau_m[a:b], w_l[a:b],
                                                tau_l[a:b], code[a:b], code[a:b] > 0)]
        return out + [(w.code, w.t_start, w.t_end, w.samples, w.motor_energy, w.load_energy)
                      for w in integrator.flush()]

    every = windows(EnergyIntegrator(0.1, 0.015))
    fast = EnergyIntegrator(0.1, 0.015, min_duration=min_duration)
    kept = windows(fast)

    def short(w: tuple) -> bool:
        return w[2] - w[1] < min_duration or w[3] < 2
    assert fast.dropped_short > 0
    assert [w for w in kept if not short(w)] == [w for w in every if not short(w)]
    assert fast.dropped_short + sum(map(short, kept)) == sum(map(short, every))
