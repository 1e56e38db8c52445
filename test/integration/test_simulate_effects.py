"""The real-gearbox effects end to end: ``gear-phm simulate`` flags and the publisher node."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from gear_phm.bagio import BagReader
from gear_phm.cli.main import main as gear_phm
from gear_phm.simulation.parameters import EFFECT_PARAMETERS
from integration.test_publisher import ros, run_with_listeners  # noqa: F401, I100, I201

FLAGS = ['--no-load-coulomb', '0.05', '--no-load-viscous', '0.004', '--no-load-cold-factor',
         '3', '--oil-warm-time-constant', '40', '--oil-cool-time-constant', '100',
         '--load-scale-min', '0.3',
         '--load-modulation', '0.1', '--bias-effort-load', '0.4', '--gain-effort-load', '0.005',
         '--quantum-effort-load', '0.01', '--encoder-counts-motor', '4096',
         '--idle-gap-at', '5', '--idle-gap-duration', '600', '--publish-temperature']


def test_simulate_takes_every_effect_as_an_option(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert gear_phm(['simulate', '--out', str(tmp_path / 'bag'), '--duration', '615',
                     '--rate', '100', '--seed', '2', *FLAGS]) == 0
    assert 'wrote 1500 samples' in capsys.readouterr().out
    with BagReader(tmp_path / 'bag') as reader:
        assert {'/gear_phm/truth/no_load', '/gear_phm/truth/oil',
                '/oil_temperature'} <= set(reader.topics)
        no_load = [m.vector for _, _, m in reader.messages(['/gear_phm/truth/no_load'])]
        oil = [m.vector for _, _, m in reader.messages(['/gear_phm/truth/oil'])]
        joints = [m for _, _, m in reader.messages(['/joint_states'])]
    assert len(no_load) == len(oil) == len(joints) == 1500
    assert (no_load[0].y, no_load[0].z) == pytest.approx((0.15, 0.012))   # cold: 3 x warm
    assert oil[0].x == 20.0 and oil[499].x > 24.5 and oil[500].x < 20.02  # cooled in the gap
    assert min(v.z for v in oil) >= 0.3 * 0.9 - 1e-12
    steps = np.array([m.effort[1] for m in joints]) / 0.01
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)
    motor = np.array([m.position[0] for m in joints]) / (2 * math.pi / 4096)
    np.testing.assert_allclose(motor, np.round(motor), atol=1e-6)


def test_every_effect_defaults_to_off_in_the_help(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        gear_phm(['simulate', '--help'])
    text = capsys.readouterr().out
    for spec in EFFECT_PARAMETERS:
        assert '--' + spec.name.replace('_', '-') in text


def test_random_life_with_the_bench_prior(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    assert gear_phm(['simulate', '--out', str(tmp_path / 'life'), '--random-life', '4',
                     '--prior', 'bench', '--rate', '10']) == 0
    printed = json.loads(capsys.readouterr().out)
    life = json.loads((tmp_path / 'life' / 'life.json').read_text())
    assert printed == life and life['prior'] == 'bench'
    assert life['no_load']['cold_factor'] == life['parameters']['no_load_cold_factor']
    assert {spec.name for spec in EFFECT_PARAMETERS} <= set(life['parameters'])
    with BagReader(tmp_path / 'life') as reader:
        assert '/gear_phm/truth/no_load' in reader.topics


def test_prior_needs_a_random_life(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert gear_phm(['simulate', '--out', str(tmp_path / 'x'), '--prior', 'bench']) == 2
    assert '--prior bench: for --random-life only' in capsys.readouterr().err
    assert not (tmp_path / 'x').exists()


@pytest.mark.integration
def test_the_publisher_node_publishes_the_effects(ros) -> None:  # noqa: F811
    from geometry_msgs.msg import Vector3Stamped
    from sensor_msgs.msg import Temperature
    done, (joints, no_load, temperature) = run_with_listeners(
        ros, [(Vector3Stamped, 'gear_phm/truth/no_load'), (Temperature, 'oil_temperature')],
        duration=2.0, rate=100.0, seed=4, no_load_coulomb=0.05, no_load_cold_factor=2.0,
        publish_temperature=True, bias_effort_load=0.4, idle_gap_at=1.0,
        idle_gap_duration=0.5)
    assert done.returncode == 0, done.stderr
    assert len(joints.items) == len(no_load.items) == len(temperature.items) == 150
    stamps = np.array([s for s, _, _ in joints.items])
    elapsed = (stamps - stamps[0]) * 1e-9
    assert not np.any((elapsed > 0.995) & (elapsed < 1.495))  # the gap: nothing published
    assert no_load.items[0][2].vector.y == pytest.approx(0.1)  # cold: 2 x 0.05
    assert temperature.items[0][2].temperature == 20.0
