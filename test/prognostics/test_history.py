"""Utilisation: the elapsed-time RUL at the recent duty (gear_phm.prognostics.history)."""
from __future__ import annotations

import math

import pytest

from gear_phm.prognostics.history import CHECKPOINTS, Utilisation


def _run(utilisation: Utilisation, t0: float, s0: float, seconds: int, duty: float,
         step: float = 1.0) -> tuple[float, float]:
    """Update every ``step`` s of stamp time at ``duty`` operation; return the last (t, s)."""
    t, s = t0, s0
    for _ in range(int(seconds / step)):
        t += step
        s += duty * step
        utilisation.add(t, s)
    return t, s


def test_a_night_idle_before_the_run_stops_counting_after_the_window() -> None:
    utilisation = Utilisation(window=600.0)
    t, s = _run(utilisation, 0.0, 0.0, 1800, 1.0)
    utilisation.add(t + 8 * 3600.0, s)                  # the night: no operation
    t, s = _run(utilisation, t + 8 * 3600.0, s, 300, 1.0)
    # 300 s into today's run the newest 600 s of operation hold the night: utilisation < 1
    assert utilisation.fraction == pytest.approx(2100.0 / (2100.0 + 8 * 3600.0), rel=1e-3)
    assert utilisation.elapsed_for(100.0) > 1000.0
    t, s = _run(utilisation, t, s, 400, 1.0)
    # 700 s in, the night is older than the window: the run's own duty, continuous
    assert utilisation.elapsed_for(100.0) == pytest.approx(100.0, rel=1e-9)
    assert utilisation.elapsed_for(650.0) == pytest.approx(650.0, rel=1e-9)
    # a RUL longer than today's run looks back over the night
    assert utilisation.elapsed_for(1000.0) > 1000.0 + 8 * 3600.0 - 1.0
    assert utilisation.fraction < 0.1


def test_a_fleet_whose_weeks_idle_are_its_duty_keeps_them() -> None:
    utilisation = Utilisation(window=600.0)
    t = s = 0.0
    week = 7 * 86400.0
    for _ in range(40):                                 # 30 s recordings a week apart
        t, s = _run(utilisation, t, s, 30, 1.0)
        t += week
        utilisation.add(t, s)
    q = 100.0
    # 100 s of operation take the last 600 s of operation's duty: 20 recordings
    assert utilisation.elapsed_for(q) == pytest.approx(q / utilisation.recent_fraction(600.0))
    assert utilisation.recent_fraction(600.0) == pytest.approx(30.0 / (30.0 + week), rel=0.06)


def test_continuous_duty_maps_as_the_whole_history_and_quantiles_stay_ordered() -> None:
    utilisation = Utilisation(window=60.0)
    _run(utilisation, 0.0, 0.0, 3000, 0.8)
    values = [utilisation.elapsed_for(q) for q in (1.0, 10.0, 100.0, 1000.0, 1e5)]
    assert values == sorted(values)
    assert values[2] == pytest.approx(100.0 / 0.8, rel=1e-6)
    assert utilisation.elapsed_for(0.0) == 0.0
    assert math.isnan(utilisation.elapsed_for(math.nan))
    assert utilisation.elapsed_for(math.inf) == math.inf


def test_checkpoints_stay_bounded_and_survive_the_state() -> None:
    utilisation = Utilisation(window=600.0)
    t, s = _run(utilisation, 0.0, 0.0, 20 * CHECKPOINTS, 1.0)
    assert len(utilisation.to_state()['points']) <= 2 * CHECKPOINTS
    utilisation.add(t + 3600.0, s)
    _run(utilisation, t + 3600.0, s, 100, 1.0)
    restored = Utilisation(window=600.0)
    restored.from_state(utilisation.to_state())
    for q in (10.0, 700.0, 5000.0):
        assert restored.elapsed_for(q) == utilisation.elapsed_for(q)


def test_an_older_state_without_checkpoints_loads() -> None:
    old = {'operating': 100.0, 'elapsed': 200.0, 'last': [200.0, 100.0]}
    utilisation = Utilisation()
    utilisation.from_state(old)
    assert utilisation.fraction == 0.5
    assert utilisation.elapsed_for(10.0) == pytest.approx(20.0)
    with pytest.raises(ValueError):
        utilisation.from_state({**old, 'points': [1.0, 2.0, 3.0]})
