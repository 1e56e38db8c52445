"""One drive's health: its assessor, its health status and its resets (ROS-free)."""
from __future__ import annotations

from typing import Any

from gear_phm.interfaces import health_status
from gear_phm.prognostics import HealthAssessor, HealthConfig, HealthState, ShapePrior
from gear_phm.run.names import DriveNames
from gear_phm.status import LEVEL_NAMES, StatusOut


class DriveHealth:
    """One drive's :class:`~gear_phm.prognostics.HealthAssessor` and what it reports."""

    def __init__(self, config: HealthConfig, names: DriveNames,
                 prior: ShapePrior | None = None) -> None:
        self.config = config
        self.assessor = HealthAssessor(config, prior)
        self.names = names
        #: learning resets on purpose (a reset service)
        self.resets = 0
        #: the stamp [ns] of the first status at each level (by level name)
        self.first_seen: dict[str, int] = {}

    def status_of(self, state: HealthState) -> StatusOut:
        """Return the health status ``gear_phm: <transmission_name>`` of ``state``."""
        return health_status(state, self.names.transmission_name, self.names.hardware_id)

    def statuses_at(self, stamp_ns: int, latest: HealthState | None
                    ) -> tuple[StatusOut, ...]:
        """Return the status published at ``stamp_ns`` [ns] for ``latest`` (none before one).

        Notes the first stamp of the state's level (:attr:`first_seen`).
        """
        if latest is None:
            return ()
        self.first_seen.setdefault(LEVEL_NAMES[latest.level], stamp_ns)
        return (self.status_of(latest),)

    def reconfigure(self, changed: dict[str, Any]) -> None:
        """Apply new health parameters by name; the assessor keeps what it learned.

        Raises ValueError (the configuration's reason) on a refused value.
        """
        self.config = self.config.replace(**changed)
        self.assessor.reconfigure(self.config)

    def reset(self) -> None:
        """Forget what the assessor learned, on purpose; counted in :attr:`resets`."""
        self.assessor.reset()
        self.resets += 1

    def identity(self) -> dict[str, Any]:
        """Return what a state file must match: the ratio."""
        return {'ratio': float(self.config.ratio)}

    def current_state(self) -> tuple[dict[str, Any], int | None]:
        """Return the assessor's state and the stamp [ns] of its newest health state."""
        latest = self.assessor.latest
        return self.assessor.to_state(), None if latest is None else latest.stamp_ns
