"""One drive's health: its status under its names, its first levels and its resets."""
from __future__ import annotations

from gear_phm.prognostics import HealthConfig, waiting_state
from gear_phm.run import DriveHealth, DriveNames


def test_statuses_carry_the_drive_names_and_note_the_first_level() -> None:
    health = DriveHealth(HealthConfig(ratio=3.0), DriveNames.of('rudder'))
    assert health.statuses_at(5, None) == ()
    state = waiting_state(1_000, health.assessor.u_eol)
    (status,) = health.statuses_at(2_000, state)
    assert status.name == 'gear_phm: rudder' and status.hardware_id == 'rudder'
    health.statuses_at(3_000, state)
    assert list(health.first_seen.values()) == [2_000]
    assert health.identity() == {'ratio': 3.0}
    health.reset()
    health.reconfigure({'stale_timeout': 9.0})
    assert health.resets == 1 and health.config.stale_timeout == 9.0
    assert health.assessor.config.stale_timeout == 9.0
