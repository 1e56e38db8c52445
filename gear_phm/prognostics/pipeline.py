"""The diagnostics node's logic without ROS: assemble estimator updates, run the monitor.

The estimator publishes five Vector3Stamped topics with identical stamps per update. This
class groups them by stamp (tolerating stragglers and a replay that restarts), turns each
group into an :class:`Estimate`, runs :class:`HealthMonitor` and returns the numeric health
outputs. The live node and ``gear-phm analyze`` both call it, so they compute the same thing.
"""
from __future__ import annotations

from typing import Any

from gear_phm.interfaces import (COUNTS, EFFICIENCY, FRICTION, FRICTION_COVARIANCE, INNOVATION,
                                 Vector3Out)
from gear_phm.prognostics.config import HealthConfig
from gear_phm.prognostics.monitor import Estimate, HealthMonitor, HealthStatus

INPUTS = (FRICTION, FRICTION_COVARIANCE, EFFICIENCY, INNOVATION, COUNTS)
MAX_PENDING_STAMPS = 64
#: Stamps further back than this are a new run (replay restarted), not stragglers [ns].
RESTART_JUMP_NS = 10 * 10**9


class HealthPipeline:
    """Estimator topics in, health outputs out. ``dropped`` counts unusable inputs by reason."""

    def __init__(self, config: HealthConfig, transmission_name: str, hardware_id: str) -> None:
        self.monitor = HealthMonitor(config)
        self.transmission_name = transmission_name
        self.hardware_id = hardware_id
        self.pending: dict[int, dict[str, Any]] = {}
        self.dropped: dict[str, int] = {}

    def _drop(self, reason: str) -> None:
        self.dropped[reason] = self.dropped.get(reason, 0) + 1

    def on_input(self, topic: str, stamp_ns: int, vector: Any) -> list[Vector3Out]:
        """One estimator message (``vector`` has .x .y .z); returns health/rul and
        health/efficiency records for every update completed by it."""
        latest = self.monitor.latest
        if latest is not None and stamp_ns <= latest.stamp_ns and stamp_ns not in self.pending \
                and latest.stamp_ns - stamp_ns < RESTART_JUMP_NS:
            self._drop('late_stamp')       # a straggler of an update already processed
            return []
        group = self.pending.setdefault(stamp_ns, {})
        group[topic] = vector
        if len(group) == len(INPUTS):
            return self.flush(up_to=stamp_ns)
        if len(self.pending) > MAX_PENDING_STAMPS:
            return self.flush(up_to=min(self.pending))
        return []

    def flush(self, up_to: int | None = None) -> list[Vector3Out]:
        """Process pending groups with stamps <= ``up_to`` (all if None) in stamp order;
        incomplete ones need at least friction and covariance, else they are dropped."""
        outputs: list[Vector3Out] = []
        for stamp_ns in sorted(s for s in self.pending if up_to is None or s <= up_to):
            group = self.pending.pop(stamp_ns)
            if FRICTION not in group or FRICTION_COVARIANCE not in group:
                self._drop('incomplete_update')
                continue
            estimate = Estimate.from_vectors(stamp_ns, group[FRICTION],
                                             group[FRICTION_COVARIANCE], group.get(EFFICIENCY),
                                             group.get(INNOVATION), group.get(COUNTS))
            status = self.monitor.on_estimate(estimate)
            if status is None:
                self._drop('non_finite_estimate')
                continue
            outputs += status.vectors()
        return outputs

    @property
    def latest(self) -> HealthStatus | None:
        return self.monitor.latest
