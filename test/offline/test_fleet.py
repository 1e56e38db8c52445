"""Population prior (issue 13, stretch): units at end of life teach the fleet its wear law.

The shape prior pulls an early, poorly determined fit to the fleet's shape; the fleet's prior
comes only from units at end of life; ``gear-phm fleet --population-prior`` analyses the
running units again with it.
"""
from __future__ import annotations

from dataclasses import replace
import json
import math
from pathlib import Path
import subprocess
import sys

import numpy as np
import pytest

from gear_phm.estimation import EstimatorConfig, EstimatorPipeline, EstimatorSummary
from gear_phm.offline.fleet import population_prior
from gear_phm.offline.summary import DriveSummary, HealthSummary, RunInfo, TrendSummary
from gear_phm.prognostics import ShapePrior
from gear_phm.prognostics.fits import fit_laws

GEAR_PHM = Path(sys.executable).parent / 'gear-phm'


def _early_power_history(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the first 40 % of a life u = 0.05 + 0.2 (t / 200 s)^3, in 16 bins.

    The error wanders (a random walk), as a Kalman posterior history's does: p is barely
    visible.
    """
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 80.0, 16)
    sigma = 2e-3
    walk = np.cumsum(rng.standard_normal(t.size)) / math.sqrt(t.size)
    u = 0.05 + 0.2 * (t / 200.0) ** 3 + sigma * walk
    return t, u, np.full(t.size, 1.0 / sigma ** 2)


def test_shape_prior_pulls_an_early_fit_to_the_fleet_shape() -> None:
    errors = {'none': [], 'prior': []}
    for seed in range(8):
        t, u, precision = _early_power_history(seed)
        free = fit_laws(t, u, precision, trend='power')[0]
        prior = ShapePrior('power', math.log(3.0), 0.1)
        pulled = fit_laws(t, u, precision, prior=prior)
        assert len(pulled) == 1 and pulled[0].model == 'power'
        law = pulled[0]
        errors['none'].append(abs(math.log(free.shape / 3.0)))
        errors['prior'].append(abs(math.log(law.shape / 3.0)))
        assert law.covariance[8] < free.covariance[8]        # the prior's information
    assert max(errors['prior']) < 0.1 < max(errors['none'])
    assert np.mean(errors['prior']) < 0.3 * np.mean(errors['none'])


def test_shape_prior_rejects_what_has_no_shape() -> None:
    with pytest.raises(ValueError, match='exponential, power or proportional'):
        ShapePrior('linear', 0.0, 0.1)
    with pytest.raises(ValueError, match='log sigma > 0'):
        ShapePrior('power', 1.0, 0.0)


def _summary(u: float, model: str, shape: float, u_eol: float = 0.25) -> DriveSummary:
    """Return a unit's summary with the final u and the fitted wear law given."""
    config = EstimatorConfig(ratio=3.0)
    fresh = EstimatorSummary.from_dict(EstimatorPipeline(config).summary())
    return DriveSummary(replace(fresh, u=u), RunInfo(('bag',), '/joint_states', 0, ('mcap',),
                                                     0.0),
                        0, config, HealthSummary('OK', {}, {}, 'estimating', {},
                                                 TrendSummary(model, shape, u_eol)))


def test_population_prior_comes_from_units_at_end_of_life_only() -> None:
    ended = [_summary(0.26, 'power', p) for p in (2.5, 3.0, 3.6)]
    others = [_summary(0.10, 'power', 9.0), _summary(0.30, 'linear', 0.0), None]
    prior = population_prior(ended + others)
    logs = np.log([2.5, 3.0, 3.6])
    assert prior is not None and prior.model == 'power'
    assert prior.log_mean == pytest.approx(float(np.mean(logs)))
    assert prior.log_sigma == pytest.approx(float(np.std(logs, ddof=1))) and prior.log_sigma > 0.1
    assert population_prior(ended[:2] + others) is None             # fewer than 3 ended
    tight = population_prior([_summary(0.3, 'exponential', 0.01)] * 3)
    assert tight is not None and tight.log_sigma == 0.1              # the spread's floor


@pytest.mark.long(15)
def test_fleet_cli_population_prior(tmp_path: Path) -> None:
    root, out = tmp_path / 'fleet', tmp_path / 'out'
    simulate = subprocess.run(
        [str(GEAR_PHM), 'simulate', '--fleet', '8', '--recordings', '4', '--duration', '30',
         '--wear', 'exponential', '--friction-initial', '0.05', '--friction-final', '0.26',
         '--unit-spread', '0.3', '--seed', '21', '--out', str(root)],
        capture_output=True, text=True, timeout=300)
    assert simulate.returncode == 0, simulate.stderr
    fleet = subprocess.run(
        [str(GEAR_PHM), 'fleet', str(root), '--ratio', '3.0', '--eta-opposing-min', '0.7333',
         '--out', str(out), '--workers', '1', '--no-progress', '--no-unit-outputs', '--no-plot',
         '--population-prior'], capture_output=True, text=True, timeout=500)
    assert fleet.returncode == 0, fleet.stderr
    run = json.loads((out / 'fleet_run.json').read_text())
    prior = run['population_prior']
    # the simulator's exponential wear, u0 exp(k t), is the proportional law
    assert prior is not None and prior['model'] == 'proportional', run
    rows = {line.split(',')[0]: line.split(',') for line in
            (out / 'fleet.csv').read_text().splitlines()[1:]}
    ended = {unit for unit, row in rows.items() if row[14] == 'ERROR' and 'end of life' in
             ','.join(row[15:])}
    assert len(ended) >= 3
    assert run['units_with_prior'] and not set(run['units_with_prior']) & ended
    assert set(run['units_with_prior']) | ended == set(rows)
