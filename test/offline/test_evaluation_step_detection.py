"""Step-fault detection time through the offline chain (docs/prognostics.md, "Step fault").

simulate --wear step -> analyze with only --ratio and --eta-opposing-min. Detection time: from
the fault to the first estimate within 2 sigma_u of the new u after which u_hat never falls
back below the midpoint of the old and new u (sustained: a lucky noise excursion does not
count). The ERROR level of a step beyond end of life is read from the health summary.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from gear_phm import interfaces
from gear_phm.bagio.series import read_vector_topic
from gear_phm.cli.main import main
from gear_phm.offline.evaluation import find_bag

U0, T_FAULT = 0.1, 104.0      # 104 s: the slowest of the fault phases measured in the cycle
HEALTH = ['--ratio', '3', '--eta-opposing-min', '0.5']          # end of life at u = 0.6


def detect(tmp: Path, seed: int, step: float, rate: int = 100, duration: float = 160.0,
           t_fault: float = T_FAULT) -> tuple[float, dict]:
    """Return (detection time after the fault [s] or inf, the analysis health summary)."""
    bag, analysis = tmp / f'bag_{seed}_{step}', tmp / f'a_{seed}_{step}'
    assert main(['simulate', '--rate', str(rate), '--out', str(bag), '--duration',
                 str(duration), '--seed', str(seed), '--wear', 'step', '--t-fault',
                 str(t_fault), '--fault-step', str(step), '--friction-initial', str(U0),
                 '--truth-every', '100']) == 0
    assert main(['analyze', str(bag), *HEALTH, '--out', str(analysis), '--no-plot',
                 '--no-progress']) == 0
    t, values = read_vector_topic(find_bag(analysis), interfaces.FRICTION)  # from 0 s
    u, sigma = values[:, 0], values[:, 2]
    new = U0 + step
    after = t >= t_fault
    back = np.flatnonzero(after & (np.abs(u - new) >= abs(step) / 2.0))
    start = t[back[-1]] if back.size else t_fault
    hit = after & (t > start) & (np.abs(u - new) <= 2.0 * sigma)
    detected = float(t[hit][0] - t_fault) if hit.any() else math.inf
    health = json.loads((analysis / 'summary.json').read_text())['health']
    return detected, health


@pytest.mark.parametrize('step, bound', [(0.1, 8.0), (0.01, 60.0)])
def test_step_is_detected_within_the_documented_bound(tmp_path: Path, step: float,
                                                      bound: float) -> None:
    """Steps beyond and below the gate are detected within their bounds (3 seeds).

    A step beyond the gate (0.1 = 30 window sigmas) is detected by re-initialisation after
    max_consecutive_gated windows: measured 3.0-3.5 s, bound 8 s. A step below the gate
    (0.01 ~ 3 window sigmas at 100 Hz) is tracked as wear once the whiteness test has raised
    q: measured 26-43 s, bound 60 s (docs/prognostics.md derives both).
    """
    times = [detect(tmp_path, seed, step)[0] for seed in (1, 2, 3)]
    assert max(times) <= bound, times
    if step > 0.05:
        assert min(times) >= 1.0, times       # it takes windows after the fault, not luck


def test_step_beyond_end_of_life_gives_error_within_bound(tmp_path: Path) -> None:
    """A step past end of life gives ERROR within 14 s.

    u 0.1 -> 0.7 (end of life at 0.6): ERROR 'end of life' within the detection bound plus
    level_dwell (5 s) plus one status period (1 s): 14 s; measured 7-9 s.
    """
    for seed in (1, 2):
        detected, health = detect(tmp_path, seed, 0.6)
        assert detected <= 8.0
        assert health['level'] == 'ERROR' and 'end of life' in health['message']
        error_at = health['first_seen_ns']['ERROR'] * 1e-9
        assert T_FAULT < error_at <= T_FAULT + 14.0, error_at


def test_sub_gate_step_after_a_long_constant_run_within_worst_case_bound(
        tmp_path: Path) -> None:
    """A sub-gate step after 2000 s at constant u is detected within 150 s.

    After 2000 s at constant u the learned q has fallen to q_min (1e-22): a sub-gate step
    then waits for q to climb ~35 e-folds at <= 0.38 per window. Measured 122-128 s (seeds 1,
    2); documented worst-case bound 150 s.
    """
    detected, _ = detect(tmp_path, 1, 0.01, duration=2200.0, t_fault=2000.0)
    assert 60.0 < detected <= 150.0, detected
