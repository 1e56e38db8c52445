"""The opt-in architecture prior of the random lives, and the existing priors unchanged by it."""
from __future__ import annotations

import pytest

from gear_phm.simulation import config_from_parameters
from gear_phm.simulation.lives import ARCHITECTURE_PLANTS, PRIORS, random_life


@pytest.mark.parametrize(('seed', 'prior', 'plant', 'ratio', 'eta_healthy', 'end_of_life'), [
    (0, 'paper', 'lever', 3.717821252117981, 0.8564873248869888, 859.73),
    (1, 'paper', 'spur', 17.594537739621373, 0.9778949257805315, 692.65),
    (1, 'bench', 'spur', 17.594537739621373, 0.9778949257805315, 29684.65),
    (2, 'paper', 'lever', 11.806939709512516, 0.9028733940610729, 20720.55),
])
def test_the_existing_priors_draw_what_they_drew(seed: int, prior: str, plant: str,
                                                 ratio: float, eta_healthy: float,
                                                 end_of_life: float) -> None:
    life = random_life(seed, prior=prior)          # the values from before the new prior
    assert life.parameters['plant'] == plant
    assert life.parameters['ratio'] == ratio and life.eta_healthy == eta_healthy
    assert life.end_of_life == pytest.approx(end_of_life, abs=1e-9)


def test_the_architecture_prior_draws_every_architecture_plant_on_the_paper_draws() -> None:
    assert PRIORS == ('paper', 'bench', 'architectures')
    plants = set()
    for seed in range(16):
        paper, life = random_life(seed), random_life(seed, prior='architectures')
        p = life.parameters
        plants.add(p['plant'])
        assert p['plant'] in ARCHITECTURE_PLANTS
        # the paper prior's plant draws: same ratio, duty cycle, load and noise
        for name in ('ratio', 'travel', 'extend_time', 'air_load_preload', 'noise_effort_load'):
            assert p[name] == paper.parameters[name]
        plant = config_from_parameters(p).plant
        healthy = p['friction_initial'] + p['friction_base']
        assert float(plant.efficiencies(healthy)[1]) == pytest.approx(life.eta_healthy,
                                                                      abs=1e-12)
        assert float(plant.efficiencies(healthy)[2]) > 0.0        # reversible when healthy
        assert life.eta_opposing_min >= 0.5
        if life.family != 'healthy':
            assert life.end_of_life is not None and 0.0 < life.end_of_life < life.duration
    assert plants == set(ARCHITECTURE_PLANTS)
    assert life.to_json()['prior'] == 'architectures'
    assert 'prior' not in random_life(0).to_json()
