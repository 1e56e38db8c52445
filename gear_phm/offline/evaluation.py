"""Scoring a run's RUL predictions against the ground truth (what ``gear-phm evaluate`` runs).

Predictions: ``gear_phm/health/rul`` (x = median RUL [s], y, z = its p5 and p95, stamped with
the time of the estimate) in a rosbag2 directory -- a diagnostics recording or an
``analyze`` output (the directory itself or a bag directly inside it, :func:`find_bag`). The
truth: :mod:`gear_phm.offline.truth`. A truth bag whose stamps do not overlap the run's is
refused; a partial overlap, or a run that ends before the last lambda of the life, gives a
warning. :func:`evaluate_run` scores with the Saxena metrics of
:mod:`gear_phm.prognostics.metrics`, from which fraction of the life the RUL stays finite, how
often the p5-p95 band holds the true RUL, the health-level transitions when the run has
``gear_phm/health/efficiency``, and, given the random life's record, its per-life scores
(``acceptance``); a healthy life is scored on whether it stays OK with RUL inf.
Definitions: docs/prognostics.md.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
import math
from pathlib import Path
from typing import Any

import numpy as np

from gear_phm.bagio import BagError
from gear_phm.bagio.series import bag_span, has_topic, read_vector_topic
from gear_phm.errors import GearPhmError
from gear_phm.interfaces import field_index, HEALTH_EFFICIENCY, HEALTH_LAYOUT, HEALTH_RUL
from gear_phm.offline.truth import LIFE_HEALTH, LifeRecord, topic_of, truth_eol_and_span
from gear_phm.parameters import RATIO
from gear_phm.prognostics import end_of_life_u, HealthConfig
from gear_phm.prognostics.metrics import (acceptance, band_coverage, evaluate, finite_from,
                                          healthy_acceptance, level_transitions)
from gear_phm.status import ERROR, LEVEL_NAMES


class EvaluationError(GearPhmError, ValueError):
    """A run that cannot be scored against its truth: one line, for the user."""


@dataclass(frozen=True)
class Predictions:
    """A run's RUL predictions: stamps [s], the median RUL and its p5 and p95 [s]."""

    times: np.ndarray
    median: np.ndarray
    p5: np.ndarray
    p95: np.ndarray

    @property
    def span(self) -> tuple[float, float]:
        """Return the first and last prediction's stamp [s]."""
        return float(self.times[0]), float(self.times[-1])


@dataclass(frozen=True)
class Evaluation:
    """The scores of one run: the metrics (JSON-ready), the warnings, u_eol [-], t_eol [s].

    ``t_eol`` is NaN for a healthy life, which has no end of life (``metrics['healthy']``).
    """

    metrics: dict[str, Any]
    warnings: tuple[str, ...]
    u_eol: float
    t_eol: float


def find_bag(run: Path, drive: str | None = None) -> Path:
    """Return the bag of ``run`` with the RUL topic (``drive``'s own for one of many).

    ``run`` is that bag or a directory holding it. Raises EvaluationError if there is none.
    """
    if not run.exists():
        msg = f'{run} does not exist'
        raise EvaluationError(msg) from None
    topic = topic_of(HEALTH_RUL, drive)
    candidates = [run] + (sorted(p.parent for p in run.glob('*/metadata.yaml'))
                          if run.is_dir() else [])
    for candidate in candidates:
        try:
            if has_topic(candidate, topic):
                return candidate
        except BagError:
            continue
    msg = f'no bag with topic {topic} in {run}'
    raise EvaluationError(msg) from None


def read_predictions(bag: Path, drive: str | None = None) -> Predictions:
    """Return the RUL predictions of ``bag`` (BagError if it cannot be read or has none)."""
    times, values = read_vector_topic(bag, topic_of(HEALTH_RUL, drive))
    median, p5, p95 = (values[:, field_index(HEALTH_LAYOUT, HEALTH_RUL, f'rul.{name}')]
                       for name in ('median', 'p5', 'p95'))
    return Predictions(times, median, p5, p95)


def read_levels(bag: Path, drive: str | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """Return (stamps [s], levels) of the run's health states, or None without that topic."""
    topic = topic_of(HEALTH_EFFICIENCY, drive)
    if not has_topic(bag, topic):
        return None
    times, vectors = read_vector_topic(bag, topic)
    return times, vectors[:, field_index(HEALTH_LAYOUT, HEALTH_EFFICIENCY, 'level')]


def health_config(values: Mapping[str, Any], ratio: float | None,
                  life: LifeRecord | None) -> HealthConfig:
    """Return the health parameters: ``values``, then the life's, then the defaults.

    ``values``: the health options by name, None for those of
    :data:`~gear_phm.offline.truth.LIFE_HEALTH` not given; ``ratio``: None for the life's,
    else the parameter's default. Raises EvaluationError if they are not valid.
    """
    chosen = dict(values)
    given = life.health_defaults() if life is not None else {}
    for name in LIFE_HEALTH:
        if chosen[name] is None:
            chosen.pop(name)
            if name in given:
                chosen[name] = given[name]
    if ratio is None:
        ratio = life.ratio if life is not None else float(RATIO.default)
    try:
        return HealthConfig(ratio=float(ratio), **chosen)
    except (TypeError, ValueError) as exc:
        raise EvaluationError(str(exc)) from None


def overlap(run: tuple[float, float], truth: tuple[float, float] | None,
            path: Path) -> list[str]:
    """Check that the run's stamps [s] overlap the truth's; return warnings if only partly.

    Raises EvaluationError when they do not overlap at all.
    """
    if truth is None:
        return []
    spans = (f"the run's predictions are stamped {run[0]:.6g}-{run[1]:.6g} s, the truth "
             f'{path} {truth[0]:.6g}-{truth[1]:.6g} s')
    if run[1] < truth[0] or run[0] > truth[1]:
        msg = f'{spans}: they do not overlap (not the same time base?)'
        raise EvaluationError(msg) from None
    slack = 0.01 * (truth[1] - truth[0])      # a thinned truth topic ends a little early
    if run[0] < truth[0] - slack or run[1] > truth[1] + slack:
        return [f'{spans}: they overlap only partly']
    return []


def evaluate_run(bag: Path, truth: Path, config: HealthConfig, *,
                 life: LifeRecord | None = None, drive: str | None = None,
                 alpha: float, lambdas: Sequence[float], band_from: float,
                 t_start: float | None = None) -> Evaluation:
    """Score the RUL predictions of ``bag`` against ``truth`` (module docstring).

    ``config``: the health parameters, whose u_eol defines the end of life; ``life``: the
    random life's record (:func:`~gear_phm.offline.truth.read_life`), whose end of life,
    wear onset (``t_start`` when None) and per-life scores are then used when its u_eol is
    the config's. Raises EvaluationError, :class:`~gear_phm.offline.truth.TruthError` or
    :class:`~gear_phm.bagio.BagError` when the run cannot be scored.
    """
    u_eol, _ = end_of_life_u(config.ratio, config.eta_opposing_min, config.must_back_drive,
                             config.u_max)
    predictions = read_predictions(bag, drive)
    same_eol = life is not None and math.isclose(u_eol, life.u_eol, rel_tol=1e-9)
    if same_eol and life is not None and (life.healthy or life.end_of_life_s is not None):
        warnings = overlap(predictions.span, bag_span(truth), truth)
        t_eol = life.end_of_life_s
        if life.healthy or t_eol is None:       # a healthy life has no end of life
            return _healthy(bag, drive, predictions, u_eol, warnings)
    else:
        t_eol, truth_span = truth_eol_and_span(truth, u_eol, drive)
        warnings = overlap(predictions.span, truth_span, truth)
    if t_start is None and life is not None and life.onset_s is not None:
        t_start = life.onset_s
    metrics = _scores(predictions, read_levels(bag, drive), t_eol, alpha, lambdas, band_from,
                      t_start, life is not None)
    times = predictions.times
    start = float(metrics['t_start_s'])
    last = max(c['lam'] for c in metrics['alpha_lambda'])
    if times[-1] < start + last * (t_eol - start):
        warnings.append(f"the run's last prediction at {times[-1]:.6g} s comes before lambda "
                        f'{last:g} of the life ({start:.6g}-{t_eol:.6g} s): later checks '
                        'score that prediction')
    return Evaluation(metrics, tuple(warnings), u_eol, t_eol)


def _scores(predictions: Predictions, levels: tuple[np.ndarray, np.ndarray] | None,
            t_eol: float, alpha: float, lambdas: Sequence[float], band_from: float,
            t_start: float | None, per_life: bool) -> dict[str, Any]:
    """Return the metrics of predictions of a life that ends at ``t_eol`` [s]."""
    times, median = predictions.times, predictions.median
    before = times < t_eol
    if not before.any():
        msg = f'no prediction before the true end of life at {t_eol:.6g} s'
        raise EvaluationError(msg) from None
    try:
        metrics = evaluate(times[before], median[before], t_eol, alpha, lambdas, t_start)
        start = float(metrics['t_start_s'])
        share, counted = band_coverage(times, predictions.p5, predictions.p95, t_eol,
                                       band_from, start)
        changes = () if levels is None else level_transitions(*levels, t_eol, start)
        finite = finite_from(times[before], median[before], t_eol, start)
        scores = (acceptance(times, median, predictions.p5, predictions.p95, t_eol, start,
                             levels, alpha) if per_life else None)
    except ValueError as exc:
        raise EvaluationError(str(exc)) from None
    metrics['rul_finite_from'] = 'inf' if math.isinf(finite) else finite
    metrics['band_coverage'] = {'from_lambda': band_from,
                                'share': 'nan' if math.isnan(share) else share,
                                'predictions': counted}
    if levels is not None:
        metrics['level_transitions'] = [
            {'t': c.t, 'lam': c.lam, 'from': LEVEL_NAMES.get(c.before, str(c.before)),
             'to': LEVEL_NAMES.get(c.after, str(c.after))} for c in changes]
        metrics['error_before_eol'] = bool(np.any((levels[1] == ERROR) & (levels[0] < t_eol)))
    if scores is not None:
        metrics['acceptance'] = scores
    return metrics


def _healthy(bag: Path, drive: str | None, predictions: Predictions, u_eol: float,
             warnings: list[str]) -> Evaluation:
    """Score a healthy random life: RUL inf and level OK throughout."""
    levels = read_levels(bag, drive)
    score = healthy_acceptance(predictions.median, None if levels is None else levels[1])
    metrics: dict[str, Any] = {'healthy': True, 'predictions': score['predictions'],
                               'acceptance': {'healthy': score}}
    return Evaluation(metrics, tuple(warnings), u_eol, math.nan)
