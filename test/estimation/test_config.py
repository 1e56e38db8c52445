"""EstimatorConfig (gear_phm.estimation.config): validation names the field and the value."""
from __future__ import annotations

import pytest

from gear_phm.estimation.config import EstimatorConfig
from gear_phm.models import eta_aiding, eta_opposing

NOISE = {'motor_torque_noise': 0.05, 'motor_speed_noise': 0.01, 'load_torque_noise': 0.05,
         'load_speed_noise': 0.01}

CONFIG = EstimatorConfig(ratio=3.0, motor_inertia=0.01, **NOISE)


def test_config_validation_names_field_and_value() -> None:
    with pytest.raises(ValueError, match=r'min_window must be < window .* got 2\.0'):
        EstimatorConfig(window=1.0, min_window=2.0)
    with pytest.raises(ValueError, match=r'ratio must be in .* got -1\.0'):
        EstimatorConfig(ratio=-1.0)
    with pytest.raises(ValueError, match='backwards_policy'):
        EstimatorConfig(backwards_policy='loop')
    with pytest.raises(ValueError, match='unknown'):
        CONFIG.replace(windw=2.0)
    assert eta_opposing(0.0, 3.0) == 1.0 and eta_aiding(0.0, 3.0) == 1.0
