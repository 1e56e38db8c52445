"""The plant's parameters (gear_phm.simulation.plant): validation names the field."""
from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
import pytest

from gear_phm.simulation.plant import Plant


@settings(max_examples=60, deadline=None)
@given(field=st.sampled_from(['ratio', 'motor_inertia', 'load_inertia', 'air_load_preload']),
       value=st.one_of(st.floats(max_value=-1e-9, allow_nan=False),
                       st.just(float('nan')), st.just(float('inf'))))
def test_invalid_plant_field_raises_naming_it(field: str, value: float) -> None:
    with pytest.raises(ValueError, match=field):
        Plant(**{field: value})
