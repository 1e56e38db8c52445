"""No-load losses at the motor (gear_phm.simulation.no_load) and their place in the simulator."""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from gear_phm.simulation import SimulationConfig, SimulationResult, Simulator
from gear_phm.simulation.no_load import NoLoadLoss
from gear_phm.simulation.oil import Oil
from gear_phm.simulation.sensors import Channel, Sensors

QUIET = Sensors(Channel(), Channel(), Channel(), Channel())


def test_the_drag_torque_at_speed_and_viscosity_factor() -> None:
    loss = NoLoadLoss(coulomb=0.1, viscous=0.01)
    w = np.array([-10.0, 0.0, 5.0])
    np.testing.assert_allclose(loss.torque(w, 2.0), [-0.4, 0.0, 0.3], rtol=1e-12)
    coulomb, viscous = loss.parts(np.array([1.0, 3.0]))
    np.testing.assert_allclose(coulomb, [0.1, 0.3])
    np.testing.assert_allclose(viscous, [0.01, 0.03])
    assert np.all(loss.torque(w, 1.5) * w >= 0.0)               # always consumes power
    assert not NoLoadLoss().enabled and loss.enabled


def test_bad_drag_is_refused() -> None:
    with pytest.raises(ValueError, match='no_load_coulomb must be >= 0'):
        NoLoadLoss(coulomb=-1.0)


def _runs(**effects: Any) -> tuple[SimulationResult, SimulationResult]:
    t = np.arange(0.0, 60.0, 0.01)
    base = Simulator(SimulationConfig(sensors=QUIET, seed=4)).sample(t)
    run = Simulator(SimulationConfig(sensors=QUIET, seed=4, **effects)).sample(t)
    return base, run


def test_the_motor_torque_is_the_load_dependent_part_plus_the_drag() -> None:
    oil = Oil(warm_time_constant=20.0, cold_factor=2.5)
    base, run = _runs(no_load=NoLoadLoss(0.05, 0.004), oil=oil)
    np.testing.assert_allclose(run.true_effort_motor, base.true_effort_motor + run.no_load_torque,
                               rtol=0, atol=1e-12)
    np.testing.assert_array_equal(run.effort_load, base.effort_load)
    np.testing.assert_array_equal(run.eta_opposing, base.eta_opposing)
    # energy balance: the extra motor energy is the drag's, > 0 in both power-flow directions
    w = run.true_velocity_motor
    extra = (run.true_effort_motor - base.true_effort_motor) * w
    for phase in (1, 2):
        moving = run.phase == phase
        assert moving.sum() > 100 and np.all(extra[moving] >= 0.0) and extra[moving].sum() > 0


def test_the_drag_follows_the_oil_temperature_and_the_speed() -> None:
    oil = Oil(ambient_temperature=20.0, running_temperature=60.0, warm_time_constant=20.0,
              cold_factor=3.0)
    _, run = _runs(no_load=NoLoadLoss(0.05, 0.004), oil=oil)
    t = run.t
    temperature = 60.0 - 40.0 * np.exp(-t / 20.0)
    factor = np.exp(math.log(3.0) * (60.0 - temperature) / 40.0)
    w = run.true_velocity_motor
    np.testing.assert_allclose(run.oil_temperature, temperature, atol=1e-9)
    np.testing.assert_allclose(run.no_load_coulomb, 0.05 * factor, rtol=1e-12)
    np.testing.assert_allclose(run.no_load_viscous, 0.004 * factor, rtol=1e-12)
    np.testing.assert_allclose(run.no_load_torque, factor * (0.05 * np.sign(w) + 0.004 * w),
                               rtol=1e-12, atol=1e-15)
    # cold: three times the warm drag at the same speed
    assert run.drag_factor[0] == pytest.approx(3.0)
    assert run.drag_factor[-1] == pytest.approx(3.0 ** (40.0 * math.exp(-59.99 / 20.0) / 40.0))


def test_defaults_leave_the_motor_torque_unchanged() -> None:
    base, run = _runs()
    np.testing.assert_array_equal(run.effort_motor, base.effort_motor)
    np.testing.assert_array_equal(run.no_load_torque, 0.0)
