"""Wear-state persistence: the estimator's posterior saved to JSON so a restart resumes.

File format (UTF-8 JSON object)::

    {"format": "gear_phm.wear_state", "version": 1, "t": <s>, "u": <->, "rate": <1/s>,
     "covariance": [[P_uu, P_ur], [P_ur, P_rr]], "ratio": <->}

Writes are atomic: the text goes to ``<path>.tmp`` in the same directory, is fsync'd, then
``os.replace``d over ``path`` and the directory is fsync'd, so a crash leaves either the old or
the new complete file. Loading validates every field; a missing, unreadable, corrupt or
inconsistent file gives ``(None, reason)`` -- the caller logs the reason and starts fresh.
"""
from __future__ import annotations

from dataclasses import dataclass
import json
import math
import os
from pathlib import Path

import numpy as np

FORMAT = 'gear_phm.wear_state'
VERSION = 1


@dataclass(frozen=True)
class WearState:
    """Posterior of the friction filter at time t [s]: u [-], rate du/dt [1/s], 2x2 P."""

    t: float
    u: float
    rate: float
    covariance: tuple[tuple[float, float], tuple[float, float]]
    ratio: float
    version: int = VERSION

    def __post_init__(self) -> None:
        problem = _state_problem(self)
        if problem:
            raise ValueError(problem)

    @property
    def x(self) -> np.ndarray:
        """State vector [u, du/dt]."""
        return np.array([self.u, self.rate])

    @property
    def P(self) -> np.ndarray:  # noqa: N802 (Kalman naming)
        """Covariance 2x2."""
        return np.array(self.covariance, dtype=float)

    @classmethod
    def from_posterior(cls, t: float, x: np.ndarray, covariance: np.ndarray,
                       ratio: float) -> WearState:
        """From a filter posterior x = [u, du/dt] and P (2x2)."""
        p = np.asarray(covariance, dtype=float).reshape(2, 2)
        return cls(float(t), float(x[0]), float(x[1]),
                   ((float(p[0, 0]), float(p[0, 1])), (float(p[1, 0]), float(p[1, 1]))),
                   float(ratio))

    def to_json(self) -> str:
        return json.dumps({'format': FORMAT, 'version': self.version, 't': self.t,
                           'u': self.u, 'rate': self.rate,
                           'covariance': [list(row) for row in self.covariance],
                           'ratio': self.ratio}, indent=1)


def _state_problem(state: WearState) -> str:
    for name in ('t', 'u', 'rate', 'ratio'):
        value = getattr(state, name)
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not math.isfinite(value):
            return f'{name} must be a finite number, got {value!r}'
    if state.version != VERSION:
        return f'version must be {VERSION}, got {state.version!r}'
    if state.ratio <= 0.0:
        return f'ratio must be > 0, got {state.ratio!r}'
    try:
        p = np.array(state.covariance, dtype=float)
    except (TypeError, ValueError):
        return f'covariance must be a 2x2 array of numbers, got {state.covariance!r}'
    if p.shape != (2, 2) or not np.isfinite(p).all():
        return f'covariance must be a finite 2x2 array, got {state.covariance!r}'
    scale = max(float(np.abs(p).max()), 1e-300)
    if abs(p[0, 1] - p[1, 0]) > 1e-9 * scale:
        return f'covariance must be symmetric, got {state.covariance!r}'
    if p[0, 0] <= 0.0 or p[1, 1] <= 0.0 or np.linalg.eigvalsh(p).min() < -1e-12 * scale:
        return f'covariance must be positive definite, got {state.covariance!r}'
    return ''


def save_wear_state(path: str | Path, state: WearState) -> None:
    """Write ``state`` to ``path`` atomically (tmp + fsync + os.replace + directory fsync)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + '.tmp')
    with open(tmp, 'w', encoding='utf-8') as stream:
        stream.write(state.to_json())
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


def load_wear_state(path: str | Path, ratio: float | None = None
                    ) -> tuple[WearState | None, str]:
    """Read a saved state: ``(state, '')`` or ``(None, reason)``; never raises on bad files.

    ``ratio``: if given, a state saved for another gearbox ratio is refused.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding='utf-8')
    except FileNotFoundError:
        return None, f'state file {path} does not exist'
    except (OSError, UnicodeDecodeError) as exc:
        return None, f'state file {path} unreadable: {exc}'
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        return None, f'state file {path} is not valid JSON: {exc}'
    if not isinstance(data, dict) or data.get('format') != FORMAT:
        return None, f'state file {path} is not a {FORMAT} file'
    try:
        cov = data['covariance']
        state = WearState(t=data['t'], u=data['u'], rate=data['rate'],
                          covariance=(tuple(cov[0]), tuple(cov[1])), ratio=data['ratio'],
                          version=data['version'])
    except KeyError as exc:
        return None, f'state file {path} lacks field {exc.args[0]!r}'
    except (TypeError, ValueError, IndexError) as exc:
        return None, f'state file {path} invalid: {exc}'
    if ratio is not None and not math.isclose(state.ratio, ratio, rel_tol=1e-9):
        return None, f'state file {path} is for ratio {state.ratio!r}, not {ratio!r}'
    return state, ''


class WearStateSaver:
    """Saves a state at most every ``period`` [s] of the caller's time (time passed in)."""

    def __init__(self, path: str | Path, period: float) -> None:
        if not period > 0.0:
            raise ValueError(f'period must be > 0 s, got {period!r}')
        self.path = Path(path)
        self.period = float(period)
        self._last: float | None = None

    def maybe_save(self, now: float, state: WearState) -> bool:
        """Save if ``period`` elapsed since the last save (or never saved); True if saved."""
        if self._last is not None and 0.0 <= now - self._last < self.period:
            return False
        save_wear_state(self.path, state)
        self._last = now
        return True
