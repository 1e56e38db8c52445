"""Stages in series (gear_phm.models.GearTrain, series_efficiencies)."""
from __future__ import annotations

from dataclasses import dataclass
import math

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from gear_phm.models import HelicalGear, ModelError, SpurGear, WormGear
from gear_phm.models.gear_train import GearTrain, series_efficiencies

SETTINGS = settings(max_examples=200, deadline=None, derandomize=True)


@dataclass(frozen=True)
class Fixed:
    """A stage with given efficiencies."""

    ratio: float
    eta_d: float
    eta_i: float

    def efficiencies(self) -> tuple[float, float]:
        return self.eta_d, self.eta_i


def test_spur_and_helical_stages_multiply() -> None:
    first = SpurGear(20, 60, 2e-3, math.radians(20.0), friction=0.08, bearing_radius_1=2e-3)
    second = HelicalGear(18, 72, 1.5e-3, math.radians(20.0), math.radians(20.0), friction=0.05,
                         bearing_radius_2=4e-3)
    third = SpurGear(25, 50, 3e-3, math.radians(25.0), friction=0.1)
    train = GearTrain((first, second, third))
    assert train.ratio == pytest.approx(3.0 * 4.0 * 2.0, rel=1e-15)
    effs = [stage.efficiencies() for stage in (first, second, third)]
    eta_d, eta_i = train.efficiencies()
    assert eta_d == pytest.approx(effs[0][0] * effs[1][0] * effs[2][0], rel=1e-12)
    assert eta_i == pytest.approx(effs[0][1] * effs[1][1] * effs[2][1], rel=1e-12)


@SETTINGS
@given(d=st.lists(st.floats(0.05, 1.0), min_size=1, max_size=5),
       i=st.lists(st.floats(0.0, 1.0), min_size=5, max_size=5))
def test_reversible_stages_multiply_both_ways(d: list[float], i: list[float]) -> None:
    stages = [Fixed(2.0, eta_d, eta_i) for eta_d, eta_i in zip(d, i)]
    eta_d, eta_i = GearTrain(tuple(stages)).efficiencies()
    assert eta_d == pytest.approx(math.prod(d), rel=1e-12)
    assert eta_i == pytest.approx(math.prod(i[:len(d)]), rel=1e-12, abs=1e-300)


@SETTINGS
@given(upstream=st.lists(st.floats(0.05, 1.0), min_size=0, max_size=4),
       locking=st.floats(-3.0, -1e-6), eta_d_last=st.floats(0.05, 1.0))
def test_self_locking_stage_at_the_load_needs_the_motor_through_the_others(
        upstream: list[float], locking: float, eta_d_last: float) -> None:
    """Energy: the motor feeds -eta_I,n per unit load power, through the upstream eta_D's."""
    stages = [Fixed(3.0, eta_d, 0.9) for eta_d in upstream] + [Fixed(40.0, eta_d_last, locking)]
    eta_d, eta_i = GearTrain(tuple(stages)).efficiencies()
    assert eta_d == pytest.approx(math.prod(upstream) * eta_d_last, rel=1e-12)
    assert eta_i == pytest.approx(locking / math.prod(upstream), rel=1e-12)


def test_self_locking_stage_in_the_middle() -> None:
    # Load -> stage 3 (eta_I 0.8) -> worm (eta_I -0.5) -> stage 1 (eta_D 0.9) -> motor.
    stages = (Fixed(2.0, 0.9, 0.85), Fixed(40.0, 0.4, -0.5), Fixed(3.0, 0.95, 0.8))
    eta_i = GearTrain(stages).efficiencies()[1]
    assert eta_i == pytest.approx(0.8 * -0.5 / 0.9, rel=1e-12)


def test_jammed_stage_makes_the_train_undefined() -> None:
    stages = (Fixed(2.0, 0.9, 0.85), Fixed(2.0, -0.1, 0.3))
    eta_d, eta_i = GearTrain(stages).efficiencies()
    assert math.isnan(eta_d)
    assert eta_i == pytest.approx(0.85 * 0.3, rel=1e-12)
    # Behind a self-locking stage the jammed one would have to be driven: undefined.
    eta_i = GearTrain((Fixed(2.0, -0.1, 0.3), Fixed(40.0, 0.4, -0.5))).efficiencies()[1]
    assert math.isnan(eta_i)


def test_worm_then_spur_arrays_broadcast() -> None:
    worm = WormGear(np.radians([3.0, 8.0, 20.0]), 1, 40, friction=0.06)
    spur = SpurGear(20, 60, friction=0.05)
    eta_d, eta_i = GearTrain((spur, worm)).efficiencies()
    worm_d, worm_i = worm.efficiencies()
    spur_d, spur_i = spur.efficiencies()
    assert np.allclose(eta_d, spur_d * worm_d, rtol=1e-12)
    expected_i = np.where(worm_i > 0, worm_i * spur_i, worm_i / spur_d)
    assert np.allclose(eta_i, expected_i, rtol=1e-12)
    assert np.shape(GearTrain((spur, worm)).ratio) == ()
    assert GearTrain((spur, worm)).ratio == pytest.approx(120.0)


def test_bad_stages_raise_model_error() -> None:
    with pytest.raises(ModelError, match=r'^stages must hold at least one stage, got none$'):
        GearTrain(())
    with pytest.raises(ModelError, match=r'^stages\[1\] must be a stage model'):
        GearTrain((SpurGear(20, 60), 3.0))          # type: ignore[arg-type]
    with pytest.raises(ModelError, match=r'^stages must hold at least one stage'):
        series_efficiencies([])
