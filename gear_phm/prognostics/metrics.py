"""Saxena et al. prognostic metrics (pure numpy). Definitions with formulas: docs/prognostics.md.

Inputs everywhere: prediction times ``t`` [s] (increasing), predicted RUL ``rul`` [s] at those
times (median; inf allowed), true end of life ``t_eol`` [s], and the time ``t_start`` [s] at
which prognostics starts (default: the first prediction time). True RUL r*(t) = t_eol - t.
Lambda times: t_lambda = t_start + lambda (t_eol - t_start). The prediction used at t_lambda
is the latest one made at or before t_lambda.

Beyond Saxena's: how early the RUL is finite (:func:`finite_from`), how often its p5-p95 band
holds the true RUL (:func:`band_coverage`) and the health-level transitions of a run
(:func:`level_transitions`), the acceptance measures of docs/prognostics.md; and the
per-life acceptance scores of a random life (:func:`acceptance`,
:func:`healthy_acceptance`), with t_start its wear onset.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
import math
from typing import Any, overload

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.status import ERROR, LEVEL_NAMES, OK, WARN

LAMBDAS = (0.25, 0.5, 0.75)
#: Half-width of the accuracy cone around the true RUL, as a fraction of it (Saxena's alpha):
#: the default of ``gear-phm evaluate`` and the cone of ``analysis.png``.
ALPHA = 0.2
#: Fraction of the life from which :func:`band_coverage` counts predictions.
BAND_FROM = 0.25
#: The acceptance scoring of a life (:func:`acceptance`): alpha-lambda at these lambdas, ...
ACCEPTANCE_LAMBDAS = (0.5, 0.75, 0.9)
#: ... p5 at or below the true RUL from this fraction of the life on, ...
NOT_OPTIMISTIC_FROM = 0.5
#: ... and the RUL finite from this fraction of the life on [-].
FINITE_BY = 0.25


@dataclass(frozen=True)
class AlphaLambda:
    """Alpha-lambda check at one lambda: the prediction within (1 +/- alpha) r*(t_lambda)."""

    lam: float
    t_lambda: float
    true_rul: float
    predicted_rul: float
    lower: float
    upper: float
    passed: bool
    relative_accuracy: float


def _inputs(t: ArrayLike, rul: ArrayLike, t_eol: float,
            t_start: float | None) -> tuple[np.ndarray, np.ndarray, float, float]:
    times = np.asarray(t, dtype=float).ravel()
    values = np.asarray(rul, dtype=float).ravel()
    if times.shape != values.shape:
        raise ValueError(f't and rul must have the same length, got {times.size} and '
                         f'{values.size}')
    if times.size == 0:
        raise ValueError('t must hold at least one prediction, got none')
    if not np.isfinite(times).all() or np.any(np.diff(times) < 0.0):
        raise ValueError('t must be finite and non-decreasing')
    if np.isnan(values).any():
        raise ValueError(f'rul must not be NaN (index {int(np.argmax(np.isnan(values)))})')
    if not math.isfinite(t_eol):
        raise ValueError(f't_eol must be finite, got {t_eol!r}')
    start = float(times[0]) if t_start is None else float(t_start)
    if not start < t_eol:
        raise ValueError(f't_start must be < t_eol = {t_eol!r}, got {start!r}')
    return times, values, float(t_eol), start


def true_end_of_life_index(true_u: ArrayLike, u_eol: float) -> int | None:
    """Index of the true end of life: the first sample whose true u [-] is >= u_eol [-].

    None if no sample reaches it (or u_eol is not finite). The rule of ``gear-phm evaluate``'s
    truth bag and of the true end of life drawn in ``analysis.png``.
    """
    values = np.asarray(true_u, dtype=float).ravel()
    if not math.isfinite(u_eol):
        return None
    crossed = np.flatnonzero(values >= u_eol)
    return int(crossed[0]) if crossed.size else None


def relative_accuracy(true_rul: float, predicted_rul: float) -> float:
    """RA = 1 - |r* - r| / r* (1 is perfect; -inf for an infinite prediction)."""
    if true_rul <= 0.0:
        return math.nan
    if math.isinf(predicted_rul):
        return -math.inf
    return 1.0 - abs(true_rul - predicted_rul) / true_rul


def alpha_lambda(t: ArrayLike, rul: ArrayLike, t_eol: float, lam: float, alpha: float = ALPHA,
                 t_start: float | None = None) -> AlphaLambda:
    """Alpha-lambda accuracy at ``lam``: (1 - alpha) r* <= r(t_lambda) <= (1 + alpha) r*."""
    if not 0.0 <= lam < 1.0:
        raise ValueError(f'lam must be in [0, 1), got {lam!r}')
    if not alpha > 0.0:
        raise ValueError(f'alpha must be > 0, got {alpha!r}')
    times, values, t_eol, start = _inputs(t, rul, t_eol, t_start)
    t_lambda = start + lam * (t_eol - start)
    true = t_eol - t_lambda
    lower, upper = (1.0 - alpha) * true, (1.0 + alpha) * true
    index = int(np.searchsorted(times, t_lambda, side='right')) - 1
    if index < 0:
        return AlphaLambda(lam, t_lambda, true, math.nan, lower, upper, False, math.nan)
    predicted = float(values[index])
    return AlphaLambda(lam, t_lambda, true, predicted, lower, upper,
                       bool(lower <= predicted <= upper), relative_accuracy(true, predicted))


def prognostic_horizon(t: ArrayLike, rul: ArrayLike, t_eol: float, alpha: float = ALPHA,
                       t_start: float | None = None) -> float:
    """Prognostic horizon PH [s] = t_eol - t_i.

    t_i is the first prediction time from which every prediction up to t_eol stays within
    r*(t) +/- alpha (t_eol - t_start). 0 if the last one is outside.
    """
    times, values, t_eol, start = _inputs(t, rul, t_eol, t_start)
    keep = (times >= start) & (times < t_eol)
    times, values = times[keep], values[keep]
    if times.size == 0:
        return 0.0
    half_width = alpha * (t_eol - start)
    inside = np.abs(values - (t_eol - times)) <= half_width
    if not inside[-1]:
        return 0.0
    outside = np.flatnonzero(~inside)
    first = 0 if outside.size == 0 else int(outside[-1]) + 1
    return float(t_eol - times[first])


def cumulative_relative_accuracy(t: ArrayLike, rul: ArrayLike, t_eol: float,
                                 t_start: float | None = None) -> float:
    """Mean RA over the predictions made in [t_start, t_eol) (NaN if none)."""
    times, values, t_eol, start = _inputs(t, rul, t_eol, t_start)
    keep = (times >= start) & (times < t_eol)
    scores = [relative_accuracy(t_eol - ti, ri) for ti, ri in zip(times[keep], values[keep])]
    return float(np.mean(scores)) if scores else math.nan


def evaluate(t: ArrayLike, rul: ArrayLike, t_eol: float, alpha: float = ALPHA,
             lambdas: Sequence[float] = LAMBDAS, t_start: float | None = None) -> dict[str, Any]:
    """All metrics as a JSON-ready dict (non-finite numbers as the strings 'inf'/'-inf'/'nan')."""
    times, values, t_eol, start = _inputs(t, rul, t_eol, t_start)
    checks = [alpha_lambda(times, values, t_eol, lam, alpha, start) for lam in lambdas]
    result = {
        'alpha': alpha,
        't_start_s': start,
        't_eol_s': t_eol,
        'predictions': int(times.size),
        'alpha_lambda': [asdict(check) for check in checks],
        'prognostic_horizon_s': prognostic_horizon(times, values, t_eol, alpha, start),
        'relative_accuracy': {str(check.lam): check.relative_accuracy for check in checks},
        'cumulative_relative_accuracy': cumulative_relative_accuracy(times, values, t_eol,
                                                                     start),
    }
    return _json_ready(result)


def finite_from(t: ArrayLike, rul: ArrayLike, t_eol: float,
                t_start: float | None = None) -> float:
    """Fraction of the life [-] from which every prediction before ``t_eol`` is finite.

    (t_f - t_start) / (t_eol - t_start), t_f the time of the first prediction after the last
    infinite one (0 if none in [t_start, t_eol) is infinite; inf if the last one is).
    """
    times, values, t_eol, start = _inputs(t, rul, t_eol, t_start)
    keep = (times >= start) & (times < t_eol)
    times, values = times[keep], values[keep]
    infinite = np.flatnonzero(~np.isfinite(values))
    if infinite.size == 0:
        return 0.0
    if infinite[-1] == times.size - 1:
        return math.inf
    return float((times[infinite[-1] + 1] - start) / (t_eol - start))


def band_coverage(t: ArrayLike, p5: ArrayLike, p95: ArrayLike, t_eol: float,
                  lam: float = BAND_FROM, t_start: float | None = None) -> tuple[float, int]:
    """Share [-] of the predictions in [t_lambda, t_eol) whose [p5, p95] holds r*(t).

    Returns (share, number of those predictions); (NaN, 0) if there are none.
    """
    held, counted = _held(t, p5, p95, t_eol, lam, t_start)
    return (held / counted if counted else math.nan), counted


def not_optimistic(t: ArrayLike, p5: ArrayLike, t_eol: float, lam: float = NOT_OPTIMISTIC_FROM,
                   t_start: float | None = None) -> tuple[int, int]:
    """(How many, of how many) predictions in [t_lambda, t_eol) have p5 <= r*(t)."""
    lower = np.asarray(p5, dtype=float).ravel()
    return _held(t, lower, np.full(lower.shape, math.inf), t_eol, lam, t_start)


def _held(t: ArrayLike, p5: ArrayLike, p95: ArrayLike, t_eol: float, lam: float,
          t_start: float | None) -> tuple[int, int]:
    """(Held, counted): predictions in [t_lambda, t_eol) and those whose [p5, p95] holds r*."""
    if not 0.0 <= lam < 1.0:
        raise ValueError(f'lam must be in [0, 1), got {lam!r}')
    times, lower, t_eol, start = _inputs(t, p5, t_eol, t_start)
    upper = np.asarray(p95, dtype=float).ravel()
    if upper.shape != times.shape or np.isnan(upper).any():
        raise ValueError('p95 must have one value, not NaN, per prediction time')
    keep = (times >= start + lam * (t_eol - start)) & (times < t_eol)
    true = t_eol - times[keep]
    held = (lower[keep] <= true) & (true <= upper[keep])
    return int(held.sum()), int(keep.sum())


@dataclass(frozen=True)
class Transition:
    """A change of health level at time ``t`` [s]; ``lam`` = (t - t_start) / (t_eol - t_start)."""

    t: float
    lam: float
    before: int
    after: int


def level_transitions(t: ArrayLike, levels: ArrayLike, t_eol: float,
                      t_start: float | None = None) -> tuple[Transition, ...]:
    """Every change of the level (0 OK, 1 WARN, 2 ERROR, 3 STALE) from one state to the next.

    All states count, before and after ``t_eol``; ``t_start`` only sets lambda.
    """
    times = np.asarray(t, dtype=float).ravel()
    codes = np.asarray(levels, dtype=float).ravel()
    if times.shape != codes.shape or times.size == 0:
        raise ValueError('t and levels must have the same, non-zero length')
    if not np.isfinite(codes).all() or np.any(np.diff(times) < 0.0):
        raise ValueError('levels must be finite and t non-decreasing')
    start = float(times[0]) if t_start is None else float(t_start)
    if not start < t_eol:
        raise ValueError(f't_start must be < t_eol = {t_eol!r}, got {start!r}')
    changed = np.flatnonzero(codes[1:] != codes[:-1]) + 1
    return tuple(Transition(float(times[i]), float((times[i] - start) / (t_eol - start)),
                            int(codes[i - 1]), int(codes[i])) for i in changed)


def level_check(t: ArrayLike, levels: ArrayLike, t_eol: float, onset: float,
                t_start: float | None = None) -> dict[str, Any]:
    """Return the acceptance check of a wear life's levels, JSON-ready.

    ``sequence``: the transitions as 'FROM>TO' level names; ``passed`` when they are
    exactly OK -> WARN then WARN -> ERROR, no state before ``onset`` [s] is WARN or ERROR and
    none before ``t_eol`` [s] is ERROR.
    """
    times = np.asarray(t, dtype=float).ravel()
    codes = np.asarray(levels, dtype=float).ravel()
    changes = level_transitions(times, codes, t_eol, t_start)
    sequence = [(c.before, c.after) for c in changes]
    warn_early = bool(np.any(np.isin(codes, (WARN, ERROR)) & (times < onset)))
    error_early = bool(np.any((codes == ERROR) & (times < t_eol)))
    first_ok = codes.size > 0 and int(codes[0]) == OK
    return {'sequence': [f'{_name(a)}>{_name(b)}' for a, b in sequence],
            'ok_to_warn': sequence.count((OK, WARN)),
            'warn_to_error': sequence.count((WARN, ERROR)),
            'warn_before_onset': warn_early, 'error_before_eol': error_early,
            'passed': bool(first_ok and sequence == [(OK, WARN), (WARN, ERROR)]
                           and not warn_early and not error_early)}


def acceptance(t: ArrayLike, median: ArrayLike, p5: ArrayLike, p95: ArrayLike, t_eol: float,
               t_start: float, levels: tuple[ArrayLike, ArrayLike] | None = None,
               alpha: float = ALPHA) -> dict[str, Any]:
    """Score one wear life for acceptance from t_start = its onset [s], JSON-ready.

    ``t``, ``median``, ``p5``, ``p95``: every prediction (after t_eol too: ignored);
    ``levels``: (stamps [s], level codes) of the health states, None without them.
    alpha-lambda at :data:`ACCEPTANCE_LAMBDAS`, band coverage from :data:`BAND_FROM` and p5 at
    or below the true RUL from :data:`NOT_OPTIMISTIC_FROM` as (held, predictions) counts, RUL
    finite from :data:`FINITE_BY`, and :func:`level_check`. Raises ValueError on bad inputs.
    """
    times = np.asarray(t, dtype=float).ravel()
    values = np.asarray(median, dtype=float).ravel()
    before = times < t_eol
    if not before.any():
        raise ValueError(f'no prediction before t_eol = {t_eol!r}')
    checks = [alpha_lambda(times[before], values[before], t_eol, lam, alpha, t_start)
              for lam in ACCEPTANCE_LAMBDAS]
    held, counted = _held(times, p5, p95, t_eol, BAND_FROM, t_start)
    below, total = not_optimistic(times, p5, t_eol, NOT_OPTIMISTIC_FROM, t_start)
    finite = finite_from(times[before], values[before], t_eol, t_start)
    result: dict[str, object] = {
        't_start_s': t_start,
        'alpha_lambda': [asdict(check) for check in checks],
        'band': {'from_lambda': BAND_FROM, 'held': held, 'predictions': counted},
        'not_optimistic': {'from_lambda': NOT_OPTIMISTIC_FROM, 'held': below,
                           'predictions': total},
        'finite': {'by_lambda': FINITE_BY, 'finite_from': finite,
                   'passed': finite <= FINITE_BY},
    }
    if levels is not None:
        result['levels'] = level_check(*levels, t_eol, t_start, t_start)
    return _json_ready(result)


def healthy_acceptance(median: ArrayLike, levels: ArrayLike | None = None) -> dict[str, Any]:
    """Score a healthy life for acceptance: every RUL inf and every level OK, JSON-ready."""
    values = np.asarray(median, dtype=float).ravel()
    finite = int(np.isfinite(values).sum())
    codes = [] if levels is None else sorted({int(c) for c in np.asarray(levels).ravel()})
    return {'predictions': int(values.size), 'finite': finite,
            'finite_share': finite / values.size if values.size else 0.0,
            'levels_seen': [_name(code) for code in codes],
            'passed': bool(values.size and finite == 0 and codes in ([], [OK]))}


def _name(level: int) -> str:
    return LEVEL_NAMES.get(level, str(level))


@overload
def _json_ready(value: dict[str, Any]) -> dict[str, Any]: ...


@overload
def _json_ready(value: object) -> object: ...


def _json_ready(value: object) -> object:
    if isinstance(value, dict):
        return {k: _json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return 'nan' if math.isnan(value) else ('inf' if value > 0 else '-inf')
    return value
