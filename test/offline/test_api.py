"""The README's notebook example of gear_phm.offline runs verbatim and says what it claims."""
from __future__ import annotations

import contextlib
import io
import os
from pathlib import Path
import re

import numpy as np
import pytest

from gear_phm.estimation import Measurement
from gear_phm.offline import AnalysisError, analyze_bag
from gear_phm.offline.records import ESTIMATES, MeasuredWindows

ROOT = Path(__file__).resolve().parents[2]


def _readme_snippet() -> str:
    text = (ROOT / 'README.md').read_text()
    section = text.split('## Python API: offline analysis in a notebook', 1)[1]
    return re.search(r'```python\n(.*?)```', section, re.S).group(1)


def test_readme_notebook_snippet_runs_verbatim() -> None:
    pytest.importorskip('pandas')
    namespace: dict = {}
    out = io.StringIO()
    cwd = os.getcwd()
    os.chdir(ROOT)                       # the snippet names bags/wearing relative to the repo
    try:
        with contextlib.redirect_stdout(out):
            exec(compile(_readme_snippet(), 'README.md', 'exec'), namespace)  # noqa: S102
    finally:
        os.chdir(cwd)
    analysis, frame = namespace['analysis'], namespace['frame']
    # true u at the end of bags/wearing is 0.30 (bags/README.md)
    assert analysis.estimates.u[-1] == pytest.approx(0.30, abs=0.01)
    assert re.match(r'u = 0\.\d{4} \+/- 0\.\d{4}, level (OK|WARN|ERROR)\n'
                    r'first WARN at \d+ s of bag time\n', out.getvalue())
    assert len(frame) == analysis.estimates.u.size
    assert {'t', 'u', 'p_uu', 'level', 'rul_p5'} <= set(frame.columns)


def test_api_histories_match_summary_and_outputs(tmp_path: Path) -> None:
    analysis = analyze_bag(ROOT / 'bags' / 'fault', ratio=3.0, out=tmp_path / 'run',
                           plot=False, eta_opposing_min=0.7333)
    e, h = analysis.estimates, analysis.health
    # the summary is the last posterior, the last estimate predicted to the newest sample
    assert e.u[-1] == pytest.approx(analysis.summary.estimator.u, abs=3 * e.u_sigma[-1])
    assert np.all(np.diff(e.stamp_ns) > 0)                  # one estimate per stamp, in order
    assert np.array_equal(h.stamp_ns, e.stamp_ns)           # a health state per estimate
    assert analysis.out == tmp_path / 'run'
    assert (tmp_path / 'run' / 'summary.json').is_file()
    # the step fault 0.05 -> 0.20 at 60 s: u before and after
    t = e.t - e.t[0]
    assert np.median(e.u[(t > 30) & (t < 55)]) == pytest.approx(0.05, abs=0.005)
    assert np.median(e.u[t > 90]) == pytest.approx(0.20, abs=0.01)
    # eta_warn derived from eta_opposing_min and the healthy eta_D learned at the start
    # (0.939, true 0.937 at u 0.05): 0.7333 + 0.25 (0.939 - 0.7333) = 0.785; u 0.20 gives
    # eta_D 0.778 < 0.785
    assert re.search(r'eta_D 0\.77\d* < 0\.78\d*(;|$)', h.messages[-1]), h.messages[-1]


def test_api_bad_input_names_the_problem(tmp_path: Path) -> None:
    bag = ROOT / 'bags' / 'healthy'
    with pytest.raises(AnalysisError, match='does not exist'):
        analyze_bag(tmp_path / 'missing', ratio=3.0)
    with pytest.raises(AnalysisError, match=r"unknown option\(s\) \['proces_noise'\]"):
        analyze_bag(bag, ratio=3.0, proces_noise=1e-10)
    with pytest.raises(AnalysisError, match='eta_warn must be > eta_opposing_min'):
        analyze_bag(bag, ratio=3.0, eta_opposing_min=0.9, eta_warn=0.85)
    with pytest.raises(AnalysisError, match='ratio must be in'):
        analyze_bag(bag, ratio=-3.0)
    for history in ('10', 10.5, 0, True):
        with pytest.raises(AnalysisError, match='history must be an integer >= 1 or None'):
            analyze_bag(bag, ratio=3.0, history=history)    # type: ignore[arg-type]
    with pytest.raises(AnalysisError, match=r'diagnostics_rate must be in \[0.01, 1000\]'):
        analyze_bag(bag, ratio=3.0, diagnostics_rate=1e12)
    with pytest.raises(AnalysisError, match='is given twice'):
        analyze_bag([bag, bag], ratio=3.0)        # its time would run twice
    with pytest.raises(AnalysisError, match='topic must be a topic name, got None'):
        analyze_bag(bag, ratio=3.0, topic=None)               # type: ignore[arg-type]
    with pytest.raises(AnalysisError, match='a bag is a path'):
        analyze_bag([None], ratio=3.0)                        # type: ignore[list-item]
    with pytest.raises(AnalysisError, match='transmissions must be a file'):
        analyze_bag(bag, transmissions=5)
    with pytest.raises(AnalysisError, match="joints 'a' and 'b'"):
        analyze_bag(bag, ratio=3.0, motor_joint='a', load_joint='b', out=tmp_path / 'x')
    assert not (tmp_path / 'x').exists()                    # a failed run leaves no output
    assert not list(tmp_path.glob('.x.*'))


def test_history_bounds_the_returned_histories_not_the_result() -> None:
    """history=N keeps N..2N evenly spaced records and the last; the summary is all of it."""
    full = analyze_bag(ROOT / 'bags' / 'healthy', 3.0, plot=False, history=None)
    lean = analyze_bag(ROOT / 'bags' / 'healthy', 3.0, plot=False, history=100)
    n = full.estimates.u.size
    assert n > 1000
    kept = lean.estimates.stamp_ns
    assert 100 <= kept.size <= 201 and 100 <= lean.health.stamp_ns.size <= 201
    assert lean.measurements == full.measurements           # 109 windows: fewer than 2N
    assert np.isin(kept, full.estimates.stamp_ns).all()
    positions = np.searchsorted(full.estimates.stamp_ns, kept)
    assert positions[0] == 0 and np.unique(np.diff(positions[:-1])).size == 1  # evenly spaced
    assert positions[-1] == n - 1 and lean.estimates.u[-1] == full.estimates.u[-1]  # the last
    assert lean.summary.estimator.u == full.summary.estimator.u
    # the default keeps a bag this short whole, and the plot's envelopes cover every estimate
    default = analyze_bag(ROOT / 'bags' / 'healthy', 3.0, plot=False)
    assert np.array_equal(default.estimates.u, full.estimates.u, equal_nan=True)
    envelope = default.envelopes[ESTIMATES]
    assert envelope.count.sum() == n and envelope.stamp_ns[0] == full.estimates.stamp_ns[0]
    for name in ('u', 'eta_opposing'):
        assert np.nanmin(envelope.low[name]) == np.nanmin(getattr(full.estimates, name))
        assert np.nanmax(envelope.high[name]) == np.nanmax(getattr(full.estimates, name))
    assert lean.summary.windows_measured == full.summary.windows_measured
    with pytest.raises(AnalysisError, match='history must be an integer >= 1'):
        analyze_bag(ROOT / 'bags' / 'healthy', 3.0, plot=False, history=0)


def test_measured_windows_are_columns_read_as_items() -> None:
    """Analysis.measurements: a sequence built from columns, equal to its items as a tuple."""
    columns = {'stamp_ns': np.array([10, 20, 30]), 'code': np.array([1, 2, 1]),
               'accepted': np.array([True, False, True]), 't': np.array([0.1, 0.2, 0.3]),
               'eta': np.array([0.9, 0.8, 0.7]), 'eta_variance': np.array([1e-4, 2e-4, 3e-4]),
               'u': np.array([0.1, 0.2, 0.3]), 'u_variance': np.array([1e-6, 2e-6, 3e-6])}
    windows = MeasuredWindows(columns)
    items = tuple((s, Measurement(t, c, e, ev, u, uv), a) for s, c, a, t, e, ev, u, uv in zip(
        [10, 20, 30], [1, 2, 1], [True, False, True], [0.1, 0.2, 0.3], [0.9, 0.8, 0.7],
        [1e-4, 2e-4, 3e-4], [0.1, 0.2, 0.3], [1e-6, 2e-6, 3e-6]))
    assert len(windows) == 3 and windows == items and list(windows) == list(items)
    assert windows[-1] == items[2] and windows[1:] == items[1:]
    assert type(windows[0][0]) is int and type(windows[0][2]) is bool
    assert windows != items[:2] and MeasuredWindows({}) == ()
    with pytest.raises(IndexError):
        windows[3]
