"""Load amplitude varying per cycle and within a cycle (gear_phm.simulation.load_variation)."""
from __future__ import annotations

import numpy as np
import pytest

from gear_phm.simulation import DutyCycle, SimulationConfig, Simulator
from gear_phm.simulation.load_variation import LoadVariation

PERIOD = DutyCycle().period          # 5.5 s


def test_one_factor_per_cycle_uniform_in_its_range() -> None:
    variation = LoadVariation(scale_min=0.3, scale_max=1.0)
    starts = np.arange(5000) * PERIOD
    factors = variation.scale(starts + 0.1, PERIOD, seed=7)
    assert factors.min() >= 0.3 and factors.max() <= 1.0
    assert factors.min() < 0.31 and factors.max() > 0.99     # the range is covered
    assert factors.mean() == pytest.approx(0.65, abs=0.01)   # uniform: (0.3 + 1) / 2
    assert factors.std() == pytest.approx(0.7 / np.sqrt(12.0), rel=0.03)
    # constant within a cycle, another draw in the next one
    np.testing.assert_array_equal(variation.scale(starts + 5.3, PERIOD, seed=7), factors)
    assert np.mean(np.diff(factors) != 0.0) > 0.99
    # seeded: the same seed the same factors, another seed others
    np.testing.assert_array_equal(variation.scale(starts + 0.1, PERIOD, seed=7), factors)
    assert not np.array_equal(variation.scale(starts + 0.1, PERIOD, seed=8), factors)


def test_the_modulation_is_smooth_and_bounded() -> None:
    variation = LoadVariation(modulation=0.2, frequency=0.3)
    t = np.arange(0.0, 2000.0, 0.01)
    scale = variation.scale(t, PERIOD, seed=1)
    assert scale.min() >= 0.8 - 1e-12 and scale.max() <= 1.2 + 1e-12
    assert scale.min() < 0.85 and scale.max() > 1.15
    assert scale.mean() == pytest.approx(1.0, abs=0.01)
    # smooth: a step of 10 ms moves it by at most 2 pi f_max A dt = 2 pi 0.45 0.2 0.01
    assert np.abs(np.diff(scale)).max() <= 2 * np.pi * 0.45 * 0.2 * 0.01 + 1e-12


def test_the_scale_is_closed_form_in_any_order() -> None:
    variation = LoadVariation(scale_min=0.2, scale_max=0.9, modulation=0.1)
    t = np.random.default_rng(2).uniform(0.0, 3e5, 4000)    # crosses blocks of 4096 cycles
    whole = variation.scale(t, PERIOD, seed=3)
    order = np.argsort(t)
    np.testing.assert_array_equal(variation.scale(t[order], PERIOD, seed=3), whole[order])


def test_the_simulator_scales_the_air_load_only() -> None:
    t = np.arange(0.0, 40.0, 0.01)
    variation = LoadVariation(scale_min=0.3, scale_max=1.0, modulation=0.1)
    base = Simulator(SimulationConfig(seed=2)).sample(t)
    run = Simulator(SimulationConfig(seed=2, load_variation=variation)).sample(t)
    plant = SimulationConfig().plant
    scale = variation.scale(t, PERIOD, seed=2)
    inertial = base.true_effort_load - (plant.air_load_preload
                                        + plant.air_load_stiffness * base.position_load)
    np.testing.assert_allclose(run.true_effort_load, inertial + scale * (
        plant.air_load_preload + plant.air_load_stiffness * base.position_load), atol=1e-9)
    np.testing.assert_array_equal(run.load_scale, scale)
    np.testing.assert_array_equal(base.load_scale, 1.0)


@pytest.mark.parametrize('kwargs, message', [
    ({'scale_min': 0.5, 'scale_max': 0.4}, 'load_scale_min must be <= load_scale_max'),
    ({'modulation': 1.0}, 'load_modulation must be < 1'),
    ({'scale_min': 0.0}, 'load_scale_min must be > 0'),
])
def test_bad_load_variations_are_refused(kwargs: dict[str, float], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        LoadVariation(**kwargs)
