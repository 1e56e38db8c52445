"""The duty cycle (gear_phm.simulation.duty_cycle): the load's motion and its validation."""
from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from gear_phm.simulation.duty_cycle import DutyCycle


@settings(max_examples=40, deadline=None)
@given(accel=st.floats(0.01, 2.0), room=st.floats(0.0, 1.0))
def test_a_stroke_with_room_for_both_ramps_travels_the_whole_way_and_no_further(
        accel: float, room: float) -> None:
    stroke = 2 * accel + room * (5.0 - 2 * accel)   # stroke >= 2 accel, up to 5 s
    cycle = DutyCycle(extend_time=stroke, retract_time=stroke, accel_time=accel)
    x, v, _ = cycle.load_motion(np.linspace(0.0, cycle.period, 2001))
    assert x.max() == pytest.approx(cycle.travel, rel=1e-6)
    assert np.all(x >= -1e-12) and np.all(x <= cycle.travel + 1e-12)


@settings(max_examples=40, deadline=None)
@given(accel=st.floats(0.01, 2.0), fraction=st.floats(0.0, 0.999))
def test_a_stroke_without_room_for_both_ramps_is_refused(accel: float, fraction: float) -> None:
    stroke = max(0.005, fraction * 2 * accel)     # stroke < 2 accel
    with pytest.raises(ValueError, match='extend_time must be >= 2 accel_time'):
        DutyCycle(extend_time=stroke, retract_time=stroke, accel_time=accel)
