"""Wear laws (gear_phm.simulation.wear): trajectories, Wear.reaching, validation."""
from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from gear_phm.simulation.wear import Wear


@pytest.mark.parametrize('kind, expected', [
    ('constant', [0.1, 0.1, 0.1]),
    ('linear', [0.1, 0.1 + 0.02 * 5, 0.1 + 0.02 * 10]),
    ('exponential', [0.1, 0.1 * np.exp(0.1), 0.1 * np.exp(0.2)]),
    ('power', [0.1, 0.1 + 0.02 * 5 ** 3, 0.1 + 0.02 * 10 ** 3]),
    ('step', [0.1, 0.1 + 0.3, 0.1 + 0.3]),
])
def test_wear_trajectories(kind: str, expected: list[float]) -> None:
    wear = Wear(kind, 0.1, 0.02, t_fault=5.0, step=0.3, exponent=3.0)
    np.testing.assert_allclose(wear.value([0.0, 5.0, 10.0]), expected)


def test_step_wear_keeps_its_initial_value_until_the_fault() -> None:
    wear = Wear('step', 0.1, 0.02, t_fault=5.0, step=0.3, exponent=3.0)
    assert wear.value(4.999) == pytest.approx(0.1)
    assert wear.value(5.0) == pytest.approx(0.4)


def test_wear_reaching_and_when_each_law_passes_a_value() -> None:
    for kind in ('linear', 'exponential', 'power'):
        wear = Wear.reaching(kind, 0.05, 0.3, 200.0, exponent=3.0)
        assert wear.value(200.0) == pytest.approx(0.3)
        # the time each law reaches 0.1: 0.05 + 0.25 t/200, 0.05 6^(t/200), 0.05 + 0.25 (t/200)^3
        t_01 = {'linear': 40.0, 'exponential': 200.0 * np.log(2.0) / np.log(6.0),
                'power': 200.0 * 0.2 ** (1.0 / 3.0)}[kind]
        assert wear.value(t_01) == pytest.approx(0.1)
        assert np.all(np.diff(wear.value(np.linspace(0.0, 200.0, 401))) > 0.0)   # rising
    assert Wear.reaching('power', 0.05, 0.3, 200.0, exponent=3.0).value(100.0) \
        == pytest.approx(0.05 + 0.25 / 8.0)                   # slow at first, then faster
    with pytest.raises(ValueError, match='exponent must be > 0'):
        Wear('power', 0.1, 0.02, exponent=0.0)
    assert np.all(Wear('constant', 0.1).value(np.linspace(0.0, 1e9, 11)) == 0.1)   # never 0.2
    step = Wear('step', 0.1, t_fault=3.0, step=0.2)
    assert step.value(np.nextafter(3.0, 0.0)) == 0.1 and step.value(3.0) == pytest.approx(0.3)


@settings(max_examples=60, deadline=None)
@given(field=st.sampled_from(['initial', 'rate', 't_fault', 'step']),
       value=st.floats(max_value=-1e-9, allow_nan=False, allow_infinity=False))
def test_negative_wear_field_raises_naming_it(field: str, value: float) -> None:
    with pytest.raises(ValueError, match=f'{field} must be >= 0'):
        Wear('linear', **{field: value})
