"""Status reports of the pure logic: levels and key-value records (no ROS, no topic names).

The levels are diagnostic_msgs/DiagnosticStatus's (OK 0, WARN 1, ERROR 2, STALE 3); a
:class:`StatusOut` is what diagnostic_updater's DiagnosticStatusWrapper holds. The transports
(:mod:`gear_phm.interfaces` for bags, :mod:`gear_phm.nodes.transport` live) turn it into a
message; the estimator and the health assessor produce it.
"""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
import math

import numpy as np

OK, WARN, ERROR, STALE = 0, 1, 2, 3
LEVEL_NAMES = {OK: 'OK', WARN: 'WARN', ERROR: 'ERROR', STALE: 'STALE'}


@dataclass(frozen=True)
class StatusOut:
    """One DiagnosticStatus.

    Level (:data:`LEVEL_NAMES`), name, message, hardware id and KeyValue pairs (decimal
    strings, see :func:`format_value`).
    """

    level: int
    name: str
    message: str
    hardware_id: str
    values: tuple[tuple[str, str], ...] = ()


def format_value(value: float | int | str) -> str:
    """Format a KeyValue text: decimal strings, ``inf``/``-inf``/``nan`` for non-finite floats."""
    kind = type(value)
    if kind is float:                   # the common case: repr gives 'inf', '-inf', 'nan' too
        return repr(value)
    if kind is int:
        return str(value)
    if isinstance(value, str):
        return value
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        return str(int(value))
    value = float(value)
    if math.isnan(value):
        return 'nan'
    if math.isinf(value):
        return 'inf' if value > 0 else '-inf'
    return repr(value)


#: Types whose ``str`` is :func:`format_value` (a float's str is its repr).
_PLAIN = frozenset((float, int, str))


def format_values(values: Iterable[float | int | str]) -> tuple[str, ...]:
    """Return :func:`format_value` of each value (by ``str`` at once where that is the same)."""
    values = tuple(values)
    if set(map(type, values)) <= _PLAIN:
        return tuple(map(str, values))
    return tuple(map(format_value, values))
