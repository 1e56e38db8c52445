"""The simulation configs' scalar checks (gear_phm.simulation._checks)."""
from __future__ import annotations

import math

import pytest

from gear_phm.simulation._checks import non_negative, one_of, positive, real


def test_real_takes_finite_numbers_and_number_strings() -> None:
    assert real('x', 3) == 3.0 and isinstance(real('x', 3), float)
    assert real('x', '2.5') == 2.5 and real('x', -1e-300) == -1e-300


@pytest.mark.parametrize('value, message', [
    (True, 'x must be a real number, got True'),
    ('abc', "x must be a real number, got 'abc'"),
    (None, 'x must be a real number, got None'),
    (math.nan, 'x must be finite, got nan'),
    (-math.inf, 'x must be finite, got -inf'),
])
def test_real_refuses_what_is_no_finite_number_naming_it(value: object, message: str) -> None:
    with pytest.raises(ValueError) as caught:
        real('x', value)
    assert str(caught.value) == message


def test_positive_and_non_negative_bounds() -> None:
    assert positive('rate', 1e-12) == 1e-12 and non_negative('gap', 0.0) == 0.0
    with pytest.raises(ValueError, match=r'^rate must be > 0, got 0\.0$'):
        positive('rate', 0.0)
    with pytest.raises(ValueError, match=r'^gap must be >= 0, got -1e-09$'):
        non_negative('gap', -1e-9)


def test_one_of_names_the_choices() -> None:
    assert one_of('kind', 'linear', ('linear', 'power')) == 'linear'
    with pytest.raises(ValueError, match="^kind must be one of linear, power; got 'cubic'$"):
        one_of('kind', 'cubic', ('linear', 'power'))
