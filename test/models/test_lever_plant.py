"""Sanity tests of the seeded lever plant (helpers/plant.py) that the estimation tests use."""
from __future__ import annotations

import numpy as np

from gear_phm.models import eta_aiding, eta_opposing
from helpers.plant import lever_plant


def test_plant_power_balance_matches_lever_model() -> None:
    run = lever_plant(1, 20.0, 0.1, noise=(0, 0, 0, 0), motor_inertia=0.0)
    p_m = run.motor_effort * run.motor_velocity
    p_l = -run.load_effort * run.load_velocity
    opposing = p_m > 1.0
    assert np.allclose(-p_l[opposing] / p_m[opposing], eta_opposing(0.1, 3.0))
    aiding = p_l > 1.0
    assert np.allclose(-p_m[aiding] / p_l[aiding], eta_aiding(0.1, 3.0))
    assert opposing.sum() > 1000 and aiding.sum() > 1000
