"""Pin every deviation of gear_phm.models from the printed paper (docs/paper-errata.md).

For each erratum the printed formula is implemented here, a property is stated that the
physics requires, and the test asserts that the property FAILS for the printed formula
(hypothesis ``find`` or a concrete counterexample) and HOLDS for the code.
"""
from __future__ import annotations

import inspect
import math
import re

from hypothesis import find, given, settings
from hypothesis import strategies as st
import pytest

from gear_phm.models import (eta_aiding, eta_aiding_from_opposing, eta_opposing,
                             eta_opposing_from_aiding, SpurGear)
import gear_phm.models.lever as lever_module
from helpers.spur_gear import geometries, mesh_work_efficiencies

SETTINGS = settings(max_examples=200, deadline=None, derandomize=True)
FIND_SETTINGS = settings(max_examples=500, database=None, derandomize=True)


def close(a: float, b: float, tol: float = 1e-9) -> bool:
    return math.isclose(a, b, rel_tol=tol, abs_tol=tol)


# ================================================================= lever (section 3)

def lever_forces(l1: float, l2: float, rho: float, aiding: bool) -> tuple[float, float]:
    """(F_M, F_U) [N] of a lever with pivot friction radius rho, for F_U = 1 N.

    Independent statics: both forces push the same way on opposite arms, so the pivot
    reaction is F_M + F_U; its friction moment rho (F_M + F_U) about the pivot centre opposes
    the rotation. Opposing load: the motor moment drives. Aiding load: the load moment drives.
    Solved for F_M from the affine moment residual.
    """
    load = 1.0

    def residual(motor: float) -> float:
        driving = load * l2 - motor * l1 if aiding else motor * l1 - load * l2
        return driving - rho * (motor + load)

    motor = -residual(0.0) / (residual(1.0) - residual(0.0))
    return motor, load


def lever_power_efficiency(l1: float, l2: float, rho: float, aiding: bool) -> float:
    """Output power / input power [-]; the end speeds are proportional to the arms."""
    motor, load = lever_forces(l1, l2, rho, aiding)
    motor_power, load_power = motor * l1, load * l2           # times a common angular speed
    return motor_power / load_power if aiding else load_power / motor_power


@st.composite
def levers(draw) -> tuple[float, float, float]:
    l1, l2 = draw(st.floats(0.1, 10.0)), draw(st.floats(0.1, 10.0))
    rho = draw(st.floats(0.0, 0.9)) * min(l1, l2)
    return l1, l2, rho


def printed_eta_opposing(l1: float, l2: float, rho: float) -> float:
    """Eq 10 with the printed definition R = l2 / l1 and u = rho / l2."""
    ratio, u = l2 / l1, rho / l2
    return (ratio - u) / (ratio * (1 + u))


# ---- E1: R = l1 / l2 (ideal force gain), not l2 / l1.

@SETTINGS
@given(lever=levers())
def test_e1_code_ratio_is_force_gain(lever) -> None:
    l1, l2, rho = lever
    expected = lever_power_efficiency(l1, l2, rho, aiding=False)
    assert close(eta_opposing(rho / l2, l1 / l2), expected)


def test_e1_printed_ratio_definition_fails() -> None:
    counterexample = find(
        levers(), lambda lever: not close(printed_eta_opposing(*lever),
                                          lever_power_efficiency(*lever, aiding=False)),
        settings=FIND_SETTINGS)
    assert counterexample is not None
    # l1 = 2 l2: printed R = l2 / l1 = 1/2, so "eta_D = 0 at u = R" puts the jam at
    # rho = l2 / 2, where the lever in fact still moves with efficiency 1/2.
    l1, l2 = 2.0, 1.0
    assert lever_power_efficiency(l1, l2, 0.0, aiding=False) == pytest.approx(1.0)
    rho = 0.5 * l2
    assert printed_eta_opposing(l1, l2, rho) == pytest.approx(0.0, abs=1e-15)
    assert lever_power_efficiency(l1, l2, rho, aiding=False) == pytest.approx(0.5)
    assert eta_opposing(rho / l2, l1 / l2) == pytest.approx(0.5)


# ---- E2: aiding balance uses F_M,I, not F_M,D.

@SETTINGS
@given(lever=levers())
def test_e2_aiding_balance_with_aiding_motor_force(lever) -> None:
    l1, l2, rho = lever
    motor_i, load = lever_forces(l1, l2, rho, aiding=True)
    assert close(load, motor_i * (l1 + rho) / (l2 - rho))        # corrected eq 11
    assert close(eta_aiding(rho / l2, l1 / l2), lever_power_efficiency(l1, l2, rho, True))


def test_e2_printed_balance_with_opposing_motor_force_fails() -> None:
    def printed_balance_holds(lever) -> bool:
        l1, l2, rho = lever
        motor_d, load = lever_forces(l1, l2, rho, aiding=False)
        return close(load, motor_d * (l1 + rho) / (l2 - rho))   # printed "(13)"

    counterexample = find(levers(), lambda lever: not printed_balance_holds(lever),
                          settings=FIND_SETTINGS)
    assert counterexample[2] > 0.0
    assert not printed_balance_holds((2.0, 1.0, 0.2))
    assert printed_balance_holds((2.0, 1.0, 0.0))                # hides without friction


# ---- E3: equation numbering (aiding pair printed as 13, 14, which are reused).

def _equation_numbers(text: str) -> list[int]:
    return [int(n) for n in re.findall(r'\((\d+)\)\s*$', text, flags=re.MULTILINE)]


def test_e3_equation_numbers_are_unique_in_code() -> None:
    numbers = _equation_numbers(inspect.getdoc(lever_module))
    assert numbers == [10, 11, 12, 13, 14]
    assert len(set(numbers)) == len(numbers)
    assert '(eq 12)' in inspect.getdoc(eta_aiding)
    assert '(eq 14)' in inspect.getdoc(eta_aiding_from_opposing)


def test_e3_printed_numbering_is_ambiguous() -> None:
    printed = '\n'.join(['F_U,D = F_M,D (l1 - rho)/(l2 + rho)   (9)',
                         'eta_D = (R - u)/(R (1 + u))           (10)',
                         'F_U,I = F_M,D (l1 + rho)/(l2 - rho)   (13)',
                         'eta_I = R (1 - u)/(R + u)             (14)',
                         'u = (R - R eta_D)/(R eta_D + 1)       (13)',
                         'eta_I = ...                           (14)'])
    numbers = _equation_numbers(printed)
    assert len(set(numbers)) < len(numbers)


# ---- E4: eq 14 denominator.

def printed_eq14(eta_d: float, ratio: float) -> float:
    return (2 * ratio ** 2 * eta_d - ratio ** 2 + ratio) / (
        ratio ** 2 * eta_d + ratio - eta_d + 1)


CURVE_POINTS = st.tuples(st.floats(0.0, 20.0), st.floats(0.1, 50.0))


@SETTINGS
@given(point=CURVE_POINTS)
def test_e4_code_eq14_is_eq12_of_eq13(point) -> None:
    u, ratio = point
    assert close(eta_aiding_from_opposing(eta_opposing(u, ratio), ratio),
                 eta_aiding(u, ratio))
    assert close(eta_opposing_from_aiding(eta_aiding(u, ratio), ratio),
                 eta_opposing(u, ratio))


def test_e4_printed_eq14_fails() -> None:
    u, ratio = find(CURVE_POINTS, lambda p: not close(printed_eq14(eta_opposing(*p), p[1]),
                                                      eta_aiding(*p)),
                    settings=FIND_SETTINGS)
    assert ratio != 1.0
    # The concrete case of the notes: R = 2, u = 0.5 -> eta_D = 0.5, eta_I = 0.4, printed 4/9.
    assert eta_opposing(0.5, 2.0) == pytest.approx(0.5)
    assert eta_aiding_from_opposing(0.5, 2.0) == pytest.approx(0.4)
    assert printed_eq14(0.5, 2.0) == pytest.approx(2.0 / 4.5)
    # Why the error hides: both agree at R = 1 and at eta_D = 1.
    assert printed_eq14(0.3, 1.0) == pytest.approx(eta_aiding_from_opposing(0.3, 1.0))
    assert printed_eq14(1.0, 7.0) == pytest.approx(eta_aiding_from_opposing(1.0, 7.0))


# ================================================================= spur gear (section 2)

def paper_spur_efficiencies(z1, z2, module, pressure_angle, addendum, friction,
                            bearing_radius_1, bearing_radius_2, *,
                            pitch_radius_per_module_tooth: float = 0.5,
                            aiding_load_bearing: str = 'rho_2') -> tuple[float, float]:
    """Eqs 1-8 as printed, with switches for the two errata (E5: r_p = m z; E6: rho_1)."""
    sin_t, cos_t = math.sin(pressure_angle), math.cos(pressure_angle)
    r_p1 = pitch_radius_per_module_tooth * module * z1
    r_p2 = pitch_radius_per_module_tooth * module * z2
    r_b1, r_b2 = r_p1 * cos_t, r_p2 * cos_t
    d_p1, d_p2 = r_p1 * sin_t, r_p2 * sin_t
    a = math.sqrt((r_p1 + addendum) ** 2 - r_b1 ** 2) - d_p1                      # (1)
    b = math.sqrt((r_p2 + addendum) ** 2 - r_b2 ** 2) - d_p2                      # (2)
    f, k = friction, friction / (a + b)
    bearing = math.sqrt(1 + (f * (a - b) / (a + b)) ** 2)
    rho_u_i = bearing_radius_2 if aiding_load_bearing == 'rho_2' else bearing_radius_1
    t_m_d = r_b1 - k * b * (d_p1 - b / 2) + k * a * (d_p1 + a / 2) + bearing_radius_1 * bearing
    t_u_d = r_b2 - k * b * (d_p2 + b / 2) + k * a * (d_p2 - a / 2) - bearing_radius_2 * bearing
    t_m_i = r_b1 + k * b * (d_p1 - b / 2) - k * a * (d_p1 + a / 2) - bearing_radius_1 * bearing
    t_u_i = r_b2 + k * b * (d_p2 + b / 2) - k * a * (d_p2 - a / 2) + rho_u_i * bearing
    ratio = z2 / z1
    return t_u_d / (ratio * t_m_d), ratio * t_m_i / t_u_i                        # (5), (8)


@SETTINGS
@given(geometry=geometries())
def test_corrected_paper_formulas_are_the_code(geometry) -> None:
    """The printed-formula implementation above, with both corrections, is SpurGear."""
    expected = paper_spur_efficiencies(**geometry)
    assert SpurGear(**geometry).efficiencies() == pytest.approx(expected, rel=1e-12)


# ---- E5: pitch radius m z / 2.

@SETTINGS
@given(geometry=geometries())
def test_e5_base_pitch_equals_rack_normal_pitch(geometry) -> None:
    """Teeth of module m mesh with a module-m rack only if 2 pi r_b / z = pi m cos(theta)."""
    geometry.update(friction=0.0, bearing_radius_1=0.0, bearing_radius_2=0.0)
    torques = SpurGear(**geometry).torques()            # frictionless: T_M,D / F = r_b1
    rack_pitch = math.pi * geometry['module'] * math.cos(geometry['pressure_angle'])
    assert close(2 * math.pi * torques['T_M_D'] / geometry['z1'], rack_pitch, 1e-12)
    assert close(2 * math.pi * torques['T_U_D'] / geometry['z2'], rack_pitch, 1e-12)


@SETTINGS
@given(geometry=geometries())
def test_e5_code_matches_work_integration(geometry) -> None:
    expected = mesh_work_efficiencies(**geometry)
    assert SpurGear(**geometry).efficiencies() == pytest.approx(expected, rel=1e-9, abs=1e-9)


def test_e5_printed_pitch_radius_fails() -> None:
    # Printed r_p = m z: base pitch 2 pi m cos(theta), twice the rack pitch.
    module, theta, z = 1e-3, math.radians(20.0), 20
    printed_base_radius = module * z * math.cos(theta)
    assert not close(2 * math.pi * printed_base_radius / z, math.pi * module * math.cos(theta))

    def printed_matches_integration(geometry) -> bool:
        printed = paper_spur_efficiencies(**geometry, pitch_radius_per_module_tooth=1.0)
        expected = mesh_work_efficiencies(**geometry)
        return close(printed[0], expected[0], 1e-6) and close(printed[1], expected[1], 1e-6)

    counterexample = find(geometries(), lambda g: not printed_matches_integration(g),
                          settings=FIND_SETTINGS)
    assert counterexample['friction'] > 0.0 or counterexample['bearing_radius_1'] > 0.0 \
        or counterexample['bearing_radius_2'] > 0.0
    # 20/60 at 20 deg, f = 0.05, a = m: printed 0.9953, physical 0.9913.
    textbook = {'z1': 20, 'z2': 60, 'module': 2e-3, 'pressure_angle': theta, 'addendum': 2e-3,
                'friction': 0.05, 'bearing_radius_1': 0.0, 'bearing_radius_2': 0.0}
    printed = paper_spur_efficiencies(**textbook, pitch_radius_per_module_tooth=1.0)
    assert printed[0] == pytest.approx(0.99531, abs=1e-5)
    assert SpurGear(**textbook).efficiencies()[0] == pytest.approx(0.99126, abs=1e-5)


# ---- E6: eq 7 bearing term is rho_2.

@SETTINGS
@given(geometry=geometries(), rho_2_fraction=st.floats(0.01, 0.5))
def test_e6_load_bearing_dissipates_under_aiding_load(geometry, rho_2_fraction) -> None:
    geometry.update(friction=0.0, bearing_radius_1=0.0,
                    bearing_radius_2=rho_2_fraction * geometry['module'] * geometry['z2'] / 2)
    eta_d, eta_i = SpurGear(**geometry).efficiencies()
    assert eta_i < 1.0
    assert eta_i == pytest.approx(mesh_work_efficiencies(**geometry)[1], rel=1e-9)


def test_e6_printed_bearing_term_fails() -> None:
    def printed_dissipates(geometry) -> bool:
        geometry = dict(geometry, friction=0.0, bearing_radius_1=0.0,
                        bearing_radius_2=0.2 * geometry['module'] * geometry['z2'] / 2)
        return paper_spur_efficiencies(**geometry, aiding_load_bearing='rho_1')[1] < 1.0

    counterexample = find(geometries(), lambda g: not printed_dissipates(g),
                          settings=FIND_SETTINGS)
    assert counterexample is not None
    # Printed eq 7 with a lossy load bearing and nothing else: eta_I = 1 exactly (no loss).
    geometry = {'z1': 30, 'z2': 30, 'module': 1e-3, 'pressure_angle': math.radians(20),
                'addendum': 1e-3, 'friction': 0.0, 'bearing_radius_1': 0.0,
                'bearing_radius_2': 5e-3}
    assert paper_spur_efficiencies(**geometry, aiding_load_bearing='rho_1')[1] == 1.0
    work = mesh_work_efficiencies(**geometry)[1]
    assert work < 0.99
    assert SpurGear(**geometry).efficiencies()[1] == pytest.approx(work, rel=1e-9)
    # Symmetric pair: swapping the bearings swaps the roles; eta_I with a lossy load bearing
    # equals eta_D with the same bearing on the motor side mirrored (energy bookkeeping).
    mirrored = dict(geometry, bearing_radius_1=5e-3, bearing_radius_2=0.0)
    assert SpurGear(**geometry).efficiencies()[1] == pytest.approx(
        SpurGear(**mirrored).efficiencies()[0], rel=1e-12)
