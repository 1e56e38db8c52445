"""The default WARN efficiency on a gearbox whose healthy eta_D is close to eta_opposing_min.

Issue 23: the derived default was eta_min + 0.25 (1 - eta_min), 0.942 for a gearbox whose
healthy eta_D was 0.939-0.941: WARN 14 s after start and for the whole healthy life. Now it is
eta_min + 0.25 (eta_healthy - eta_min), eta_healthy learned once the filter has settled.

Lever plant R 12, healthy eta_D 0.94 (u 0.05863) for 200 s, then linear wear reaching
eta_opposing_min 0.92 (u_eol 0.07973) at 500 s; recorded for 450 s at 100 Hz. Only the ratio
and ``eta_opposing_min`` are given (and ``warn_horizon`` 0, so that the level is the
efficiency rule's alone): eta_warn 0.92 + 0.25 (0.94 - 0.92) = 0.925, true eta_D crosses it
(u 0.07438) at 424 s.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gear_phm.models.lever import eta_opposing
from gear_phm.offline import analyze_bag
from gear_phm.simulation import config_from_parameters
from gear_phm.simulation.recording import write_simulation
from gear_phm.status import OK, WARN

RATIO = 12.0
U0 = 0.05863
ONSET = 200.0
RATE = (0.07973 - U0) / 300.0          # u_eol at 500 s
WARN_AT = ONSET + (0.07438 - U0) / RATE


def test_default_warn_threshold_of_a_gearbox_close_to_its_end_of_life(tmp_path: Path) -> None:
    config = config_from_parameters({'plant': 'lever', 'ratio': RATIO, 'wear': 'linear',
                                     'friction_initial': U0, 'wear_rate': RATE,
                                     'wear_onset': ONSET, 'seed': 2})
    write_simulation(tmp_path / 'bag', config, 450.0, 100.0)
    analysis = analyze_bag(tmp_path / 'bag', RATIO, history=None, plot=False,
                           eta_opposing_min=0.92, warn_horizon=0.0)
    h = analysis.health
    t = (h.stamp_ns - h.stamp_ns[0]) * 1e-9
    assert eta_opposing(U0, RATIO) == pytest.approx(0.94, abs=1e-4)
    # healthy: OK throughout the plateau (the old default 0.94 warned from the start)
    assert set(h.level[t < ONSET].tolist()) == {OK}
    warned = np.flatnonzero(h.level == WARN)
    assert warned.size, sorted(set(h.messages))
    first = t[warned[0]]
    assert WARN_AT - 15.0 < first < WARN_AT + 15.0, first   # one 5 s dwell, noise in eta_D
    assert 'eta_D' in h.messages[warned[0]]
    assert set(h.level[t >= first].tolist()) == {WARN}       # one transition, held
    values = analysis.summary.health.values
    eta_healthy, eta_warn = float(values['eta_healthy']), float(values['eta_warn'])
    # learned at the first estimate with sigma_u <= HEALTHY_SETTLED_SHARE (u_eol - u), here
    # 0.0021 in u, 0.002 in eta_D: within 2.5 of those sigma (0.9443 since the window
    # variance holds the rotor inertia until it is learned; 0.9407 before)
    assert eta_healthy == pytest.approx(0.94, abs=0.005)
    assert eta_warn == pytest.approx(0.92 + 0.25 * (eta_healthy - 0.92), rel=1e-12)
    assert 0.92 < eta_warn < eta_healthy
    # an explicit eta_warn still wins
    explicit = analyze_bag(tmp_path / 'bag', RATIO, history=None, plot=False,
                           eta_opposing_min=0.92, warn_horizon=0.0, eta_warn=0.93)
    assert explicit.summary.health.value('eta_warn') == 0.93
    assert explicit.summary.health.value('eta_healthy') == eta_healthy
