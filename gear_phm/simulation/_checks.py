"""Scalar argument checks of the simulation configs: ValueError naming the field and value."""
from __future__ import annotations

import math


def real(name: str, value: object) -> float:
    """``value`` as a finite float, else ValueError naming ``name``."""
    if isinstance(value, bool):
        raise ValueError(f'{name} must be a real number, got {value!r}')
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise ValueError(f'{name} must be a real number, got {value!r}') from exc
    if not math.isfinite(number):
        raise ValueError(f'{name} must be finite, got {value!r}')
    return number


def positive(name: str, value: object) -> float:
    """Finite and > 0."""
    number = real(name, value)
    if number <= 0.0:
        raise ValueError(f'{name} must be > 0, got {value!r}')
    return number


def non_negative(name: str, value: object) -> float:
    """Finite and >= 0."""
    number = real(name, value)
    if number < 0.0:
        raise ValueError(f'{name} must be >= 0, got {value!r}')
    return number


def one_of(name: str, value: object, choices: tuple[str, ...]) -> str:
    """One of the strings ``choices``."""
    if value not in choices:
        raise ValueError(f'{name} must be one of {", ".join(choices)}; got {value!r}')
    return str(value)
