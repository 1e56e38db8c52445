"""Replay the RUL on an analysed random-life ensemble: only the diagnostics side, in seconds.

For each life of an ensemble that bench/ensemble.py simulated and analysed
(ENSEMBLE/<rate>hz/life_<seed>/bag with life.json, .../a/a_0.mcap with the estimator's
topics), the estimator's updates are rebuilt from their topics (the diagnostics node's
:func:`~gear_phm.interfaces.estimate_from_vectors`), fed to a fresh
:class:`~gear_phm.prognostics.HealthAssessor` (the life's ratio and eta_opposing_min,
defaults otherwise, as ``gear-phm analyze``), and its health states are scored as
``gear-phm evaluate`` scores them (:func:`~gear_phm.prognostics.metrics.acceptance`, from the
wear onset; :func:`~gear_phm.prognostics.metrics.healthy_acceptance`). The aggregate, per
family and per feature tables are bench/ensemble.py's. The estimator's output is fixed, so a
change of the RUL method is scored on the whole ensemble in minutes instead of 40.

The decoded updates are cached per life as OUT/cache/<rate>hz_life_<seed>.npz (a re-run
costs only the assessor). Writes OUT/table.md and OUT/replay.json.

Usage: .venv/bin/python bench/rul_replay.py [ENSEMBLE] [--out OUT] [--workers 2] [--nice 10]
       [--seeds 1 2 ...] [--param NAME=VALUE ...]

``--param`` overrides a health parameter (:class:`~gear_phm.prognostics.HealthConfig`) for
every life, as ``gear-phm analyze --param`` would: a default is scored on the whole ensemble
before it is changed.
"""
from __future__ import annotations

import argparse
import json
import math
from multiprocessing import Pool
import os
from pathlib import Path
import sys
import time
from types import SimpleNamespace
from typing import Any

from ensemble import _json_ready, groups, LIFE_HEADER, life_row, tables
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from gear_phm import interfaces  # noqa: E402
from gear_phm.bagio.chunks import McapChunkReader  # noqa: E402
from gear_phm.offline.truth import truth_eol  # noqa: E402
from gear_phm.prognostics import end_of_life_u, HealthAssessor, HealthConfig  # noqa: E402
from gear_phm.prognostics.metrics import acceptance, healthy_acceptance  # noqa: E402

TOPICS = interfaces.ESTIMATOR_TOPICS


def decoded(analysis: Path, cache: Path) -> tuple[np.ndarray, np.ndarray]:
    """Return (stamps [ns], N x 3 x len(TOPICS) values) of the estimator's updates.

    Updates whose stamp lacks one of the topics keep NaN there; cached in ``cache`` with the
    topics' names (a cache of other topics, e.g. from before gear_phm/direction_offset, is
    made again).
    """
    if cache.is_file():
        with np.load(cache) as data:
            if 'topics' in data and data['topics'].tolist() == list(TOPICS):
                return data['stamps'], data['values']
    columns: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {t: [] for t in TOPICS}
    with McapChunkReader(sorted(analysis.glob('*.mcap'))) as reader:
        names = {'/' + t: t for t in TOPICS}
        names.update({t: t for t in TOPICS})
        for batch in reader.batches(list(names)):
            stamps, values = interfaces.vector3_stamped_columns(
                batch.buffer, batch.offsets, batch.lengths)
            columns[names[batch.topic]].append((stamps, values))
    per_topic = {}
    for topic, parts in columns.items():
        if parts:
            per_topic[topic] = (np.concatenate([p[0] for p in parts]),
                                np.concatenate([p[1] for p in parts]))
    stamps = np.unique(np.concatenate([s for s, _ in per_topic.values()]))
    values = np.full((stamps.size, 3, len(TOPICS)), np.nan)
    for k, topic in enumerate(TOPICS):
        if topic in per_topic:
            s, v = per_topic[topic]
            values[np.searchsorted(stamps, s), :, k] = v
    cache.parent.mkdir(parents=True, exist_ok=True)
    np.savez(cache, stamps=stamps, values=values, topics=np.array(TOPICS))
    return stamps, values


def estimates(stamps: np.ndarray, values: np.ndarray) -> list[Any]:
    """Return the decoded updates as FrictionEstimates (as the diagnostics node rebuilds them)."""
    out = []
    rows = values.tolist()
    for stamp, row in zip(stamps.tolist(), rows):
        vectors = {topic: SimpleNamespace(x=row[0][k], y=row[1][k], z=row[2][k])
                   for k, topic in enumerate(TOPICS) if not math.isnan(row[0][k])
                   or not math.isnan(row[1][k]) or not math.isnan(row[2][k])}
        out.append(interfaces.estimate_from_vectors(int(stamp), vectors))
    return out


def replay_life(task: tuple[Path, Path, dict[str, Any]]) -> dict[str, Any]:
    """Assess and score one life; return its life.json, scores and timings."""
    directory, out, overrides = task
    started = time.perf_counter()
    life = json.loads((directory / 'bag' / 'life.json').read_text())
    name = f"{life['rate_hz']:g}hz_life_{life['seed']}"
    stamps, values = decoded(directory / 'a', out / 'cache' / f'{name}.npz')
    updates = estimates(stamps, values)
    config = HealthConfig(ratio=float(life['ratio']),
                          eta_opposing_min=float(life['eta_opposing_min'])).replace(**overrides)
    assessor = HealthAssessor(config)
    assessing = time.perf_counter()
    states = [s for s in assessor.on_estimates(updates) if s is not None]
    assessed = time.perf_counter() - assessing
    t = np.array([s.stamp_ns for s in states]) * 1e-9
    order = np.argsort(t, kind='stable')
    t = t[order]
    median, p5, p95, level = (np.array([getattr(s.rul, k) if k != 'level' else s.level
                                        for s in states])[order]
                              for k in ('median', 'p5', 'p95', 'level'))
    if life['healthy']:
        score: dict[str, Any] = {'healthy': healthy_acceptance(median, level)}
    else:
        u_eol, _ = end_of_life_u(config.ratio, config.eta_opposing_min, config.must_back_drive,
                                 config.u_max)
        t_eol = life['end_of_life_s']
        if t_eol is None or not math.isclose(u_eol, float(life['u_eol']), rel_tol=1e-9):
            t_eol = truth_eol(directory / 'bag', u_eol)
        onset = life['onset_s'] if life['onset_s'] is not None else float(t[0])
        score = acceptance(t, median, p5, p95, float(t_eol), float(onset), (t, level))
    changes = [(s.stamp_ns * 1e-9, s.level, s.message.split(':')[0].split(';')[0])
               for s, before in zip(states[1:], states) if s.level != before.level]
    trace = {'t': t, 'median': median, 'p5': p5, 'p95': p95, 'level': level}
    np.savez(out / 'cache' / f'{name}.states.npz', **trace)
    return {'life': life, 'evaluation': {'acceptance': score}, 'directory': str(directory),
            'seconds': time.perf_counter() - started, 'assess_seconds': assessed,
            'updates': len(updates), 'changes': changes}


def _parameter(text: str) -> tuple[str, Any]:
    """Return (name, value) of a ``NAME=VALUE`` option; the value's type is the field's."""
    name, _, value = text.partition('=')
    default = getattr(HealthConfig(), name, None)
    if default is None or not value:
        raise SystemExit(f'--param {text!r}: not NAME=VALUE of a health parameter')
    if isinstance(default, bool):
        return name, value.lower() in ('1', 'true', 'yes')
    return name, type(default)(value)


def main() -> int:
    """Replay the ensemble's lives and print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('ensemble', type=Path, nargs='?', default=Path('/tmp/ensemble-60'))
    parser.add_argument('--out', type=Path, default=Path('/tmp/rul-replay'))
    parser.add_argument('--workers', type=int, default=2)
    parser.add_argument('--nice', type=int, default=10)
    parser.add_argument('--seeds', type=int, nargs='*', default=None,
                        help='only these seeds (default: every life in ENSEMBLE)')
    parser.add_argument('--param', action='append', default=[], metavar='NAME=VALUE',
                        help='a health parameter for every life (repeatable)')
    args = parser.parse_args()
    overrides = dict(_parameter(text) for text in args.param)
    os.nice(args.nice)
    lives = sorted((p for p in args.ensemble.glob('*hz/life_*') if (p / 'a').is_dir()),
                   key=lambda p: (p.parent.name, int(p.name.split('_')[1])))
    if args.seeds:
        lives = [p for p in lives if int(p.name.split('_')[1]) in args.seeds]
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / 'cache').mkdir(exist_ok=True)
    started = time.perf_counter()
    with Pool(args.workers) as pool:
        results = pool.map(replay_life, [(p, args.out, overrides) for p in lives], chunksize=1)
    elapsed = time.perf_counter() - started
    assess = sum(r['assess_seconds'] for r in results)
    updates = sum(r['updates'] for r in results)
    text = ['\n'.join([LIFE_HEADER] + [life_row(r) for r in results]), tables(results),
            f'{len(results)} lives, {updates} updates, assessor {assess:.1f} s '
            f'({1e6 * assess / max(updates, 1):.1f} us/update), wall {elapsed:.0f} s']
    print('\n\n'.join(text))
    (args.out / 'table.md').write_text('\n\n'.join(text) + '\n', encoding='utf-8')
    summary = {'lives': len(results), 'gear_phm': groups(results),
               'level_changes': {f"{r['life']['rate_hz']:g}hz_life_{r['life']['seed']}":
                                 r['changes'] for r in results if r['changes']},
               'assess_seconds': assess, 'updates': updates}
    (args.out / 'replay.json').write_text(json.dumps(_json_ready(summary), indent=2) + '\n',
                                          encoding='utf-8')
    return 0


if __name__ == '__main__':
    sys.exit(main())
