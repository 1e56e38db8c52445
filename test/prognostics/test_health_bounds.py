"""The filter checks' bound (gear_phm.prognostics.health.chi_square_mean_bound)."""
from __future__ import annotations

import pytest

from gear_phm.prognostics.health import chi_square_mean_bound


@pytest.mark.parametrize('window', [3, 20, 100])
def test_chi_square_bound_close_to_exact(window: int) -> None:
    from scipy.stats import chi2         # here, not at collection: 0.7 s of CPU per worker
    exact = chi2.ppf(0.999, window) / window
    assert chi_square_mean_bound(window, 0.999) == pytest.approx(exact, rel=0.02)
