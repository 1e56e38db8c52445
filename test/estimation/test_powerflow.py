"""Power-flow classification (gear_phm.estimation.powerflow): codes, deadband, signs."""
from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st
import numpy as np

from gear_phm.estimation.powerflow import classify


def test_classify_codes_and_deadband() -> None:
    p_m = np.array([10.0, -10.0, 10.0, -10.0, 0.05, 10.0, 10.0])
    p_l = np.array([-9.0, 9.0, 1.0, -1.0, -0.05, -9.0, 0.0])
    w_m = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 1.0])
    codes = classify(p_m, p_l, w_m, power_threshold=0.1, speed_threshold=0.01)
    assert codes.tolist() == [1, 2, 3, -1, 0, 0, 0]


@given(st.floats(-1e3, 1e3), st.floats(-1.0, 1.0), st.floats(0.0, 10.0), st.booleans())
def test_classify_is_idle_when_either_power_is_within_the_deadband(
        other: float, fraction: float, thr: float, motor_in_band: bool) -> None:
    small = fraction * thr                          # |small| <= thr: inside the deadband
    p_m, p_l = (small, other) if motor_in_band else (other, small)
    assert int(classify(p_m, p_l, 1.0, power_threshold=thr)) == 0


@given(st.floats(1e-6, 1e3), st.floats(1e-6, 1e3), st.floats(0.0, 10.0),
       st.sampled_from([1.0, -1.0]), st.sampled_from([1.0, -1.0]))
def test_classify_outside_the_deadband_depends_on_both_signs_only(
        excess_m: float, excess_l: float, thr: float, sign_m: float, sign_l: float) -> None:
    p_m, p_l = sign_m * (thr + excess_m), sign_l * (thr + excess_l)
    code = int(classify(p_m, p_l, 1.0, power_threshold=thr))
    assert code == {(1, -1): 1, (-1, 1): 2, (1, 1): 3, (-1, -1): -1}[(int(sign_m), int(sign_l))]
