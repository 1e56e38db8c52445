"""The architecture plants: each efficiency from its reference model's geometry and friction."""
from __future__ import annotations

import numpy as np
import pytest

from gear_phm.models import (GearTrain, LeadScrew, PlanetaryGearSet, SpurGear, Stage,
                             u_from_eta_opposing, WormGear)
from gear_phm.models.power_flow import OPPOSING, SELF_LOCKING
from gear_phm.simulation import config_from_parameters
from gear_phm.simulation.plant import EFFICIENCY_MODELS, Plant

FRICTION = np.array([0.02, 0.05, 0.1])


@pytest.mark.parametrize(('model', 'ratio', 'reference'), [
    ('gear_train', 4.0, GearTrain((SpurGear(20.0, 40.0, friction=FRICTION),) * 2)),
    ('planetary', 8.0, PlanetaryGearSet(20.0, 60.0, friction=FRICTION)),     # 1 + 140 / 20
    ('planetary', 3.0, PlanetaryGearSet(40.0, 20.0, friction=FRICTION)),     # 1 + 80 / 40
    ('worm', 30.0, WormGear(np.deg2rad(10.0), 1.0, 30.0, np.deg2rad(20.0), FRICTION)),
    ('screw', 30.0, LeadScrew(2 * np.pi / 30.0, 2 / (30.0 * np.tan(np.deg2rad(10.0))),
                              np.deg2rad(15.0), FRICTION)),
])
def test_plant_efficiencies_are_the_reference_models(model: str, ratio: float,
                                                     reference: Stage) -> None:
    plant = Plant(ratio=ratio, efficiency_model=model)
    assert float(plant.reference_model(0.05).ratio) == pytest.approx(ratio, rel=1e-12)
    u, eta_d, eta_i = plant.efficiencies(FRICTION)
    want_d, want_i = reference.efficiencies()
    np.testing.assert_allclose(eta_d, want_d, rtol=1e-12)
    np.testing.assert_allclose(eta_i, want_i, rtol=1e-12)
    np.testing.assert_allclose(u, u_from_eta_opposing(want_d, ratio), rtol=1e-12)
    assert (np.diff(eta_d) < 0.0).all() and (np.diff(eta_i) < 0.0).all()    # wear costs


def test_worm_plant_numbers_and_self_locking() -> None:
    # gamma 10 deg, mu 0.05, alpha_n 20 deg: phi' = atan(0.05 / cos 20) = 3.046 deg
    plant = Plant(ratio=30.0, efficiency_model='worm')
    _, eta_d, eta_i = plant.efficiencies(0.05)
    assert float(eta_d) == pytest.approx(np.tan(np.deg2rad(10)) / np.tan(np.deg2rad(13.046)),
                                         abs=1e-4)
    assert float(eta_d) == pytest.approx(0.7610, abs=1e-4)
    assert float(eta_i) == pytest.approx(0.6917, abs=1e-4)
    # lead angle 0.06 rad (3.44 deg) < phi' 7.27 deg at mu 0.12: the load cannot back-drive
    locked = Plant(ratio=30.0, efficiency_model='worm', lead_angle=0.06)
    _, eta_d, eta_i = locked.efficiencies(0.12)
    assert float(eta_d) == pytest.approx(0.3175, abs=1e-4)
    assert float(eta_i) == pytest.approx(-1.1172, abs=1e-4)
    _, phase = locked.input_torque(np.array([10.0, 10.0]), np.array([1.0, -1.0]), eta_d, eta_i)
    assert phase.tolist() == [OPPOSING, SELF_LOCKING]


def test_plants_refuse_a_geometry_naming_the_field() -> None:
    with pytest.raises(ValueError, match='ratio of the planetary plant must be > 2'):
        Plant(ratio=2.0, efficiency_model='planetary')
    with pytest.raises(ValueError, match='wheel_teeth'):
        Plant(ratio=0.5, efficiency_model='worm')
    with pytest.raises(ValueError, match='direction_offset applies to the lever plant only'):
        Plant(efficiency_model='worm', direction_offset=0.01)


def test_every_plant_is_a_simulation_parameter_choice() -> None:
    assert EFFICIENCY_MODELS == ('lever', 'spur', 'gear_train', 'planetary', 'worm', 'screw')
    config = config_from_parameters({'plant': 'worm', 'ratio': 40.0, 'lead_angle': 0.1})
    assert config.plant.efficiency_model == 'worm' and config.plant.lead_angle == 0.1
