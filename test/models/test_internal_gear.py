"""Internal mesh (gear_phm.models.InternalGear) against an independent work integration."""
from __future__ import annotations

import math

from hypothesis import assume, given, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from gear_phm.models import InternalGear, min_teeth, ModelError
from gear_phm.models.internal_gear import interference_free

SETTINGS = settings(max_examples=150, deadline=None, derandomize=True)


def _tip_points(centre: np.ndarray, radius: float) -> list[float]:
    """Return x of the points where the x axis (the line of action) meets a circle."""
    half = math.sqrt(radius ** 2 - centre[1] ** 2)
    return [centre[0] - half, centre[0] + half]


def internal_work_efficiencies(z1: float, z2: float, module: float, pressure_angle: float,
                               addendum: float, friction: float,
                               steps: int = 2000) -> tuple[float, float]:
    """(eta_D, eta_I) [-]: both wheels placed in the plane, power integrated along the path.

    The line of action is the x axis; the pinion's base circle touches it at the origin from
    below, the ring's base circle (same side, same sense of rotation) further back. The
    contact runs where the point lies inside the pinion's tip circle and outside the ring's
    (inner) tip circle; velocities of each wheel's material at the point give the sliding,
    Coulomb friction opposes it. Aiding: the same flanks with the motion reversed.
    """
    r_p1, r_p2 = module * z1 / 2, module * z2 / 2
    r_b1, r_b2 = r_p1 * math.cos(pressure_angle), r_p2 * math.cos(pressure_angle)
    o1 = np.array([0.0, -r_b1])
    # The ring's centre: at distance r_p2 - r_p1 from o1, its base circle tangent to the x axis.
    dy = r_b2 - r_b1
    o2 = np.array([-math.sqrt((r_p2 - r_p1) ** 2 - dy ** 2), -r_b2])
    pitch = o1 + (o1 - o2) * r_p1 / (r_p2 - r_p1)         # on the ray o2 -> o1, r_p1 beyond
    assert abs(pitch[1]) < 1e-12 * r_p2
    start = _tip_points(o2, r_p2 - addendum)[1]           # ring tip, on the pinion's side
    end = _tip_points(o1, r_p1 + addendum)[1]             # pinion tip
    omega_1, omega_2 = 1.0, r_b1 / r_b2
    results = []
    for sense in (1.0, -1.0):
        power_1 = power_2 = 0.0
        for side in ((start, pitch[0]), (pitch[0], end)):   # midpoints: exact, linear sides
            width = (side[1] - side[0]) / steps
            x = side[0] + width * (np.arange(steps) + 0.5)
            v1 = sense * omega_1 * np.stack([o1[1] + 0.0 * x, x - o1[0]])
            v2 = sense * omega_2 * np.stack([o2[1] + 0.0 * x, x - o2[0]])
            assert np.allclose(v1[0], v2[0], rtol=0, atol=1e-12)  # no separation
            slip = v1[1] - v2[1]                                 # pinion relative to ring
            # The pinion pushes the ring along their common normal motion (-x here).
            force_on_2 = np.stack([-1.0 + 0.0 * x, friction * np.sign(slip)])
            power_2 += float(np.sum(force_on_2 * v2)) * width
            power_1 += -float(np.sum(force_on_2 * v1)) * width
        # Opposing: the pinion gives (power_1 < 0), the ring takes; aiding the reverse.
        results.append(power_2 / -power_1 if sense > 0 else power_1 / -power_2)
    return results[0], results[1]


@st.composite
def meshes(draw) -> dict:
    theta = draw(st.floats(math.radians(17.0), math.radians(30.0)))
    z1 = float(draw(st.integers(math.ceil(float(min_teeth(theta))), 60)))
    z2 = float(draw(st.integers(int(z1) + 12, 300)))
    assume(bool(interference_free(z1, z2, theta)))
    module = draw(st.floats(0.5e-3, 5e-3))
    return {'z1': z1, 'z2': z2, 'module': module, 'pressure_angle': theta,
            'addendum': module, 'friction': draw(st.floats(0.0, 0.5))}


@SETTINGS
@given(mesh=meshes())
def test_matches_work_integration(mesh: dict) -> None:
    expected = internal_work_efficiencies(**mesh)
    assert InternalGear(**mesh).efficiencies() == pytest.approx(expected, rel=1e-9, abs=1e-9)


def test_integration_resolves_friction() -> None:
    base = internal_work_efficiencies(20, 80, 2e-3, math.radians(20), 2e-3, 0.05)
    more = internal_work_efficiencies(20, 80, 2e-3, math.radians(20), 2e-3, 0.06)
    assert base[0] - more[0] > 5e-4
    assert base[1] - more[1] > 5e-4


def test_first_order_loss_and_comparison_with_external() -> None:
    # Loss f (1/r_b1 - 1/r_b2) mean|s|, mean|s| = (A^2 + B^2) / (2 (A + B)).
    module, theta, f = 2e-3, math.radians(20.0), 0.02
    r_p1, r_p2 = module * 10, module * 40
    r_b1, r_b2 = r_p1 * math.cos(theta), r_p2 * math.cos(theta)
    a = math.sqrt((r_p1 + module) ** 2 - r_b1 ** 2) - r_p1 * math.sin(theta)
    b = r_p2 * math.sin(theta) - math.sqrt((r_p2 - module) ** 2 - r_b2 ** 2)
    loss = f * (1 / r_b1 - 1 / r_b2) * (a * a + b * b) / (2 * (a + b))
    eta_d, eta_i = InternalGear(20, 80, module, theta, friction=f).efficiencies()
    assert eta_d == pytest.approx(1 - loss, abs=2e-5)
    assert eta_i == pytest.approx(1 - loss, abs=2e-5)
    assert InternalGear(20, 80, module, theta).efficiencies() == (1.0, 1.0)
    assert InternalGear(20, 80).ratio == 4.0


def test_bad_fields_raise_model_error_naming_them() -> None:
    with pytest.raises(ModelError, match=r'^z1 must be >= 17\.1'):
        InternalGear(12, 80)
    with pytest.raises(ModelError, match=r'^z2 must be >= 21 \(a ring has more teeth'):
        InternalGear(20, 20)
    with pytest.raises(ModelError, match=r'^z2 21\.0 gives involute interference'):
        InternalGear(20, 21)
    with pytest.raises(ModelError, match=r'^friction must be >= 0, got -0\.1$'):
        InternalGear(20, 80, friction=-0.1)
    with pytest.raises(ModelError, match=r'^module must be > 0'):
        InternalGear(20, 80, module=0.0)
