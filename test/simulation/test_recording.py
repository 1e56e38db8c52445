"""The bag writers of gear_phm.simulation.recording: the extended truth and the oil temperature."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from gear_phm.bagio import BagReader, TYPESTORE
from gear_phm.bagio.batch_writer import stamped_float64_rows
from gear_phm.interfaces import stamp_to_ns
from gear_phm.simulation import SimulationConfig, Simulator
from gear_phm.simulation.parameters import config_from_parameters
from gear_phm.simulation.recording import Fleet, write_drives, write_fleet, write_simulation

EFFECTS = {'seed': 3, 'no_load_coulomb': 0.05, 'no_load_viscous': 0.004,
           'no_load_cold_factor': 2.5, 'oil_warm_time_constant': 30.0,
           'load_scale_min': 0.3, 'load_modulation': 0.1, 'publish_temperature': True}


def _topics(path: Path) -> dict[str, str]:
    with BagReader(path) as reader:
        return dict(reader.topics)


def test_defaults_write_the_three_topics_of_old(tmp_path: Path) -> None:
    write_simulation(tmp_path / 'bag', SimulationConfig(), 1.0, 100.0)
    assert _topics(tmp_path / 'bag') == {
        '/joint_states': 'sensor_msgs/msg/JointState',
        '/gear_phm/truth/friction': 'geometry_msgs/msg/Vector3Stamped',
        '/gear_phm/truth/efficiency': 'geometry_msgs/msg/Vector3Stamped'}


def test_the_extended_truth_holds_the_simulated_values(tmp_path: Path) -> None:
    config = config_from_parameters(EFFECTS)
    write_simulation(tmp_path / 'bag', config, 20.0, 100.0, start_time=5.0, truth_every=3)
    topics = _topics(tmp_path / 'bag')
    assert topics['/gear_phm/truth/no_load'] == 'geometry_msgs/msg/Vector3Stamped'
    assert topics['/gear_phm/truth/oil'] == 'geometry_msgs/msg/Vector3Stamped'
    assert topics['/oil_temperature'] == 'sensor_msgs/msg/Temperature'
    truth = Simulator(config).sample(np.arange(2000) / 100.0)
    with BagReader(tmp_path / 'bag') as reader:
        rows = {topic: [(stamp_to_ns(m.header.stamp), m) for _, _, m in reader.messages([topic])]
                for topic in ('/gear_phm/truth/no_load', '/gear_phm/truth/oil',
                              '/oil_temperature')}
    every = np.arange(0, 2000, 3)
    for topic, names in (('/gear_phm/truth/no_load',
                          ('no_load_torque', 'no_load_coulomb', 'no_load_viscous')),
                         ('/gear_phm/truth/oil', ('oil_temperature', 'drag_factor',
                                                  'load_scale'))):
        assert [ns for ns, _ in rows[topic]] == list(5_000_000_000 + every * 10_000_000)
        values = np.array([(m.vector.x, m.vector.y, m.vector.z) for _, m in rows[topic]])
        np.testing.assert_allclose(values, np.column_stack(
            [getattr(truth, name)[every] for name in names]), rtol=1e-12, atol=1e-15)
    temperature = np.array([(m.temperature, m.variance) for _, m in rows['/oil_temperature']])
    np.testing.assert_allclose(temperature[:, 0], truth.oil_temperature[every], rtol=1e-12)
    np.testing.assert_array_equal(temperature[:, 1], 0.0)
    assert temperature[0, 0] == 20.0
    assert temperature[-1, 0] == pytest.approx(60.0 - 40.0 * np.exp(-19.98 / 30.0), abs=1e-9)


def test_temperature_rows_are_the_serializer_s_bytes() -> None:
    stamps = np.array([0, 1_500_000_001, 2**31 * 10**9 - 1], dtype=np.int64)
    values = np.array([[20.0, 0.0], [61.25, 0.01], [-5.0, 1.0]])
    rows = stamped_float64_rows(stamps, values)
    kinds = TYPESTORE.types
    for row, ns, (temperature, variance) in zip(rows, stamps, values):
        sec, nanosec = divmod(int(ns), 10**9)
        message = kinds['sensor_msgs/msg/Temperature'](
            header=kinds['std_msgs/msg/Header'](stamp=kinds['builtin_interfaces/msg/Time'](
                sec=sec, nanosec=nanosec), frame_id=''),
            temperature=temperature, variance=variance)
        assert row.tobytes() == bytes(TYPESTORE.serialize_cdr(
            message, 'sensor_msgs/msg/Temperature'))


def test_many_drives_each_have_their_extended_truth(tmp_path: Path) -> None:
    plain = SimulationConfig(seed=1)
    effects = config_from_parameters(EFFECTS)
    write_drives(tmp_path / 'bag', [(plain, ('m1', 'l1'), 'left'),
                                    (effects, ('m2', 'l2'), 'right')], 1.0, 50.0)
    topics = set(_topics(tmp_path / 'bag'))
    assert {'/gear_phm/right/truth/no_load', '/gear_phm/right/truth/oil',
            '/right/oil_temperature', '/gear_phm/left/truth/friction'} <= topics
    assert not {t for t in topics if t.startswith('/gear_phm/left/truth/no')}
    with pytest.raises(ValueError, match='must share their idle gap'):
        write_drives(tmp_path / 'other', [
            (plain, ('m1', 'l1'), 'left'),
            (config_from_parameters({'idle_gap_at': 1.0, 'idle_gap_duration': 2.0}),
             ('m2', 'l2'), 'right')], 1.0, 50.0)


def test_each_fleet_recording_starts_from_the_oil_s_initial_temperature(tmp_path: Path) -> None:
    config = config_from_parameters(EFFECTS)
    write_fleet(tmp_path / 'fleet', config, Fleet(1, recordings=2, gap=100.0), 60.0, 10.0)
    firsts = []
    for k in range(2):
        with BagReader(tmp_path / 'fleet' / 'unit_00' / f'rec_{k:03d}') as reader:
            firsts.append(next(iter(reader.messages(['/oil_temperature'])))[2].temperature)
    assert firsts == [20.0, 20.0]
    truth = yaml.safe_load((tmp_path / 'fleet' / 'unit_00' / 'truth.yaml').read_text())
    assert truth['recording_start_s'] == [0.0, 160.0]
