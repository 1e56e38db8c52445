"""Time the RUL predictor alone on the calls an analysis made, and keep its outputs.

``record BAG OUT.pkl ANALYZE-ARGS...``: runs ``gear-phm analyze`` on BAG with the
RulPredictor's calls (construction, u_eol, add, predict) recorded to OUT.pkl.
``replay OUT.pkl [RESULT.npy]``: replays them on a fresh predictor of this checkout, prints the
seconds it took (best of 3) and saves every predict's (median, p5, p95) to RESULT.npy.

Usage (from the checkout, with PYTHONPATH=.):
  .venv/bin/python bench/rul_refit_trace.py record bags/wearing /tmp/t.pkl --ratio 3.0
  .venv/bin/python bench/rul_refit_trace.py replay /tmp/t.pkl /tmp/t.npy
"""
from __future__ import annotations

import pickle
import sys
import time
from typing import Any

import numpy as np

from gear_phm.prognostics import predictor as module


def record(bag: str, out: str, args: list[str]) -> None:
    """Analyse ``bag`` with the predictor's calls recorded to ``out``."""
    calls: list[tuple[Any, ...]] = []
    cls = module.RulPredictor
    init, add, predict = cls.__init__, cls.add, cls.predict

    def rec_init(self: Any, *a: Any, **k: Any) -> None:
        calls.append(('init', a, k))
        init(self, *a, **k)

    def rec_add(self: Any, *a: Any, **k: Any) -> None:
        calls.append(('add', self.u_eol, a, k))
        add(self, *a, **k)

    def rec_predict(self: Any, t: float, u: float) -> Any:
        calls.append(('predict', self.u_eol, t, u))
        return predict(self, t, u)
    cls.__init__, cls.add, cls.predict = rec_init, rec_add, rec_predict   # type: ignore
    from gear_phm.cli.main import main
    main(['analyze', bag, *args, '--no-plot', '--out', out + '.analysis', '--overwrite'])
    with open(out, 'wb') as stream:
        pickle.dump(calls, stream)


def replay(path: str) -> tuple[float, np.ndarray]:
    """Return the seconds the recorded calls took and the predictions."""
    with open(path, 'rb') as stream:
        calls = pickle.load(stream)
    predictor = None
    results = []
    start = time.perf_counter()
    for call in calls:
        if call[0] == 'init':
            predictor = module.RulPredictor(*call[1], **call[2])
        elif call[0] == 'add':
            predictor.u_eol = call[1]
            predictor.add(*call[2], **call[3])
        else:
            predictor.u_eol = call[1]
            rul = predictor.predict(call[2], call[3])
            results.append((rul.median, rul.p5, rul.p95))
    return time.perf_counter() - start, np.array(results)


if __name__ == '__main__':
    if sys.argv[1] == 'record':
        record(sys.argv[2], sys.argv[3], sys.argv[4:])
    else:
        runs = [replay(sys.argv[2]) for _ in range(3)]
        print(f'{min(r[0] for r in runs):.3f} s, {runs[0][1].shape[0]} predictions')
        if len(sys.argv) > 3:
            np.save(sys.argv[3], runs[0][1])
