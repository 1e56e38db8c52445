"""A healthy gearbox that is not the lever model, through the live node executables (issue 23).

Lever plant R 50 whose eta_D (0.85, u 0.17241) and eta_I (0.80, u 0.19691) do not come from
one u (``direction_offset`` 0.0245), that does not wear. The publisher replays 60 s of it at
250 Hz twice as fast as real time to the estimator and diagnostics nodes, started with the
ratio (and ``eta_opposing_min`` only, 0.80: the derived WARN efficiency must come from the
learned healthy eta_D, not be read as wear). Before the direction offset was a state of the
filter, u switched between the two readings at every change of load direction, the published
eta_D alternated 0.850/0.832 and eta_I 0.825/0.800, and the swings were read as growth: WARN
"RUL 669 s of operation" after 25 s (at 1 kHz).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gear_phm.interfaces import COUNTS, EFFICIENCY, FRICTION
from gear_phm.models.lever import eta_aiding, eta_opposing
from gear_phm.simulation import config_from_parameters
from gear_phm.simulation.recording import write_simulation
from helpers.live import replay_to_nodes

pytestmark = [pytest.mark.integration, pytest.mark.timeout(180)]

RATIO = 50.0
U = 0.17241
OFFSET = 0.0245
RATE = 250.0
DURATION = 60.0
SETTLED = 10.0           # s of bag time before the efficiencies are held to their truth
PLANT = {'plant': 'lever', 'ratio': RATIO, 'friction_initial': U, 'direction_offset': OFFSET,
         'motor_inertia': 2e-4, 'noise_effort_motor': 0.003, 'noise_effort_load': 0.1,
         'noise_velocity_motor': 0.05, 'noise_velocity_load': 0.002, 'seed': 3}


def _phase_means(stamps: np.ndarray, u: np.ndarray, flow: np.ndarray) -> list[float]:
    """Mean u of each run of estimates with one power-flow code (1 opposing, 2 aiding)."""
    means, start = [], 0
    for i in range(1, len(flow) + 1):
        if i == len(flow) or flow[i] != flow[start]:
            if flow[start] in (1, 2) and i - start >= 3:
                means.append(float(np.mean(u[start:i])))
            start = i
    return means


@pytest.mark.long(30)                 # 60 s replayed twice as fast as real time
def test_healthy_mismatched_gearbox_stays_ok_with_steady_u(tmp_path: Path) -> None:
    bag = tmp_path / 'mismatch'
    write_simulation(bag, config_from_parameters(PLANT), DURATION, RATE)
    eta_d, eta_i = float(eta_opposing(U, RATIO)), float(eta_aiding(U + OFFSET, RATIO))
    driver, code, error = replay_to_nodes(
        'direction_offset_test', (FRICTION, COUNTS, EFFICIENCY), bag, DURATION,
        (f'ratio:={RATIO}', 'eta_opposing_min:=0.8', 'rate:=5.0', 'transmission_name:=mismatch'),
        (f'ratio:={RATIO}', 'publish_rate:=20.0'))
    assert code == 0, error

    # levels: never WARN or ERROR (STALE once the replay has ended), RUL inf
    health = [s for s in driver.statuses['gear_phm'] if 'rul_s' in s]
    assert sum(s['_level'] == b'\x00' for s in health) > 100
    levels = {s['_level'] for s in health}
    assert levels <= {b'\x00', b'\x03'}, sorted({s['_message'] for s in health})
    assert {s['rul_s'] for s in health} <= {'inf', 'nan'}     # nan: waiting for data
    assert sum(s['rul_s'] == 'inf' for s in health) > 100
    final = health[-1]
    # the healthy eta_D was learned, the derived WARN efficiency below it
    assert float(final['eta_healthy']) == pytest.approx(eta_d, abs=0.005)
    assert 0.8 < float(final['eta_warn']) < float(final['eta_healthy'])

    # the offset is a reported part of the estimate
    status = driver.latest('gear_phm estimator')
    assert float(status['direction_offset']) == pytest.approx(OFFSET, abs=0.004)

    # u steady across the direction changes: phase means within 2 sigma of each other
    friction = driver.messages[FRICTION]
    counts = {m.header.stamp.sec * 10 ** 9 + m.header.stamp.nanosec: m.vector.z
              for m in driver.messages[COUNTS]}
    rows = np.array([(m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec, m.vector.x,
                      m.vector.z, counts.get(m.header.stamp.sec * 10 ** 9
                                             + m.header.stamp.nanosec, np.nan))
                     for m in friction])
    late = rows[rows[:, 0] - rows[0, 0] > SETTLED]
    means = _phase_means(late[:, 0], late[:, 1], late[:, 3])
    assert len(means) > 10                 # many changes of load direction were seen
    swing = np.max(np.abs(np.diff(means)))
    sigma = float(np.median(late[:, 2]))
    print(f'u phase means {min(means):.5f}..{max(means):.5f}, swing {swing:.2e}, '
          f'sigma {sigma:.2e}')
    assert swing <= 2.0 * sigma, (swing, sigma)
    assert np.max(np.abs(late[:, 1] - (U + 0.5 * OFFSET))) < 3.0 * sigma + 0.002   # midpoint

    # each published efficiency matches its own direction's truth
    efficiency = np.array([(m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec, m.vector.x,
                            m.vector.y) for m in driver.messages[EFFICIENCY]])
    settled = efficiency[efficiency[:, 0] - efficiency[0, 0] > SETTLED]
    assert settled.shape[0] > 100
    print(f'eta_D error max {np.max(np.abs(settled[:, 1] - eta_d)):.2e}, eta_I error max '
          f'{np.max(np.abs(settled[:, 2] - eta_i)):.2e}, offset {status["direction_offset"]}, '
          f'eta_healthy {final["eta_healthy"]}, eta_warn {final["eta_warn"]}')
    assert np.max(np.abs(settled[:, 1] - eta_d)) < 0.01
    assert np.max(np.abs(settled[:, 2] - eta_i)) < 0.01
