"""Typed fields of JSON records: the values records write, and their checked reading back.

The result records (:class:`~gear_phm.estimation.summary.EstimatorSummary`,
:mod:`gear_phm.offline.summary`) write themselves as :data:`JsonValue` and read a parsed
document back through these readers, which raise :class:`RecordError` naming the field of a
value of the wrong type.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Union

import numpy as np

from gear_phm.errors import GearPhmError

#: A value ``json.dumps`` writes (NaN and infinities as ``NaN`` and ``Infinity``).
JsonValue = Union[None, bool, int, float, str, Sequence['JsonValue'],
                  Mapping[str, 'JsonValue']]
#: A JSON object: a record's ``to_dict()``.
JsonObject = dict[str, JsonValue]


class RecordError(GearPhmError, ValueError):
    """A JSON document that is not the record it should be (a field missing or mistyped)."""


def field(values: Mapping[str, object], key: str) -> object:
    """Return ``values[key]``; RecordError if it is missing."""
    if key not in values:
        msg = f'field {key!r} is missing'
        raise RecordError(msg) from None
    return values[key]


def _wrong(key: str, kind: str, value: object) -> RecordError:
    return RecordError(f'field {key!r}: expected {kind}, got {value!r}')


def number(values: Mapping[str, object], key: str) -> float:
    """Return the number ``values[key]`` as it is, an int or a float (RecordError if neither).

    An int stays an int, so that the record writes back what it read.
    """
    value = field(values, key)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _wrong(key, 'a number', value) from None
    return value


def integer(values: Mapping[str, object], key: str) -> int:
    """Return the integer ``values[key]`` (RecordError if it is not an integer)."""
    value = field(values, key)
    if isinstance(value, bool) or not isinstance(value, int):
        raise _wrong(key, 'an integer', value) from None
    return value


def text(values: Mapping[str, object], key: str) -> str:
    """Return the string ``values[key]`` (RecordError if it is not a string)."""
    value = field(values, key)
    if not isinstance(value, str):
        raise _wrong(key, 'a string', value) from None
    return value


def flag(values: Mapping[str, object], key: str) -> bool:
    """Return the boolean ``values[key]`` (RecordError if it is not a boolean)."""
    value = field(values, key)
    if not isinstance(value, bool):
        raise _wrong(key, 'true or false', value) from None
    return value


def obj(values: Mapping[str, object], key: str) -> Mapping[str, object]:
    """Return the JSON object ``values[key]`` (RecordError if it is not one)."""
    value = field(values, key)
    if not isinstance(value, Mapping) or not all(isinstance(k, str) for k in value):
        raise _wrong(key, 'an object', value) from None
    return value


def counts(values: Mapping[str, object], key: str) -> dict[str, int]:
    """Return the object of integers ``values[key]``, in its order."""
    found = obj(values, key)
    return {name: integer(found, name) for name in found}


def texts(values: Mapping[str, object], key: str) -> dict[str, str]:
    """Return the object of strings ``values[key]``, in its order."""
    found = obj(values, key)
    return {name: text(found, name) for name in found}


def scalar(values: Mapping[str, object], key: str) -> JsonValue:
    """Return the JSON scalar ``values[key]`` (a numpy scalar as its Python value).

    Raises RecordError for any other value.
    """
    value = field(values, key)
    if isinstance(value, np.generic):
        value = value.item()
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    raise _wrong(key, 'a number, a string, true, false or null', value) from None


def one_or_many(values: Mapping[str, object], key: str) -> tuple[str, ...]:
    """Return a string ``values[key]`` as one, or a list of strings as they are."""
    value = field(values, key)
    if isinstance(value, str):
        return (value,)
    if isinstance(value, list) and value and all(isinstance(v, str) for v in value):
        return tuple(value)
    raise _wrong(key, 'a string or a list of strings', value) from None


def one_or_list(items: Sequence[str]) -> JsonValue:
    """Return one item as itself, several as a list (as :func:`one_or_many` reads them)."""
    return items[0] if len(items) == 1 else list(items)
