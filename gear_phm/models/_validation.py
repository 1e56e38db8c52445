"""Argument checks shared by the models: ModelError that names the argument and the value."""
from __future__ import annotations

import math
import numbers

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.errors import GearPhmError


class ModelError(GearPhmError, ValueError):
    """An argument outside a model function's domain, named with its value: one line."""


def _first_bad(values: np.ndarray, bad: np.ndarray) -> str:
    """Describe the first offending element of ``values`` (scalar or array)."""
    if values.ndim == 0:
        return repr(float(values))
    index = tuple(int(i) for i in np.argwhere(bad)[0])
    count = int(np.count_nonzero(bad))
    return f'{float(values[index])!r} at index {index} ({count} bad element(s))'


def finite(name: str, value: ArrayLike) -> np.ndarray:
    """Return ``value`` as a float array; raise ModelError if any element is NaN or infinite."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ModelError(f'{name} must be a real number or array, got {value!r}') from exc
    bad = ~np.isfinite(array)
    if bad.any():
        raise ModelError(f'{name} must be finite, got {_first_bad(array, bad)}')
    return array


def positive(name: str, value: ArrayLike) -> np.ndarray:
    """Finite and strictly greater than zero."""
    array = finite(name, value)
    bad = array <= 0.0
    if bad.any():
        raise ModelError(f'{name} must be > 0, got {_first_bad(array, bad)}')
    return array


def non_negative(name: str, value: ArrayLike) -> np.ndarray:
    """Finite and greater than or equal to zero."""
    array = finite(name, value)
    bad = array < 0.0
    if bad.any():
        raise ModelError(f'{name} must be >= 0, got {_first_bad(array, bad)}')
    return array


def in_open_interval(name: str, value: ArrayLike, low: float, high: float,
                     unit: str = '') -> np.ndarray:
    """Finite and strictly inside (low, high)."""
    array = finite(name, value)
    bad = (array <= low) | (array >= high)
    if bad.any():
        raise ModelError(
            f'{name} must be in ({low:g}, {high:g}){unit}, got {_first_bad(array, bad)}')
    return array


def at_least(name: str, value: ArrayLike, minimum: ArrayLike, why: str) -> np.ndarray:
    """Finite and >= ``minimum`` (broadcast); ``why`` explains the bound in the message."""
    array = finite(name, value)
    bound = np.broadcast_to(np.asarray(minimum, dtype=float), np.broadcast(array, minimum).shape)
    full = np.broadcast_to(array, bound.shape)
    bad = full < bound
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0]) if bad.ndim else ()
        raise ModelError(
            f'{name} must be >= {float(bound[index]):.4g} ({why}), '
            f'got {_first_bad(full, bad)}')
    return array


def real_scalar(name: str, value: object) -> None:
    """Raise ModelError unless ``value`` is one real number (a Python or numpy scalar)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        msg = (f'{name} must be a real number (one value; the numpy functions take arrays), '
               f'got {value!r:.60}')
        raise ModelError(msg) from None


def scalar_ratio(ratio: float) -> None:
    """Raise ModelError unless ``ratio`` is one finite real number > 0."""
    real_scalar('ratio', ratio)
    if not 0.0 < ratio < math.inf:
        msg = f'ratio must be > 0 and finite, got {ratio!r}'
        raise ModelError(msg) from None


def in_half_open_interval(name: str, value: ArrayLike, low: float, high: float,
                          unit: str = '') -> np.ndarray:
    """Finite and inside [low, high)."""
    array = finite(name, value)
    bad = (array < low) | (array >= high)
    if bad.any():
        raise ModelError(
            f'{name} must be in [{low:g}, {high:g}){unit}, got {_first_bad(array, bad)}')
    return array


def result(value: ArrayLike) -> np.ndarray | float:
    """Return a Python float for a 0-d result, the array otherwise (the models' return type)."""
    array = np.asarray(value, dtype=float)
    return float(array) if array.ndim == 0 else array


def unwrap(value: np.ndarray) -> np.ndarray | float:
    """Return the value a model stores in a field: a 0-d array as its numpy scalar."""
    stored: np.ndarray | float = value[()] if value.ndim == 0 else value
    return stored
