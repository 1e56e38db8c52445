"""End-of-life rules: which criteria are enabled, and the self-locking-when-healthy test."""
from __future__ import annotations

import pytest

from gear_phm.prognostics.end_of_life import (end_of_life_thresholds, end_of_life_u,
                                              healthy_self_locking, U_SELF_LOCKING)


def test_self_locking_is_a_criterion_only_when_asked_for() -> None:
    assert end_of_life_thresholds(3.0, 0.2, False) == pytest.approx({'eta_opposing_min': 1.5})
    assert end_of_life_u(3.0, 0.2, True) == (U_SELF_LOCKING, 'self_locking')
    assert end_of_life_u(3.0, 0.2, True, u_max=0.9) == (0.9, 'u_max')


@pytest.mark.parametrize(('u_aiding', 'u_sigma', 'expected'), [
    (0.05, 0.01, False),          # sigma 0.01 <= 0.1 * 0.95
    (1.2, 0.01, True),            # eta_I < 0 from the start: self-locking by design
    (1.0, 0.0, True),             # eta_I = 0 exactly: self-locking (holds its load)
    (0.95, 0.01, None),           # 0.01 > 0.1 * 0.05: not settled, not judged
    (1.05, 0.006, None),
    (float('nan'), 0.01, None),
    (0.5, float('inf'), None),
])
def test_healthy_self_locking_is_judged_once_settled_on_one_side(
        u_aiding: float, u_sigma: float, expected: bool | None) -> None:
    assert healthy_self_locking(u_aiding, u_sigma) is expected
