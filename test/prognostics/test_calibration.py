"""The RUL band's quantiles (gear_phm.prognostics.calibration) against numpy's."""
from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(st.floats(-1e9, 1e9), st.just(math.inf), st.just(0.0)), min_size=1,
                max_size=300),
       st.lists(st.floats(0.0, 1.0), min_size=1, max_size=4))
def test_rul_quantiles_equal_numpys_inverted_cdf(values: list[float],
                                                 probabilities: list[float]) -> None:
    from gear_phm.prognostics.calibration import inverted_cdf_quantiles
    array = np.array(values)
    assert inverted_cdf_quantiles(array, tuple(probabilities)) == \
        np.quantile(array, probabilities, method='inverted_cdf').tolist()
