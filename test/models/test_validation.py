"""The models' argument checks (gear_phm.models._validation): one-line ModelError messages."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gear_phm.errors import GearPhmError
from gear_phm.models._validation import (at_least, finite, in_half_open_interval,
                                         in_open_interval, ModelError, non_negative, positive,
                                         real_scalar, result, scalar_ratio, unwrap)


def test_model_error_is_a_gear_phm_error_and_a_value_error() -> None:
    assert issubclass(ModelError, GearPhmError) and issubclass(ModelError, ValueError)


def test_finite_names_the_first_bad_element_and_counts_them() -> None:
    np.testing.assert_array_equal(finite('u', [0.1, 0.2]), [0.1, 0.2])
    with pytest.raises(ModelError) as caught:
        finite('u', [[0.1, math.nan], [math.inf, 0.2]])
    assert str(caught.value) == 'u must be finite, got nan at index (0, 1) (2 bad element(s))'
    with pytest.raises(ModelError, match=r"^u must be a real number or array, got 'x'$"):
        finite('u', 'x')


def test_bounds_name_the_argument_and_the_value() -> None:
    with pytest.raises(ModelError, match=r'^ratio must be > 0, got 0\.0$'):
        positive('ratio', 0.0)
    with pytest.raises(ModelError, match=r'^f must be >= 0, got -0\.5$'):
        non_negative('f', -0.5)
    with pytest.raises(ModelError, match=r'^beta must be in \(0, 1\.5\) rad, got 1\.5$'):
        in_open_interval('beta', 1.5, 0.0, 1.5, ' rad')
    np.testing.assert_array_equal(in_half_open_interval('a', [0.0, 0.5], 0.0, 1.0), [0.0, 0.5])
    with pytest.raises(ModelError, match=r'^a must be in \[0, 1\), got 1\.0 at index \(1,\)'):
        in_half_open_interval('a', [0.5, 1.0], 0.0, 1.0)


def test_at_least_broadcasts_the_bound_and_says_why() -> None:
    np.testing.assert_array_equal(at_least('z', [17.0, 20.0], [17.0, 18.0], 'no undercut'),
                                  [17.0, 20.0])
    with pytest.raises(ModelError, match=r'^z must be >= 18 \(no undercut\), got 17\.0 at '):
        at_least('z', 17.0, [17.0, 18.0], 'no undercut')


def test_scalars_and_ratios() -> None:
    real_scalar('n', np.float64(2.0))
    for bad in (True, [1.0], np.array([1.0]), '1'):
        with pytest.raises(ModelError, match='^n must be a real number'):
            real_scalar('n', bad)
    scalar_ratio(3.0)
    for bad_ratio in (0.0, -1.0, math.inf, math.nan):
        with pytest.raises(ModelError, match='^ratio must be > 0 and finite'):
            scalar_ratio(bad_ratio)


def test_results_are_floats_when_0_d_and_arrays_otherwise() -> None:
    assert type(result(np.float64(0.5))) is float and result(np.array(0.25)) == 0.25
    assert isinstance(result([0.5, 0.6]), np.ndarray)
    assert type(unwrap(np.array(0.5))) is np.float64
    array = np.array([1.0, 2.0])
    assert unwrap(array) is array
