"""State files: what a node or an offline run needs to continue a transmission's life.

A state file is one UTF-8 JSON object::

    {"format": "gear_phm.state", "schema": 1, "kind": "estimator",
     "identity": {"ratio": 30.0, "motor_joint": "motor", "load_joint": "load"},
     "state": {...}}

``kind`` says whose state it is (``estimator`` or ``health``), ``identity`` the facts that
must not change between runs of the same transmission (the ratio and the joint names), and
``state`` the payload that the owner exports and restores. Nothing here knows the payload.

Writes are atomic: the text goes to ``<path>.tmp`` in the same directory, is fsync'd, then
``os.replace``d over ``path``, and the directory is fsync'd; a crash leaves the old or the
new complete file. :func:`load_state` never raises on a bad file: a missing file starts fresh
quietly; a corrupt one, or one of another schema or kind, is moved aside to
``<path>.bad-<n>`` (kept, never overwritten) and reported, so the caller starts fresh and says
why. A file of another identity is refused (:class:`StateMismatch`) unless the caller asks to
reset, since continuing another gearbox's wear would be silently wrong.
"""
from __future__ import annotations

from dataclasses import dataclass
import json
import math
import os
from pathlib import Path
from typing import Any

FORMAT = 'gear_phm.state'
SCHEMA = 1


class StateMismatch(ValueError):
    """The state file belongs to another transmission (ratio or joint names differ)."""


@dataclass(frozen=True)
class Loaded:
    """Result of :func:`load_state`: the payload (None: start fresh) and what happened.

    ``problem`` is '' for a good or a missing file, else a one-line reason (the file was
    moved to ``kept_as``).
    """

    state: dict[str, Any] | None
    problem: str = ''
    kept_as: Path | None = None


def save_state(path: str | Path, kind: str, identity: dict[str, Any],
               state: dict[str, Any]) -> None:
    """Write the state atomically (ValueError if it holds non-finite numbers or non-JSON)."""
    path = Path(path)
    text = json.dumps({'format': FORMAT, 'schema': SCHEMA, 'kind': kind,
                       'identity': identity, 'state': state}, allow_nan=False,
                      separators=(',', ':'))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + '.tmp')
    with open(tmp, 'w', encoding='utf-8') as stream:
        stream.write(text)
        stream.flush()
        os.fsync(stream.fileno())
    os.replace(tmp, path)
    try:
        fd = os.open(path.parent, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _keep_aside(path: Path) -> Path:
    for n in range(1, 10_000):
        target = path.with_name(f'{path.name}.bad-{n}')
        if not target.exists():
            os.replace(path, target)
            return target
    raise OSError(f'too many kept-aside state files next to {path}')


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float) or isinstance(b, float):
        try:
            return math.isclose(float(a), float(b), rel_tol=1e-9)
        except (TypeError, ValueError):
            return False
    return bool(a == b)


def load_state(path: str | Path, kind: str, identity: dict[str, Any],
               reset: bool = False) -> Loaded:
    """Read a state file written by :func:`save_state` for ``kind`` and ``identity``.

    Missing: ``Loaded(None)``. Unreadable, not JSON, another format, schema or kind: moved
    aside, ``Loaded(None, reason, kept_as)``. Another identity: :class:`StateMismatch`
    naming both, unless ``reset``, in which case it is moved aside too.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding='utf-8')
    except FileNotFoundError:
        return Loaded(None)
    except (OSError, UnicodeDecodeError) as exc:
        problem = f'state file {path} unreadable ({" ".join(str(exc).split())})'
        return Loaded(None, problem, _keep_aside(path))
    problem = ''
    data: Any = None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        problem = f'state file {path} is not valid JSON ({exc.msg} at {exc.pos}): truncated?'
    if not problem:
        if not isinstance(data, dict) or data.get('format') != FORMAT:
            problem = f'state file {path} is not a {FORMAT} file'
        elif data.get('schema') != SCHEMA:
            problem = (f'state file {path} has schema {data.get("schema")!r}; this gear_phm '
                       f'reads schema {SCHEMA}')
        elif data.get('kind') != kind:
            problem = f'state file {path} holds {data.get("kind")!r} state, not {kind!r}'
        elif not isinstance(data.get('state'), dict) \
                or not isinstance(data.get('identity'), dict):
            problem = f'state file {path} lacks its state or identity'
    if problem:
        return Loaded(None, problem, _keep_aside(path))
    saved = data['identity']
    differ = [f'{key} {saved.get(key)!r} (file) != {value!r}' for key, value in identity.items()
              if not _same(saved.get(key), value)]
    if differ:
        if not reset:
            raise StateMismatch(f'state file {path} is for another transmission: '
                                f'{"; ".join(differ)}; set the same values, or reset the '
                                f'state to start this transmission afresh')
        kept = _keep_aside(path)
        return Loaded(None, f'state reset on request ({"; ".join(differ)})', kept)
    return Loaded(data['state'])
