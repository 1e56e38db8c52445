"""The end-of-life threshold (gear_phm.prognostics.end_of_life): the least of the criteria."""
from __future__ import annotations

import pytest

from gear_phm.prognostics.end_of_life import end_of_life_u


def test_end_of_life_threshold_is_min_of_enabled_criteria() -> None:
    assert end_of_life_u(3.0, 0.5) == pytest.approx((0.6, 'eta_opposing_min'))
    # eta_D = 0.2 needs u = 3 * 0.8 / 1.6 = 1.5 > 1: self-locking (u = 1) binds first
    assert end_of_life_u(3.0, 0.2) == (1.0, 'self_locking')
    assert end_of_life_u(3.0, 0.2, self_locking_eol=False) == pytest.approx((1.5,
                                                                             'eta_opposing_min'))
    assert end_of_life_u(3.0, 0.5, u_max=0.3) == (0.3, 'u_max')
    with pytest.raises(ValueError, match='eta_opposing_min'):
        end_of_life_u(3.0, -0.5)
