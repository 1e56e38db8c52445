"""Prognostics, free of ROS: end of life, RUL, health levels, Saxena metrics, wear state.

See docs/prognostics.md. Everything takes time ``t`` [s] as an argument; nothing reads a clock.
"""
from gear_phm.prognostics.config import cross_field_problem, HealthConfig, PARAMETERS
from gear_phm.prognostics.end_of_life import end_of_life_thresholds, end_of_life_u
from gear_phm.prognostics.health import DivergenceMonitor, health_level, is_stale
from gear_phm.prognostics.monitor import (Estimate, HealthMonitor, HealthStatus, STATUS_KEYS,
                                          waiting_status)
from gear_phm.prognostics.options import add_health_arguments, health_config_from_args
from gear_phm.prognostics.rul import RulEstimate, RulPredictor, Trend, TrendDetector
from gear_phm.prognostics.state import load_wear_state, save_wear_state, WearState, WearStateSaver

__all__ = [
    'PARAMETERS', 'STATUS_KEYS', 'DivergenceMonitor', 'Estimate', 'HealthConfig',
    'HealthMonitor', 'HealthStatus', 'RulEstimate', 'RulPredictor', 'Trend', 'TrendDetector',
    'WearState', 'WearStateSaver', 'add_health_arguments', 'cross_field_problem',
    'end_of_life_thresholds', 'end_of_life_u', 'health_config_from_args', 'health_level',
    'is_stale', 'load_wear_state', 'save_wear_state', 'waiting_status',
]
