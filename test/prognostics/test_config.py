"""HealthConfig (gear_phm.prognostics.config): cross-field rules name the parameter."""
from __future__ import annotations

import pytest

from gear_phm.prognostics.config import HealthConfig


def test_config_cross_field_rules_name_the_parameter() -> None:
    with pytest.raises(ValueError, match='eta_warn must be > eta_opposing_min'):
        HealthConfig(eta_warn=0.5, eta_opposing_min=0.5)
    with pytest.raises(ValueError, match='mc_samples'):
        HealthConfig(mc_samples=10)
    with pytest.raises(ValueError, match='trend'):
        HealthConfig(trend='quadratic')
    assert HealthConfig().replace(eta_warn=0.9).eta_warn == 0.9
