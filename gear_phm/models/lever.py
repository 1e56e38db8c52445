"""Simplified lever model of a transmission (Berri et al., eqs 9-14, corrected).

A lever with friction in its pivot stands for any transmission of ratio ``R``. The pivot
friction is a friction radius ``rho``: the hinge reaction is offset by ``rho`` to the side that
opposes the motion. With motor arm ``l1`` and load arm ``l2``:

* ``R = l1 / l2`` is the ideal force (torque) gain ``F_U / F_M`` -- the same meaning as
  ``z2 / z1`` for a gear pair. The paper prints ``R = l2 / l1``; that contradicts its own
  eqs 10, 13 and 14 (see docs/paper-errata.md, E1).
* ``u = rho / l2`` is the dimensionless friction parameter [-]. ``u = 0`` is lossless.

Opposing (direct) load, power flows motor -> load, reaction moves towards the motor force::

    F_U (l2 + rho) = F_M (l1 - rho)
    eta_D = F_U / (R F_M) = (R - u) / (R (1 + u))                                   (10)

Aiding (inverse) load, power flows load -> motor, reaction on the other side::

    F_U (l2 - rho) = F_M (l1 + rho)                                                 (11)
    eta_I = R F_M / F_U  = R (1 - u) / (R + u)                                      (12)

Inverses and the link between the two efficiencies (eq 14 corrected, E4)::

    u = R (1 - eta_D) / (R eta_D + 1)                                               (13)
    u = R (1 - eta_I) / (R + eta_I)                                       (13, aiding)
    eta_I = (2 R eta_D + 1 - R) / ((R - 1) eta_D + 2)                               (14)
    eta_D = (2 eta_I + R - 1) / (2 R - (R - 1) eta_I)                        (14 inverse)

Domain. ``ratio`` must be finite and > 0, every argument finite: otherwise ``ModelError`` (a
``ValueError`` and a :class:`~gear_phm.errors.GearPhmError`) naming the argument and the
value. The physical domain is ``u >= 0``, which maps one-to-one to ``eta_D in (-1/R, 1]`` and
``eta_I in (-R, 1]``. Outside it the functions return the algebraic
continuation of the same formula while its denominator stays positive (e.g. ``eta > 1`` gives
``u < 0``): a noisy measurement just above 1 must map to a slightly negative ``u`` without being
clipped, or an estimator fed with it would be biased. Where the formula has a pole or no real
pre-image (``u <= -1`` for eta_D, ``u <= -R`` for eta_I, ``eta_D <= -1/R``, ``eta_I <= -R``) the
result is NaN. All functions broadcast their arguments like numpy ufuncs, but the float paths
(:func:`efficiencies`, :func:`readings`, :func:`reading_with_slope`), which take one value each.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.models._validation import finite, ModelError, positive, real_scalar, scalar_ratio


def _eta_d_terms(u: Any, ratio: Any) -> tuple[Any, Any]:
    """Numerator and denominator of eq 10 (floats or arrays)."""
    return ratio - u, ratio * (1.0 + u)


def _eta_i_terms(u: Any, ratio: Any) -> tuple[Any, Any]:
    """Numerator and denominator of eq 12 (floats or arrays)."""
    return ratio * (1.0 - u), ratio + u


def _where_valid(valid: np.ndarray, numerator: np.ndarray, denominator: np.ndarray) -> np.ndarray:
    """Divide: numerator / denominator where ``valid``, NaN elsewhere, without warnings."""
    safe = np.where(valid, denominator, 1.0)
    result = np.where(valid, numerator / safe, np.nan)
    return result[()] if result.ndim == 0 else result


def eta_opposing(u: ArrayLike, ratio: ArrayLike) -> np.ndarray | float:
    """Opposing-load (direct) efficiency eta_D [-] of friction parameter u [-] (eq 10).

    eta_D = (R - u) / (R (1 + u)); 1 at u = 0, 0 at u = R, -> -1/R as u -> inf.
    NaN where u <= -1.
    """
    u = finite('u', u)
    ratio = positive('ratio', ratio)
    return _where_valid(u > -1.0, *_eta_d_terms(u, ratio))


def eta_aiding(u: ArrayLike, ratio: ArrayLike) -> np.ndarray | float:
    """Aiding-load (inverse) efficiency eta_I [-] of friction parameter u [-] (eq 12).

    eta_I = R (1 - u) / (R + u); 1 at u = 0, 0 at u = 1 (self-locking onset), -> -R.
    NaN where u <= -R.
    """
    u = finite('u', u)
    ratio = positive('ratio', ratio)
    return _where_valid(u > -ratio, *_eta_i_terms(u, ratio))


def efficiencies(u: float, ratio: float) -> tuple[float, float]:
    """(eta_D, eta_I) [-] of one friction parameter u [-] (eqs 10 and 12), for Python floats.

    The per-update path of the estimator: the same formulas as :func:`eta_opposing` and
    :func:`eta_aiding` without numpy's per-call cost: NaN where a formula is undefined
    (u <= -1, u <= -R) or u is not finite. ModelError if u is not one real number (arrays:
    :func:`efficiencies_array`) or ``ratio`` is not finite and > 0.
    """
    if type(u) is not float:
        real_scalar('u', u)
    if type(ratio) is not float or not 0.0 < ratio < math.inf:
        scalar_ratio(ratio)
    eta_d = math.nan
    eta_i = math.nan
    if u > -1.0 and math.isfinite(u):
        numerator, denominator = _eta_d_terms(u, ratio)
        eta_d = numerator / denominator
    if u > -ratio and math.isfinite(u):
        numerator, denominator = _eta_i_terms(u, ratio)
        eta_i = numerator / denominator
    return eta_d, eta_i


def efficiencies_array(u: np.ndarray, ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """Return :func:`efficiencies` of an array of u [-].

    The same values, element by element (the same float operations); NaN where a formula is
    undefined or u is not finite.
    """
    u = np.asarray(u, dtype=float)
    finite_u = np.isfinite(u)
    with np.errstate(invalid='ignore', divide='ignore', over='ignore'):
        eta_d = _where_valid(finite_u & (u > -1.0), *_eta_d_terms(u, ratio))
        eta_i = _where_valid(finite_u & (u > -ratio), *_eta_i_terms(u, ratio))
    return np.asarray(eta_d, dtype=float), np.asarray(eta_i, dtype=float)


def readings_array(eta_d: np.ndarray, eta_i: np.ndarray, ratio: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Return :func:`readings` of arrays of eta_D and eta_I [-].

    The same values, element by element; NaN where one is undefined or not finite.
    """
    eta_d = np.asarray(eta_d, dtype=float)
    eta_i = np.asarray(eta_i, dtype=float)
    with np.errstate(invalid='ignore', divide='ignore', over='ignore'):
        numerator, denominator = _u_d_terms(eta_d, ratio)
        u_d = _where_valid(np.isfinite(eta_d) & (denominator > 0.0), numerator, denominator)
        numerator, denominator = _u_i_terms(eta_i, ratio)
        u_i = _where_valid(np.isfinite(eta_i) & (denominator > 0.0), numerator, denominator)
    return np.asarray(u_d, dtype=float), np.asarray(u_i, dtype=float)


def _u_d_terms(eta: Any, ratio: Any) -> tuple[Any, Any]:
    """Numerator and denominator of eq 13 (floats or arrays)."""
    return ratio * (1.0 - eta), ratio * eta + 1.0


def _u_i_terms(eta: Any, ratio: Any) -> tuple[Any, Any]:
    """Numerator and denominator of eq 13, aiding (floats or arrays)."""
    return ratio * (1.0 - eta), ratio + eta


def u_from_eta_opposing(eta: ArrayLike, ratio: ArrayLike) -> np.ndarray | float:
    """Friction parameter u [-] from the opposing-load efficiency eta_D [-] (eq 13).

    u = R (1 - eta_D) / (R eta_D + 1). NaN where eta_D <= -1/R (no u reaches it).
    """
    eta = finite('eta', eta)
    ratio = positive('ratio', ratio)
    numerator, denominator = _u_d_terms(eta, ratio)
    return _where_valid(denominator > 0.0, numerator, denominator)


def u_from_eta_aiding(eta: ArrayLike, ratio: ArrayLike) -> np.ndarray | float:
    """Friction parameter u [-] from the aiding-load efficiency eta_I [-] (eq 13, aiding).

    u = R (1 - eta_I) / (R + eta_I). NaN where eta_I <= -R (no u reaches it).
    """
    eta = finite('eta', eta)
    ratio = positive('ratio', ratio)
    numerator, denominator = _u_i_terms(eta, ratio)
    return _where_valid(denominator > 0.0, numerator, denominator)


def readings(eta_d: float, eta_i: float, ratio: float) -> tuple[float, float]:
    """(u from eta_D, u from eta_I) [-] (eq 13 both ways), for Python floats.

    The per-update path of the diagnostics: the formulas of :func:`u_from_eta_opposing` and
    :func:`u_from_eta_aiding` without numpy's per-call cost. NaN where one is undefined or
    an efficiency is not finite. ModelError if an efficiency is not one real number or
    ``ratio`` is not finite and > 0.
    """
    if type(eta_d) is not float:
        real_scalar('eta_d', eta_d)
    if type(eta_i) is not float:
        real_scalar('eta_i', eta_i)
    if type(ratio) is not float or not 0.0 < ratio < math.inf:
        scalar_ratio(ratio)
    u_d = u_i = math.nan
    if math.isfinite(eta_d):
        numerator, denominator = _u_d_terms(eta_d, ratio)
        u_d = numerator / denominator if denominator > 0.0 else math.nan
    if math.isfinite(eta_i):
        numerator, denominator = _u_i_terms(eta_i, ratio)
        u_i = numerator / denominator if denominator > 0.0 else math.nan
    return u_d, u_i


def eta_aiding_from_opposing(eta_opposing: ArrayLike, ratio: ArrayLike) -> np.ndarray | float:
    """Aiding-load efficiency eta_I [-] implied by the opposing-load one eta_D [-] (eq 14).

    eta_I = (2 R eta_D + 1 - R) / ((R - 1) eta_D + 2), the corrected eq 14. Defined where
    eta_D has a pre-image u > -min(1, R); NaN elsewhere.
    """
    eta_d = finite('eta_opposing', eta_opposing)
    ratio = positive('ratio', ratio)
    u = u_from_eta_opposing(eta_d, ratio)
    denominator = (ratio - 1.0) * eta_d + 2.0
    valid = np.isfinite(u) & (u > -np.minimum(1.0, ratio)) & (denominator > 0.0)
    return _where_valid(valid, 2.0 * ratio * eta_d + 1.0 - ratio, denominator)


def eta_opposing_from_aiding(eta_aiding: ArrayLike, ratio: ArrayLike) -> np.ndarray | float:
    """Opposing-load efficiency eta_D [-] implied by the aiding-load one eta_I [-].

    eta_D = (2 eta_I + R - 1) / (2 R - (R - 1) eta_I), the inverse of eq 14. NaN outside the
    image of u > -min(1, R).
    """
    eta_i = finite('eta_aiding', eta_aiding)
    ratio = positive('ratio', ratio)
    u = u_from_eta_aiding(eta_i, ratio)
    denominator = 2.0 * ratio - (ratio - 1.0) * eta_i
    valid = np.isfinite(u) & (u > -np.minimum(1.0, ratio)) & (denominator > 0.0)
    return _where_valid(valid, 2.0 * eta_i + ratio - 1.0, denominator)


def _slope_terms(base: Any, ratio: Any) -> tuple[Any, Any]:
    """Return du/deta's numerator -R (R + 1) and denominator base^2 (floats or arrays).

    ``base``: eq 13's denominator, R eta_D + 1 or R + eta_I (aiding).
    """
    return -ratio * (ratio + 1.0), base ** 2     # ** as numpy's scalars: pow, not base * base


def d_u_d_eta_opposing(eta: ArrayLike, ratio: ArrayLike) -> np.ndarray | float:
    """Sensitivity du/deta_D [-] of eq 13: -R (R + 1) / (R eta_D + 1)^2 (variance propagation)."""
    eta = finite('eta', eta)
    ratio = positive('ratio', ratio)
    base = _u_d_terms(eta, ratio)[1]
    return _where_valid(base > 0.0, *_slope_terms(base, ratio))


def d_u_d_eta_aiding(eta: ArrayLike, ratio: ArrayLike) -> np.ndarray | float:
    """Sensitivity du/deta_I [-] of eq 13 (aiding): -R (R + 1) / (R + eta_I)^2."""
    eta = finite('eta', eta)
    ratio = positive('ratio', ratio)
    base = _u_i_terms(eta, ratio)[1]
    return _where_valid(base > 0.0, *_slope_terms(base, ratio))


def reading_with_slope(eta: float, ratio: float, aiding: bool) -> tuple[float, float]:
    """(u, du/deta) [-] of one efficiency [-] by eq 13, for Python floats.

    ``aiding`` False: eta is eta_D (:func:`u_from_eta_opposing`,
    :func:`d_u_d_eta_opposing`); True: eta_I (the aiding ones). The per-window path of the
    estimator, the same float operations without numpy's per-call cost. NaN where undefined;
    ModelError if ``eta`` is not finite (as those functions) or ``ratio`` not finite and > 0.
    """
    if type(eta) is not float:
        real_scalar('eta', eta)
    if type(ratio) is not float or not 0.0 < ratio < math.inf:
        scalar_ratio(ratio)
    if not math.isfinite(eta):
        msg = f'eta must be finite, got {eta!r}'
        raise ModelError(msg) from None
    numerator, base = (_u_i_terms if aiding else _u_d_terms)(eta, ratio)
    if not base > 0.0:
        return math.nan, math.nan
    slope_numerator, slope_denominator = _slope_terms(base, ratio)
    return numerator / base, slope_numerator / slope_denominator
