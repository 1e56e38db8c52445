"""Stamp screening and loss counting (gear_phm.estimation.stamps) through the pipeline.

Stray stamps are dropped and counted without touching the estimate, runs reset or are
accepted, gaps are counted as samples_missing, for any batch split.
"""
from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from gear_phm.estimation import EstimatorConfig, EstimatorPipeline
from gear_phm.estimation.stamps import BLOCK, StampScreen
from gear_phm.status import OK, WARN
from helpers.plant import lever_plant

CONFIG = EstimatorConfig(ratio=3.0, motor_torque_noise=0.05, load_torque_noise=0.05,
                         motor_inertia=0.01)
MS = 1_000_000


def _columns(run, index=None):
    cols = (run.stamp_ns, run.motor_velocity, run.motor_effort, run.load_velocity,
            run.load_effort)
    return [c if index is None else c[index] for c in cols]


def _feed(pipeline: EstimatorPipeline, columns, cuts=()) -> list:
    n = columns[0].size
    bounds = [0, *sorted(c for c in cuts if 0 < c < n), n]
    out = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        out += pipeline.on_batch(*(c[a:b] for c in columns))
    return out


def _insert(columns, at: int, stamp: int):
    """Return the stream with one extra sample stamped ``stamp`` before sample ``at``.

    The extra sample has the values of sample ``at``.
    """
    return [np.insert(c, at, stamp if k == 0 else c[at]) for k, c in enumerate(columns)]


def _same(got, expected) -> bool:
    """Return whether ``got`` matches ``expected``.

    Same stamps; u and covariance equal up to float rounding of the batch split.
    """
    return [e.stamp_ns for e in got] == [e.stamp_ns for e in expected] and np.allclose(
        [(e.u, *e.covariance) for e in got], [(e.u, *e.covariance) for e in expected],
        rtol=1e-9, atol=1e-15)


def test_lone_zero_past_and_future_stamps_are_dropped_and_change_nothing() -> None:
    run = lever_plant(3, 60.0, 0.1)
    clean = EstimatorPipeline(CONFIG)
    expected = _feed(clean, _columns(run))
    cols = _columns(run)
    stamps = run.stamp_ns
    cols = _insert(cols, 40000, stamps[39000] + 3 * 3600 * 10 ** 9)   # 3 h ahead
    cols = _insert(cols, 30000, stamps[29000])                         # 1 s back
    cols = _insert(cols, 20000, 0)                                     # zero stamp
    dirty = EstimatorPipeline(CONFIG)
    got = _feed(dirty, cols, cuts=(10000, 20000, 20001, 35000))
    assert _same(got, expected)                   # u, sigma and stamps unchanged
    assert dirty.counts['backwards'] == 2 and dirty.counts['future'] == 1
    assert dirty.counts['stamp_reset'] == 0 and dirty.samples_missing == 0
    assert dirty.samples_rejected == clean.samples_rejected + 3
    status = dict(dirty.status('e').values)
    assert status['dropped_backwards'] == '2' and status['dropped_future'] == '1'


def test_a_short_stray_run_is_dropped_a_run_of_stamp_run_resets() -> None:
    run = lever_plant(4, 30.0, 0.1)
    cols = _columns(run)
    stray = [np.concatenate((c[:20000], c[:9], c[20000:])) for c in cols]  # 9 < stamp_run
    pipeline = EstimatorPipeline(CONFIG)
    _feed(pipeline, stray, cuts=(20003,))
    assert pipeline.counts['backwards'] == 9 and pipeline.counts['stamp_reset'] == 0
    looped = [np.concatenate((c, c, c)) for c in cols]                     # a bag loops
    pipeline = EstimatorPipeline(CONFIG)
    out = _feed(pipeline, looped, cuts=(30003, 30005, 60000))
    assert pipeline.counts['stamp_reset'] == 2 and pipeline.counts['backwards'] == 0
    single = EstimatorPipeline(CONFIG)
    once = _feed(single, cols)
    # every loop gives the same estimates as the first pass: nothing lost at the reset
    assert _same(out, once * 3)


def test_every_output_stamp_is_an_accepted_input_stamp_strictly_increasing() -> None:
    run = lever_plant(5, 40.0, 0.1)
    cols = _columns(run)
    rng = np.random.default_rng(1)
    keep = np.sort(rng.choice(run.t.size, run.t.size * 9 // 10, replace=False))
    cols = [c[keep] for c in cols]
    cols = _insert(cols, 5000, 0)
    out = _feed(EstimatorPipeline(CONFIG), cols, cuts=range(0, keep.size, 777))
    stamps = [e.stamp_ns for e in out]
    assert stamps == sorted(set(stamps))
    assert set(stamps) <= set(run.stamp_ns[keep].tolist())


def test_missing_samples_counted_exactly_used_rejected_missing_add_up() -> None:
    run = lever_plant(6, 30.0, 0.1)
    rng = np.random.default_rng(2)
    lost = np.zeros(run.t.size, dtype=bool)
    lost[rng.choice(np.arange(1, run.t.size - 1), 900, replace=False)] = True   # 3 %
    lost[12000:12050] = True                                                   # a burst
    cols = [c[~lost] for c in _columns(run)]
    pipeline = EstimatorPipeline(CONFIG)
    out = _feed(pipeline, cols, cuts=range(0, run.t.size, 1234))
    assert pipeline.samples_missing == int(lost.sum())
    assert pipeline.samples_used + pipeline.samples_rejected + pipeline.samples_missing \
        == run.t.size
    # each estimate carries the count at its own stamp
    for e in out[::10]:
        assert e.samples_missing == int(lost[run.stamp_ns <= e.stamp_ns].sum())
    assert pipeline.screen.period_ns == pytest.approx(1e6)


def test_loss_ratio_over_the_status_period_warns_above_loss_warn() -> None:
    run = lever_plant(7, 20.0, 0.1)
    cols = _columns(run)
    pipeline = EstimatorPipeline(CONFIG)
    pipeline.on_batch(*(c[:15000] for c in cols))
    pipeline.status('e')                                    # closes the first period
    status = pipeline.status('e')
    assert status.level == OK and dict(status.values)['loss_ratio'] == '0.0'
    part = slice(15000, 20000)
    keep = np.ones(5000, dtype=bool)
    keep[1::25] = False                                     # 4 % lost
    pipeline.on_batch(*(c[part][keep] for c in cols))
    status = pipeline.status('e')
    values = dict(status.values)
    assert status.level == WARN and 'missing' in status.message
    assert float(values['loss_ratio']) == pytest.approx(200 / 5000, rel=1e-3)
    assert values['samples_missing'] == '200'
    assert float(values['sample_period_s']) == pytest.approx(1e-3)


def _stamps(*pieces: tuple[float, float]) -> np.ndarray:
    """Back-to-back stretches of (duration [s], period [s]) from stamp 1e18 ns."""
    out, t = [], 10 ** 18
    for duration, period in pieces:
        step = int(round(period * 1e9))
        count = int(round(duration / period))
        out.append(t + step * np.arange(count, dtype=np.int64))
        t = int(out[-1][-1]) + step
    return np.concatenate(out)


def _screen_missing(stamps: np.ndarray, hold: float = 5.0, cuts=()) -> tuple[int, StampScreen]:
    screen = StampScreen(10, int(0.5e9), int(hold * 1e9))
    bounds = [0, *sorted(c for c in cuts if 0 < c < stamps.size), stamps.size]
    held = stamps[:0]
    for a, b in zip(bounds[:-1], bounds[1:]):
        part = np.concatenate((held, stamps[a:b]))    # held stamps go first, as the pipeline
        held = part[screen.screen(part).held]
    return screen.missing, screen


def test_rate_raised_is_followed_at_once_rate_lowered_after_period_hold() -> None:
    missing, screen = _screen_missing(_stamps((5.0, 0.01), (5.0, 0.001)))
    assert missing == 0 and screen.period_ns == pytest.approx(1e6)
    # 1 kHz -> 100 Hz: the slower rate counts as 90 % loss until it has lasted period_hold
    missing, screen = _screen_missing(_stamps((5.0, 0.001), (20.0, 0.01)), hold=2.0)
    assert screen.period_ns == pytest.approx(1e7)
    assert 9 * 150 <= missing <= 9 * 300               # 1.5-3 s of 100 Hz, 9 per sample


def test_heavy_uniform_loss_is_counted_for_period_hold() -> None:
    stamps = _stamps((1.0, 1e-4), (2.0, 1e-4))          # 10 kHz
    received = np.concatenate((stamps[:10000], stamps[10000::4]))   # then 3 of 4 lost
    missing, screen = _screen_missing(received, hold=5.0, cuts=range(0, 20000, 333))
    assert received.size == 15000 and missing == 3 * 4999
    assert screen.period_ns == pytest.approx(1e5)


def test_first_gaps_wait_for_the_first_block() -> None:
    stamps = _stamps((1.0, 0.01))                        # 100 samples at 100 Hz
    received = np.delete(stamps, [3, 4, 50])
    missing, screen = _screen_missing(received)
    assert screen.period_ns is None and missing == 0     # fewer than BLOCK differences
    more = _stamps((3.0, 0.01))[100:]
    screen.screen(more)
    assert screen.missing == 3 and BLOCK == 100


@settings(max_examples=25, deadline=None)
@given(st.lists(st.integers(1, 4000), min_size=1, max_size=8))
def test_screen_decisions_do_not_depend_on_batch_split(cuts: list[int]) -> None:
    run = lever_plant(8, 20.0, 0.1)
    cols = _columns(run)
    rng = np.random.default_rng(3)
    keep = np.ones(run.t.size, dtype=bool)
    keep[rng.choice(run.t.size, 400, replace=False)] = False
    cols = [c[keep] for c in cols]
    for at, stamp in ((3000, 0), (7000, cols[0][100]), (9000, cols[0][-1] + 10 ** 12)):
        cols = _insert(cols, at, stamp)
    cols = [np.concatenate((c, c[:4000])) for c in cols]                  # and a loop
    whole = EstimatorPipeline(CONFIG)
    expected = _feed(whole, cols)
    split = EstimatorPipeline(CONFIG)
    got = _feed(split, cols, cuts=np.cumsum(cuts).tolist())
    assert [(e.stamp_ns, e.samples_used, e.samples_rejected, e.samples_missing)
            for e in got] == [(e.stamp_ns, e.samples_used, e.samples_rejected,
                               e.samples_missing) for e in expected]
    assert np.allclose([e.u for e in got], [e.u for e in expected], rtol=1e-9, atol=1e-12)
    assert split.counts == whole.counts and split.samples_missing == whole.samples_missing
    assert whole.counts['stamp_reset'] == 1 and whole.counts['future'] == 1


def test_heavy_bursty_loss_is_counted_once_never_as_rejected_too() -> None:
    """Loss that leaves gaps longer than the jump limit again and again.

    As in an overloaded node at 10 kHz: every gap is counted missing, no received sample is
    dropped.
    """
    stamps = _stamps((1.0, 1e-4), (3.0, 1e-4))
    rng = np.random.default_rng(4)
    keep = np.ones(stamps.size, dtype=bool)
    position = 10000
    while position < stamps.size:                      # 3-15 received, then 50-400 lost
        position += int(rng.integers(3, 16))
        lost = int(rng.integers(50, 401))
        keep[position:position + lost] = False
        position += lost
    keep[-20:] = True              # the stream ends in sequence (a held run would wait)
    screen = StampScreen(10, int(0.5e9), int(5e9))
    dropped, held = 0, stamps[:0]
    for part in np.array_split(stamps[keep], 37):
        part = np.concatenate((held, part))           # held stamps go first, as the pipeline
        screened = screen.screen(part)
        held = part[screened.held]
        dropped += sum(step[1] for step in screened.steps if isinstance(step, tuple))
    assert dropped == 0
    assert screen.missing == int((~keep).sum())
