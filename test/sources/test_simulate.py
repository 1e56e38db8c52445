"""The publisher's simulate source (gear_phm.sources.simulate), without ROS."""
from __future__ import annotations

import numpy as np
import pytest

from gear_phm.simulation import config_from_parameters, PARAMETERS, sample_times, simulate
from gear_phm.sources import Sample, SourceError
from gear_phm.sources.simulate import SimulateSource


def defaults(**overrides: object) -> dict[str, object]:
    values: dict[str, object] = {spec.name: spec.default for spec in PARAMETERS}
    values.update(overrides)
    return values


def test_simulate_source_yields_the_simulation_at_its_sample_times() -> None:
    values = defaults(seed=3, wear='linear', wear_rate=0.01)
    source = SimulateSource.from_parameters(values, rate=200.0, duration=1.3)
    items = list(source.items())             # 1.3 s at 200 Hz: 260 samples over 3 chunks
    expected = simulate(config_from_parameters(values), sample_times(1.3, 200.0))
    assert len(items) == len(expected) == 260
    assert [elapsed for elapsed, _ in items] == [k * 5_000_000 for k in range(260)]
    samples = [item for _, item in items]
    assert all(isinstance(s, Sample) for s in samples)
    columns = {
        'position': (expected.position_motor, expected.position_load),
        'velocity': (expected.velocity_motor, expected.velocity_load),
        'effort': (expected.effort_motor, expected.effort_load),
        'friction': (expected.u, expected.friction),
        'efficiency': (expected.eta_opposing, expected.eta_aiding),
    }
    for name, (first, second) in columns.items():
        got = np.array([getattr(s, name) for s in samples])
        np.testing.assert_array_equal(got[:, 0], first, err_msg=name)      # chunked = one call
        np.testing.assert_array_equal(got[:, 1], second, err_msg=name)
    assert source.describe() == [('rate_hz', 200.0)]


def test_simulate_source_refuses_a_run_that_jams_and_bad_parameters() -> None:
    with pytest.raises(SourceError, match=r'parameter duration: .* \(gearbox jams\)'):
        SimulateSource.from_parameters(defaults(wear='linear', wear_rate=2.0), rate=50.0,
                                       duration=10.0)
    with pytest.raises(SourceError, match='^parameter .*wear'):
        SimulateSource.from_parameters(defaults(wear='sudden'), rate=50.0, duration=1.0)
    unbounded = SimulateSource.from_parameters(defaults(wear='linear', wear_rate=2.0),
                                               rate=50.0, duration=0.0)
    with pytest.raises(ValueError, match='the gearbox jams'):       # found while running
        for _ in unbounded.items():
            pass
