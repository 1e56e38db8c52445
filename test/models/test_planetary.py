"""Planetary gear set (gear_phm.models.PlanetaryGearSet): Willis closed forms per configuration."""
from __future__ import annotations

import math

from hypothesis import assume, given, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from gear_phm.models import GearTrain, InternalGear, ModelError, SpurGear
from gear_phm.models.internal_gear import interference_free
from gear_phm.models.planetary import PlanetaryGearSet

SETTINGS = settings(max_examples=100, deadline=None, derandomize=True)


@st.composite
def sets(draw) -> dict:
    fields = {'z_sun': float(draw(st.integers(18, 80))),
              'z_planet': float(draw(st.integers(18, 80))),
              'module': draw(st.floats(0.5e-3, 4e-3)),
              'pressure_angle': math.radians(draw(st.floats(20.0, 25.0))),
              'friction': draw(st.floats(0.0, 0.3))}
    z_ring = fields['z_sun'] + 2 * fields['z_planet']
    assume(bool(interference_free(fields['z_planet'], z_ring, fields['pressure_angle'])))
    return fields


def basic(fields: dict) -> tuple[float, float, float]:
    """(k, eta0, eta0') from the two meshes, built here without the set."""
    z_ring = fields['z_sun'] + 2 * fields['z_planet']
    mesh = {k: fields[k] for k in ('module', 'pressure_angle', 'friction')}
    sp_d, sp_i = SpurGear(fields['z_sun'], fields['z_planet'], **mesh).efficiencies()
    pr_d, pr_i = InternalGear(fields['z_planet'], z_ring, **mesh).efficiencies()
    return z_ring / fields['z_sun'], sp_d * pr_d, pr_i * sp_i


#: (fixed, driving) -> (R, eta_D, eta_I) of (k, eta0, eta0'): Mueller's tables, each derived
#: with the power-loss method (loss = (1 - eta0) times the power through the meshes).
CLOSED_FORMS = {
    ('ring', 'sun'): (lambda k, e, r: 1 + k, lambda k, e, r: (1 + k * e) / (1 + k),
                      lambda k, e, r: (1 + k) * r / (k + r)),
    ('ring', 'carrier'): (lambda k, e, r: 1 / (1 + k), lambda k, e, r: (1 + k) * r / (k + r),
                          lambda k, e, r: (1 + k * e) / (1 + k)),
    ('sun', 'ring'): (lambda k, e, r: (1 + k) / k, lambda k, e, r: (k + r) / (1 + k),
                      lambda k, e, r: (1 + k) * e / (1 + k * e)),
    ('sun', 'carrier'): (lambda k, e, r: k / (1 + k), lambda k, e, r: (1 + k) * e / (1 + k * e),
                         lambda k, e, r: (k + r) / (1 + k)),
    ('carrier', 'sun'): (lambda k, e, r: k, lambda k, e, r: e, lambda k, e, r: r),
    ('carrier', 'ring'): (lambda k, e, r: 1 / k, lambda k, e, r: r, lambda k, e, r: e),
}


@SETTINGS
@given(fields=sets(), configuration=st.sampled_from(sorted(CLOSED_FORMS)))
def test_every_configuration_matches_its_closed_form(fields: dict, configuration) -> None:
    fixed, driving = configuration
    gear = PlanetaryGearSet(**fields, fixed=fixed, driving=driving)
    k, eta0, eta0_reverse = basic(fields)
    ratio, eta_d, eta_i = (form(k, eta0, eta0_reverse) for form in CLOSED_FORMS[configuration])
    assert gear.ratio == pytest.approx(ratio, rel=1e-12)
    assert gear.efficiencies() == pytest.approx((eta_d, eta_i), rel=1e-9, abs=1e-9)
    assert gear.basic_efficiencies() == pytest.approx((eta0, eta0_reverse), rel=1e-12)


@SETTINGS
@given(k=st.floats(1.5, 12.0), eta0=st.floats(0.05, 1.0))
def test_ring_fixed_sun_driving_is_the_textbook_reducer(k: float, eta0: float) -> None:
    """Check eta = (1 + k eta0) / (1 + k) by the power-loss method (the table's first row)."""
    expected_d = CLOSED_FORMS[('ring', 'sun')][1](k, eta0, eta0)
    # Power-loss method, independently: the meshes carry T_sun (omega_sun - omega_carrier).
    omega_sun, omega_carrier = 1.0, 1.0 / (1.0 + k)
    through_meshes = omega_sun - omega_carrier                   # per unit sun torque
    assert 1.0 - (1.0 - eta0) * through_meshes / omega_sun == pytest.approx(expected_d)


def test_typical_reducer_numbers() -> None:
    gear = PlanetaryGearSet(20, 30, friction=0.08)          # ring 80, k 4, R 5
    eta0, eta0_reverse = gear.basic_efficiencies()
    eta_d, eta_i = gear.efficiencies()
    assert gear.ratio == 5.0 and gear.z_ring == 80.0 and gear.output == 'carrier'
    assert eta0 == pytest.approx(0.97825, abs=1e-5)
    assert eta_d == pytest.approx((1 + 4 * eta0) / 5, rel=1e-12)
    assert eta_i == pytest.approx(5 * eta0_reverse / (4 + eta0_reverse), rel=1e-12)
    assert eta_d > eta0                                      # the carrier's share is lossless
    assert gear.speeds()['carrier'] == pytest.approx(0.2)
    assert PlanetaryGearSet(20, 30, fixed='carrier').reverses is True
    assert PlanetaryGearSet(20, 30, friction=0.0).efficiencies() == pytest.approx((1.0, 1.0))


def test_shorter_ring_teeth_avoid_interference() -> None:
    gear = PlanetaryGearSet(18, 18, friction=0.05, ring_addendum=0.8e-3)
    assert 0.9 < gear.efficiencies()[0] < 1.0


def test_multi_stage_planetary_multiplies() -> None:
    first = PlanetaryGearSet(20, 30, friction=0.08)
    second = PlanetaryGearSet(24, 36, module=2e-3, friction=0.06)
    train = GearTrain((first, second))
    assert train.ratio == pytest.approx(25.0, rel=1e-15)
    (d1, i1), (d2, i2) = first.efficiencies(), second.efficiencies()
    assert train.efficiencies() == pytest.approx((d1 * d2, i1 * i2), rel=1e-12)


def test_arrays_broadcast() -> None:
    gear = PlanetaryGearSet(np.array([18.0, 20.0, 30.0]), 30.0, friction=0.05, fixed='sun',
                            driving='ring')
    eta_d, eta_i = gear.efficiencies()
    assert eta_d.shape == eta_i.shape == (3,)
    single = PlanetaryGearSet(20.0, 30.0, friction=0.05, fixed='sun', driving='ring')
    assert eta_d[1] == pytest.approx(single.efficiencies()[0], rel=1e-15)


@pytest.mark.parametrize('fields, message', [
    ({'fixed': 'planet'}, r"^fixed must be one of sun, ring, carrier, got 'planet'$"),
    ({'driving': 'ring', 'fixed': 'ring'}, r"^driving must differ from fixed, both are 'ring'$"),
    ({'z_ring': 81.0}, r'^z_ring must be z_sun \+ 2 z_planet \(80, coaxial'),
    ({'z_sun': 0.0}, r'^z_sun must be > 0, got 0\.0$'),
    ({'friction': -0.1}, r'^sun-planet mesh .*: friction must be >= 0, got -0\.1$'),
    ({'z_planet': 10.0}, r'^sun-planet mesh \(z1 = z_sun, z2 = z_planet\): z2 must be >= 17'),
    ({'z_planet': 18.0}, r'^planet-ring mesh \(z1 = z_planet, z2 = z_ring\): z2 56\.0 gives '
                         'involute interference'),
    ({'z_planet': 18.0, 'ring_addendum': 0.0}, r'^planet-ring mesh .*: ring_addendum must be'),
])
def test_bad_fields_raise_model_error_naming_them(fields: dict, message: str) -> None:
    arguments = {'z_sun': 20.0, 'z_planet': 30.0, **fields}
    with pytest.raises(ModelError, match=message):
        PlanetaryGearSet(**arguments)
