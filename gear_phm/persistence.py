"""Persisted wear state of a live node: a versioned JSON document, written atomically (no ROS).

Document::

    {"schema": 1, "kind": "estimator" | "diagnostics",
     "identity": {"ratio": 3.0, "motor_joint": "motor", ...},
     "saved_stamp_ns": <newest sample stamp [ns] in the state, or null>,
     "state": {...}}            # the classes' to_state() dicts

JSON has no inf/nan: :func:`encode_float` writes a non-finite float as the string 'inf',
'-inf' or 'nan' (finite floats are numbers, which round-trip exactly), :func:`decode_float`
reads both forms back.

:func:`save_state` writes it with :func:`gear_phm.staging.write_atomic`: a temporary file in
the same directory, flushed and fsynced, renamed over the target (``os.replace``, atomic on
POSIX), the directory fsynced, so a crash at any point leaves the old or the new file, never a
torn one.

:func:`load_state`: a missing file gives None (start fresh); an unreadable, unparseable,
wrong-schema or wrong-kind file is renamed ``<name>.bad-<UTC time>`` and raises
:class:`StateCorrupt` (start fresh, report the reason); a file written for another gearbox
(different ratio or joint names) raises :class:`StateMismatch` and is left in place, unless
``reset`` is set: then it is renamed ``<name>.old-<UTC time>`` and None is returned.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping
from datetime import datetime, timezone
import json
import math
import os
from pathlib import Path
from typing import Any

from gear_phm.errors import GearPhmError
from gear_phm.staging import write_atomic

#: Version of the document layout; a file with another version is set aside. 2: the filter
#: and the RUL history run on operating time, not on stamp time as in 1.
SCHEMA = 2
#: Relative tolerance of a float identity value (e.g. the ratio).
IDENTITY_RTOL = 1e-9


class StateError(GearPhmError):
    """A state file that cannot be used; ``str()`` is the reason."""


class StateCorrupt(StateError):
    """Unreadable, unparseable, or of another schema or kind; ``moved_to`` holds the file."""

    def __init__(self, reason: str, moved_to: Path | None) -> None:
        super().__init__(reason)
        self.moved_to = moved_to


class StateForeign(StateError):
    """The state file's path holds something else (a folder, another file): left as it is."""


class StateMismatch(StateError):
    """Written for another gearbox (identity differs); the file is left as it is."""


def encode_float(value: float) -> float | str:
    """Return a JSON-safe float: finite as is, else 'inf', '-inf' or 'nan'."""
    value = float(value)
    if math.isfinite(value):
        return value
    return 'nan' if math.isnan(value) else ('inf' if value > 0 else '-inf')


def decode_float(value: Any) -> float:
    """Inverse of :func:`encode_float` (a number or 'inf'/'-inf'/'nan'); ValueError else."""
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise ValueError(f'expected a number, got {value!r}')
    if isinstance(value, str) and value not in ('inf', '-inf', 'nan'):
        raise ValueError(f'expected a number, got {value!r}')
    return float(value)


def encode_floats(values: Iterable[float]) -> list[float | str]:
    """:func:`encode_float` of each value."""
    return [encode_float(v) for v in values]


def decode_floats(values: Iterable[Any]) -> list[float]:
    """:func:`decode_float` of each value."""
    return [decode_float(v) for v in values]


def _utc_tag(now: datetime | None = None) -> str:
    now = datetime.now(timezone.utc) if now is None else now
    return now.strftime('%Y%m%dT%H%M%S.%fZ')


def set_aside(path: Path, suffix: str) -> Path:
    """Rename ``path`` to ``<path>.<suffix>-<UTC time>`` (a free name); return the new path."""
    tag = _utc_tag()
    target = path.with_name(f'{path.name}.{suffix}-{tag}')
    n = 1
    while target.exists():
        target = path.with_name(f'{path.name}.{suffix}-{tag}-{n}')
        n += 1
    os.replace(path, target)
    return target


def document(kind: str, identity: Mapping[str, Any], state: Mapping[str, Any],
             saved_stamp_ns: int | None) -> dict[str, Any]:
    """Return the state document described in the module docstring."""
    return {'schema': SCHEMA, 'kind': kind, 'identity': dict(identity),
            'saved_stamp_ns': saved_stamp_ns, 'state': dict(state)}


def save_state(path: str | os.PathLike[str], kind: str, identity: Mapping[str, Any],
               state: Mapping[str, Any], saved_stamp_ns: int | None = None) -> None:
    """Write the document atomically (:func:`~gear_phm.staging.write_atomic`).

    OSError/ValueError on failure.
    """
    text = json.dumps(document(kind, identity, state, saved_stamp_ns), allow_nan=False,
                      separators=(',', ':'))
    write_atomic(Path(path), text)


def identity_difference(saved: Mapping[str, Any], current: Mapping[str, Any]) -> str:
    """'' if the identities agree, else which values differ (floats to IDENTITY_RTOL)."""
    problems = []
    for key in sorted(set(saved) | set(current)):
        a, b = saved.get(key), current.get(key)
        if isinstance(a, (int, float)) and isinstance(b, (int, float)) \
                and not isinstance(a, bool) and not isinstance(b, bool):
            same = math.isclose(float(a), float(b), rel_tol=IDENTITY_RTOL)
        else:
            same = a == b
        if not same:
            problems.append(f'{key} {a!r} in the file, {b!r} now')
    return ', '.join(problems)


def load_state(path: str | os.PathLike[str], kind: str, identity: Mapping[str, Any],
               reset: bool = False) -> dict[str, Any] | None:
    """Return the saved ``state`` dict, or None to start fresh (module docstring).

    Raises :class:`StateCorrupt` (a damaged state file, set aside), :class:`StateForeign`
    (the path holds a folder or a file that is no state file: left as it is; moving a user's
    file or folder aside would be worse than not starting) or :class:`StateMismatch` (file
    kept).
    """
    target = Path(path)
    keep = 'it is left as it is; choose another state_file, or move it away to start fresh'
    if target.exists() and not target.is_file():
        raise StateForeign(f'state file {target} is a folder or not a regular file: {keep}')
    try:
        text = target.read_text(encoding='utf-8')
    except FileNotFoundError:
        return None
    except (OSError, UnicodeDecodeError) as exc:
        reason = ' '.join(str(exc).split())
        raise StateForeign(f'state file {target} cannot be read as text ({reason}): '
                           f'{keep}') from None
    if text.strip() and not (text.lstrip().startswith('{') and '"schema"' in text[:256]):
        raise StateForeign(f'state file {target} is not a gear_phm state file (no JSON '
                           f'object with a schema): {keep}')
    try:
        doc = json.loads(text)
    except ValueError as exc:
        raise set_aside_corrupt(target, f'not JSON: {exc}')
    if not isinstance(doc, dict):
        raise set_aside_corrupt(target, 'not a JSON object')
    if doc.get('schema') != SCHEMA:
        raise set_aside_corrupt(target, f'schema {doc.get("schema")!r}, expected {SCHEMA}')
    if doc.get('kind') != kind:
        raise set_aside_corrupt(target, f'kind {doc.get("kind")!r}, expected {kind!r}')
    if not isinstance(doc.get('identity'), dict) or not isinstance(doc.get('state'), dict):
        raise set_aside_corrupt(target, 'identity or state missing')
    difference = identity_difference(doc['identity'], identity)
    if difference:
        if reset:
            set_aside(target, 'old')
            return None
        raise StateMismatch(f'state file {target} is for another gearbox ({difference}); '
                            f'set state_reset to true to start fresh (the file is kept aside)')
    state: dict[str, Any] = doc['state']
    return state


def set_aside_corrupt(target: Path, reason: str) -> StateCorrupt:
    """Rename a bad file ``<name>.bad-<UTC time>``; return the error to raise."""
    try:
        moved: Path | None = set_aside(target, 'bad')
    except OSError:
        moved = None
    where = f'kept as {moved}' if moved is not None else 'could not be moved aside'
    return StateCorrupt(f'state file {target} {reason}; starting fresh ({where})', moved)
