"""Another valid value of a parameter, for the tests that set each one (no ROS)."""
from __future__ import annotations

import math

from gear_phm.parameters import ParamSpec, Value

#: Values that keep the cross-field rules whatever else was changed before (eta_warn above
#: any eta_opposing_min here; min_window below window).
CHOSEN: dict[str, Value] = {'eta_warn': 0.9, 'eta_opposing_min': 0.55, 'u_max': 0.5,
                            'trend': 'linear', 'frame_id': 'bench_frame',
                            'transmission_name': 'renamed', 'hardware_id': 'gb-renamed'}


def other_value(spec: ParamSpec, current: Value) -> Value:
    """Return a valid value of ``spec`` that differs from ``current``."""
    if spec.name in CHOSEN and CHOSEN[spec.name] != current:
        return CHOSEN[spec.name]
    if isinstance(current, bool):
        return not current
    if spec.choices:
        return next(choice for choice in spec.choices if choice != current)
    if isinstance(current, str):
        return current + '_other'
    if isinstance(current, int):
        return current + 1 if spec.high is None or current + 1 <= spec.high else current - 1
    changed = 1.5 * current if current and math.isfinite(current) else 1e-3
    return min(changed, spec.high) if spec.high is not None else changed
