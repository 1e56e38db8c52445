"""LevelTracker: the "now self-locking" WARN of a gearbox that back-drove when healthy."""
from __future__ import annotations

from gear_phm.prognostics.health import LevelTracker
from gear_phm.status import OK, WARN


def _tracker(watch: bool) -> LevelTracker:
    tracker = LevelTracker(1.5, 'eta_opposing_min', 0.21, 0.0, level_hysteresis=0.05,
                           level_dwell=0.0, level_clear_dwell=0.0)
    tracker.watch_self_locking = watch
    return tracker


def test_self_locking_warns_only_on_a_gearbox_that_back_drove_when_healthy() -> None:
    assert _tracker(False).update(0.0, 1.1, 0.3, float('inf'), u_aiding=1.1) == (OK, 'ok')
    level, message = _tracker(True).update(0.0, 1.1, 0.3, float('inf'), u_aiding=1.1)
    assert level == WARN
    assert message == ('now self-locking: cannot be back-driven (aiding reading u 1.1 >= 1, '
                       'eta_I <= 0)')


def test_self_locking_warn_needs_u_past_1_beyond_its_noise_and_clears_with_hysteresis() -> None:
    tracker = _tracker(True)
    # u_aiding 1.01 with sigma 0.01: 1.01 - 1.645 0.01 < 1, not yet
    assert tracker.update(0.0, 1.01, 0.3, float('inf'), u_sigma=0.01, u_aiding=1.01)[0] == OK
    assert tracker.update(1.0, 1.02, 0.3, float('inf'), u_sigma=0.01, u_aiding=1.02)[0] == WARN
    # stays until below 1 (1 - 0.05) = 0.95
    level, message = tracker.update(2.0, 0.96, 0.3, float('inf'), u_sigma=0.01, u_aiding=0.96)
    assert level == WARN and 'clearing' in message
    assert tracker.update(3.0, 0.94, 0.3, float('inf'), u_sigma=0.01, u_aiding=0.94) == (OK, 'ok')


def test_an_older_state_without_the_self_locking_latch_restores() -> None:
    tracker = _tracker(True)
    state = tracker.to_state()
    del state['locked']
    restored = _tracker(True)
    restored.from_state(state)
    assert restored.latches['locked'].active is False
