"""An idle gap in a record: the gearbox stands still and nothing is published.

Elapsed time t [s] runs on through the gap (the oil cools, stamps jump over it); the
operating time s [s], which drives the duty cycle and the wear, stops during it::

    s(t) = t                              t < at
    s(t) = at                             at <= t < at + duration   (not published)
    s(t) = t - duration                   t >= at + duration

So the run after the gap continues the one before it where it stopped, from a colder oil
("the next day's run").
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.simulation._checks import non_negative


@dataclass(frozen=True)
class IdleGap:
    """One idle gap of ``duration`` [s] from elapsed time ``at`` [s]; duration 0: none."""

    at: float = 0.0
    duration: float = 0.0

    def __post_init__(self) -> None:
        non_negative('idle_gap_at', self.at)
        non_negative('idle_gap_duration', self.duration)

    @property
    def enabled(self) -> bool:
        """Return True if the gap lasts longer than 0 s."""
        return self.duration > 0.0

    def operating_time(self, t: ArrayLike) -> np.ndarray:
        """Operating time s [s] at elapsed times t [s] (t itself without a gap)."""
        t = np.asarray(t, dtype=float)
        if not self.enabled:
            return t
        result: np.ndarray = t - np.clip(t - self.at, 0.0, self.duration)
        return result

    def idle(self, t: ArrayLike) -> np.ndarray:
        """Return True at the elapsed times t [s] inside the gap (not published)."""
        t = np.asarray(t, dtype=float)
        inside: np.ndarray = (t >= self.at) & (t < self.at + self.duration)
        return inside

    def elapsed(self, s: float) -> float:
        """First elapsed time [s] at operating time ``s`` [s]."""
        return float(s) + self.duration if self.enabled and s > self.at else float(s)
