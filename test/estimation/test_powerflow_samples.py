"""Power-flow codes when both sides feed power in (eta_I < 0), offline and live alike."""
from __future__ import annotations

import itertools

import numpy as np

from gear_phm.estimation.powerflow import classify, classify_sample
from gear_phm.models.power_flow import AIDING, IDLE, IMPOSSIBLE, OPPOSING, SELF_LOCKING
from gear_phm.simulation.plant import Plant


def _flows(plant: Plant, u: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """P_m, P_l [W], w_m [rad/s] and the plant's phase over a swing out and back."""
    t = np.linspace(0.0, 2.0, 401)
    position = 0.3 * np.sin(np.pi * t)
    w_l = 0.3 * np.pi * np.cos(np.pi * t)
    acceleration = -0.3 * np.pi ** 2 * np.sin(np.pi * t)
    _, eta_d, eta_i = plant.efficiencies(u)
    tau_out = plant.output_torque(position, acceleration)
    tau_in, phase = plant.input_torque(tau_out, w_l, eta_d, eta_i)
    w_m = plant.ratio * w_l
    return tau_in * w_m, -tau_out * w_l, w_m, phase


def test_a_self_locking_plant_reads_self_locking_where_the_load_aids() -> None:
    plant = Plant(ratio=3.0)
    p_m, p_l, w_m, phase = _flows(plant, 1.2)          # eta_I = 3 (1 - 1.2) / 4.2 = -0.143
    assert set(phase.tolist()) == {OPPOSING, SELF_LOCKING}
    locking = phase == SELF_LOCKING
    assert locking.sum() > 100
    assert (p_m[locking] > 0.0).all() and (p_l[locking] > 0.0).all()   # both feed power in
    assert np.allclose(-p_m[locking] / p_l[locking], 3.0 * -0.2 / 4.2)   # eta_I < 0
    code = classify(p_m, p_l, w_m, 1e-6, 1e-6)
    out = (np.abs(p_m) > 1e-6) & (np.abs(p_l) > 1e-6)      # outside the deadband
    assert out.sum() >= 395 and (code[out] == phase[out]).all()
    assert (code[~out] == IDLE).all()
    live = np.array([classify_sample(a, b, c, 1e-6, 1e-6) for a, b, c in zip(p_m, p_l, w_m)])
    assert (live == code).all()
    # the same swing of a reversible gearbox (u 0.05) aids instead
    p_m, p_l, w_m, phase = _flows(plant, 0.05)
    assert set(phase.tolist()) == {OPPOSING, AIDING}
    out = (np.abs(p_m) > 1e-6) & (np.abs(p_l) > 1e-6)
    assert out.sum() >= 395 and (classify(p_m, p_l, w_m, 1e-6, 1e-6)[out] == phase[out]).all()


def test_the_live_sample_code_is_the_offline_code_at_and_around_the_deadband() -> None:
    values = [-2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0, float('nan'), float('inf')]
    rows = np.array(list(itertools.product(values, values, [0.0, 0.01, -0.3, 1.0])))
    code = classify(rows[:, 0], rows[:, 1], rows[:, 2], power_threshold=0.5,
                    speed_threshold=0.01)
    live = [classify_sample(a, b, c, 0.5, 0.01) for a, b, c in rows.tolist()]
    assert live == code.tolist()
    assert classify_sample(1.0, 1.0, 1.0, 0.5, 0.01) == SELF_LOCKING
    assert classify_sample(-1.0, -1.0, 1.0, 0.5, 0.01) == IMPOSSIBLE
