"""Prognostics, free of ROS: end of life, RUL, health levels, Saxena metrics.

:class:`HealthAssessor` turns each :class:`~gear_phm.estimation.FrictionEstimate` into a
:class:`HealthState`. See docs/prognostics.md. Everything takes time from the estimates'
stamps and operating times; nothing reads a clock.
"""
from gear_phm.prognostics.assessor import HealthAssessor, HealthState, waiting_state
from gear_phm.prognostics.config import (cross_field_problem, derived_eta_warn, HealthConfig,
                                         PARAMETERS)
from gear_phm.prognostics.end_of_life import end_of_life_thresholds, end_of_life_u
from gear_phm.prognostics.fits import fit_trend, ShapePrior, Trend
from gear_phm.prognostics.health import DivergenceDetector, LevelTracker
from gear_phm.prognostics.history import Utilisation, WearHistory
from gear_phm.prognostics.predictor import RulEstimate, RulPredictor

__all__ = [
    'PARAMETERS', 'DivergenceDetector', 'HealthAssessor', 'HealthConfig', 'HealthState',
    'LevelTracker', 'RulEstimate', 'RulPredictor', 'ShapePrior', 'Trend', 'Utilisation',
    'WearHistory',
    'cross_field_problem', 'derived_eta_warn', 'end_of_life_thresholds', 'end_of_life_u',
    'fit_trend', 'waiting_state',
]
