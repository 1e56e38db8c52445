"""Idle gaps (gear_phm.simulation.idle_gap): nothing published, the oil cools, the run goes on."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gear_phm.bagio import BagReader
from gear_phm.interfaces import stamp_to_ns
from gear_phm.simulation import SimulationConfig, Simulator
from gear_phm.simulation.idle_gap import IdleGap
from gear_phm.simulation.parameters import config_from_parameters
from gear_phm.simulation.recording import write_simulation
from gear_phm.sources import Sample
from gear_phm.sources.simulate import SimulateSource

GAP = {'idle_gap_at': 11.0, 'idle_gap_duration': 3600.0, 'oil_warm_time_constant': 5.0,
       'oil_cool_time_constant': 600.0, 'publish_temperature': True}


def test_the_operating_time_stops_in_the_gap() -> None:
    gap = IdleGap(at=10.0, duration=5.0)
    t = np.array([0.0, 9.0, 10.0, 12.0, 15.0, 20.0])
    np.testing.assert_array_equal(gap.operating_time(t), [0.0, 9.0, 10.0, 10.0, 10.0, 15.0])
    np.testing.assert_array_equal(gap.idle(t), [False, False, True, True, False, False])
    assert gap.elapsed(9.0) == 9.0 and gap.elapsed(12.0) == 17.0
    np.testing.assert_array_equal(IdleGap().operating_time(t), t)
    assert not IdleGap().enabled
    with pytest.raises(ValueError, match='idle_gap_duration must be >= 0'):
        IdleGap(duration=-1.0)


def test_the_run_after_the_gap_continues_where_it_stopped() -> None:
    config = config_from_parameters(GAP)
    simulator = Simulator(config)
    before = simulator.sample(np.array([10.99]))
    after = Simulator(config).sample(np.array([3611.0, 3611.01]))
    plain = Simulator(SimulationConfig()).sample(np.array([10.99, 11.0, 11.01]))
    np.testing.assert_allclose(after.true_velocity_load, plain.true_velocity_load[1:])
    np.testing.assert_allclose(after.true_effort_load, plain.true_effort_load[1:])
    assert before.oil_temperature[0] > 55.0                   # warm: 5 s time constant
    assert after.oil_temperature[0] < 25.0                    # back near the ambient 20
    assert after.drag_factor[0] >= 1.0


def test_nothing_is_written_in_the_gap_and_the_oil_is_cooler_after(tmp_path: Path) -> None:
    config = config_from_parameters(GAP)
    count = write_simulation(tmp_path / 'bag', config, 3630.0, 100.0)
    assert count == 1100 + 1900                               # 11 s before, 19 s after
    with BagReader(tmp_path / 'bag') as reader:
        joints = [stamp_to_ns(m.header.stamp) for _, _, m in reader.messages(['/joint_states'])]
        oil = [(stamp_to_ns(m.header.stamp), m.temperature)
               for _, _, m in reader.messages(['/oil_temperature'])]
    stamps = np.array(joints) * 1e-9
    assert not np.any((stamps >= 11.0) & (stamps < 3611.0))
    assert stamps[1099] == pytest.approx(10.99) and stamps[1100] == pytest.approx(3611.0)
    assert len(oil) == count
    temperature = dict(oil)
    last, first = temperature[joints[1099]], temperature[joints[1100]]
    expected = 20.0 + (last - 20.0) * np.exp(-3600.01 / 600.0)
    assert first == pytest.approx(expected, abs=0.05) and first < last - 30.0


def test_the_publisher_source_skips_the_gap() -> None:
    config = config_from_parameters(GAP)
    items = list(SimulateSource(config, rate=10.0, duration=3615.0).items())
    elapsed = np.array([ns for ns, _ in items]) * 1e-9
    assert len(items) == 110 + 40
    assert not np.any((elapsed >= 11.0) & (elapsed < 3611.0))
    sample = items[0][1]
    assert isinstance(sample, Sample) and len(sample.no_load) == 3 and len(sample.oil) == 3
    assert sample.temperature == (20.0,)
