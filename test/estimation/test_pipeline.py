"""The estimator pipeline (gear_phm.estimation.pipeline): batches, plants, stamps (seeded)."""
from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from gear_phm import interfaces
from gear_phm.bagio import TYPESTORE
from gear_phm.codec import JointStateDecoder
from gear_phm.estimation import EstimatorConfig
from gear_phm.estimation.pipeline import EstimatorPipeline
from gear_phm.models import SpurGear
from gear_phm.status import WARN
from helpers.plant import lever_plant

NOISE = {'motor_torque_noise': 0.05, 'motor_speed_noise': 0.01, 'load_torque_noise': 0.05,
         'load_speed_noise': 0.01}

CONFIG = EstimatorConfig(ratio=3.0, motor_inertia=0.01, **NOISE)


def _topics(estimates: list) -> list:
    """Return the estimator topics' records of each estimate, as the transports publish them."""
    return [o for e in estimates for o in interfaces.estimate_outputs(e)]


def _feed(pipeline: EstimatorPipeline, run, start: int = 0, stop: int | None = None) -> list:
    s = slice(start, stop)
    return _topics(pipeline.on_batch(run.stamp_ns[s], run.motor_velocity[s],
                                     run.motor_effort[s], run.load_velocity[s],
                                     run.load_effort[s]))


def _on_message(pipeline: EstimatorPipeline, decoder: JointStateDecoder, raw: bytes) -> list:
    """One serialized JointState through the node's decoder, then the pipeline (as the node)."""
    sample = decoder.decode(raw)
    if isinstance(sample, str):
        pipeline.reject_message(sample)
        return []
    stamp, *values = sample
    return _topics(pipeline.on_batch(np.array([stamp], dtype=np.int64),
                                     *(np.array([v]) for v in values)))


def _track(config: EstimatorConfig, run) -> tuple[np.ndarray, ...]:
    """Posterior after each accepted update: t [s], x (n, 2), P (n, 2, 2), NIS."""
    records = []
    pipeline = EstimatorPipeline(config)
    pipeline.on_measurement = lambda m, ok: ok and records.append(
        (m.t, pipeline.filter.x, pipeline.filter.P, pipeline.filter.last.nis))
    _feed(pipeline, run)
    t, x, p, nis = (np.array(v) for v in zip(*records))
    return t, x, p, nis


def test_window_variance_matches_monte_carlo_scatter() -> None:
    zs = []
    for seed in range(4):
        run = lever_plant(seed, 120.0, 0.2)
        records = []
        pipeline = EstimatorPipeline(CONFIG, on_measurement=lambda m, ok: records.append(m))
        _feed(pipeline, run)
        zs += [(m.u - 0.2) / math.sqrt(m.u_variance) for m in records]
    zs = np.array(zs)
    assert len(zs) > 200
    assert abs(zs.mean()) < 0.15 and 0.85 < zs.std() < 1.15


@settings(max_examples=15, deadline=None)
@given(st.lists(st.integers(1, 4000), min_size=1, max_size=8))
def test_results_do_not_depend_on_batch_split(cuts: list[int]) -> None:
    run = lever_plant(7, 30.0, 0.1)
    whole = EstimatorPipeline(CONFIG)
    expected = _feed(whole, run)
    split = EstimatorPipeline(CONFIG)
    bounds = sorted(set([0, run.t.size] + [int(np.cumsum(cuts)[i]) % run.t.size
                                           for i in range(len(cuts))]))
    got = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        got += _feed(split, run, a, b)
    assert [(o.topic, o.stamp_ns) for o in got] == [(o.topic, o.stamp_ns) for o in expected]
    assert np.allclose([o.x for o in got], [o.x for o in expected], rtol=1e-9, atol=1e-12,
                       equal_nan=True)
    assert split.counts == whole.counts


# --- acceptance: simplified-model plant ----------------------------------------------------

def test_simplified_plant_accuracy_coverage_and_consistency() -> None:
    """M independent seeded runs.

    NEES: final posterior of each run, averaged over runs, vs chi2(2M)/M (NEES along one run
    is autocorrelated). NIS: innovations are white, so all post-convergence NIS are pooled,
    vs chi2(K)/K. Accuracy and band coverage after 60 s.
    """
    from scipy.stats import chi2         # here, not at collection: 0.7 s of CPU per worker
    config = CONFIG.replace(process_noise=0.0, adaptive=False)  # matched: constant-u plant
    final_nees, nis, cover = [], [], []
    runs = 16
    for seed in range(runs):
        u_true = 0.05 + 0.01 * seed
        t, x, p, n = _track(config, lever_plant(seed, 120.0, u_true))
        after = t > 60.0
        err = x[after] - np.array([u_true, 0.0])
        assert np.max(np.abs(err[:, 0])) <= 0.02 * u_true
        final_nees.append(err[-1] @ np.linalg.inv(p[after][-1]) @ err[-1])
        nis.append(n[after])
        cover.append(np.abs(err[:, 0]) <= 1.96 * np.sqrt(p[after][:, 0, 0]))
    nis, cover = np.concatenate(nis), np.concatenate(cover)
    assert cover.mean() >= 0.90
    low, high = chi2.ppf([0.025, 0.975], 2 * runs) / runs
    assert low <= np.mean(final_nees) <= high
    k = nis.size
    low, high = chi2.ppf([0.025, 0.975], k) / k
    assert low <= nis.mean() <= high


def test_spur_gear_plant_efficiencies_within_0_01() -> None:
    gear = SpurGear(20, 60, friction=0.08, bearing_radius_1=2e-4, bearing_radius_2=6e-4)
    eta_d, eta_i = gear.efficiencies()
    run = lever_plant(11, 200.0, 0.0, eta_pair=(lambda t: np.full(t.shape, eta_d),
                                                lambda t: np.full(t.shape, eta_i)))
    pipeline = EstimatorPipeline(CONFIG.replace(ratio=float(gear.ratio)))
    out = _feed(pipeline, run)
    summary = pipeline.summary()
    assert abs(summary['eta_opposing'] - eta_d) <= 0.01
    assert abs(summary['eta_aiding'] - eta_i) <= 0.01
    late = [o for o in out if o.topic == interfaces.EFFICIENCY and
            o.stamp_ns > run.stamp_ns[0] + 60e9]
    assert max(abs(o.x - eta_d) for o in late) <= 0.01
    assert max(abs(o.y - eta_i) for o in late) <= 0.01


def test_tracks_wear_ramp_and_detects_step() -> None:
    # the plant wears while it moves (28 % of this duty cycle is dwell): u ramps over its
    # operating time s, the filter's time axis, so it tracks without lag
    ramp = lambda s: 0.1 + 0.1 * np.clip((s - 100.0) / 200.0, 0.0, 1.0)  # noqa: E731
    run = lever_plant(5, 400.0, ramp, wear_clock='operating')
    out = _feed(EstimatorPipeline(CONFIG), run)
    fr = [o for o in out if o.topic == interfaces.FRICTION]
    t = (np.array([o.stamp_ns for o in fr]) - run.stamp_ns[0]) * 1e-9
    s = np.interp(t, run.t, run.operating_time)
    u = np.array([o.x for o in fr])
    during = (s > 140.0) & (s < 300.0)
    lag = np.mean((ramp(s[during]) - u[during]) / (0.1 / 200.0))
    assert abs(lag) < 1.0                                  # seconds of operation
    assert np.max(np.abs(u[during] - ramp(s[during]))) < 0.003

    step = lambda t: np.where(t < 90.0, 0.1, 0.15)  # noqa: E731
    run = lever_plant(5, 150.0, step)
    pipeline = EstimatorPipeline(CONFIG)
    out = _feed(pipeline, run)
    fr = [o for o in out if o.topic == interfaces.FRICTION]
    t = (np.array([o.stamp_ns for o in fr]) - run.stamp_ns[0]) * 1e-9
    u = np.array([o.x for o in fr])
    detected = t[(t >= 90.0) & (np.abs(u - 0.15) < 0.0075)]
    assert detected.size and detected[0] - 90.0 < 8.0
    assert pipeline.counts['reinitialised'] >= 1


def test_filter_runs_on_operating_time_across_a_week_long_gap() -> None:
    """Two recordings of a wearing plant, the second stamped 7 days later (issue 13).

    u after the gap stays within 1 sigma of the same data without the gap (stamp time would
    predict u + 5e-4 1/s * 7 days = u + 302), and the operating time is the moving time only.
    """
    wear = lambda s: 0.1 + 5e-4 * s  # noqa: E731
    run = lever_plant(6, 240.0, wear, wear_clock='operating')
    week_ns = 7 * 86400 * 10**9
    split = int(np.searchsorted(run.t, 121.0))
    stamps = run.stamp_ns.copy()
    stamps[split:] += week_ns
    columns = (run.motor_velocity, run.motor_effort, run.load_velocity, run.load_effort)
    gap, plain = EstimatorPipeline(CONFIG), EstimatorPipeline(CONFIG)
    first = gap.on_batch(stamps[:split], *(c[:split] for c in columns))
    second = gap.on_batch(stamps[split:], *(c[split:] for c in columns))
    plain.on_batch(run.stamp_ns, *columns)
    assert abs(second[0].u - first[-1].u) <= 3.0 * first[-1].u_sigma     # no jump
    assert gap.counts['reinitialised'] == plain.counts['reinitialised']
    sigma = math.sqrt(plain.filter.P[0, 0])
    assert abs(gap.filter.x[0] - plain.filter.x[0]) <= sigma
    assert abs(gap.filter.x[0] - run.u[-1]) <= 3.0 * sigma
    assert abs(gap.filter.x[1] - 5e-4) <= 3.0 * math.sqrt(gap.filter.P[1, 1])
    # the interval across the gap does not count; every other one as without the gap
    across = run.operating_time[split] - run.operating_time[split - 1]
    assert plain.operating_time == pytest.approx(run.operating_time[-1], abs=1e-9)
    assert gap.operating_time == pytest.approx(run.operating_time[-1] - across, abs=1e-5)
    assert gap.operating_time < 0.8 * 240.0                   # the dwells do not count
    # each estimate carries the operating time at its stamp, continuous across the gap
    assert first[-1].operating_time <= second[0].operating_time <= first[-1].operating_time + 0.2
    assert second[-1].operating_time == pytest.approx(gap.operating_time, abs=0.2)
    assert all(b.operating_time >= a.operating_time for a, b in zip(first + second,
                                                                    (first + second)[1:]))


# --- robustness ----------------------------------------------------------------------------

def test_garbage_samples_are_counted_and_do_not_disturb_estimate() -> None:
    run = lever_plant(2, 120.0, 0.1)
    clean = EstimatorPipeline(CONFIG.replace(backwards_policy='skip'))
    _feed(clean, run)
    dirty = EstimatorPipeline(CONFIG.replace(backwards_policy='skip'))
    stamps = run.stamp_ns.copy()
    effort = run.motor_effort.copy()
    effort[5000:5010] = np.nan
    effort[6000] = np.inf
    stamps_bad = stamps.copy()
    stamps_bad[7000:7005] = stamps[100:105]                # stale stamps
    dirty.on_batch(stamps_bad, run.motor_velocity, effort, run.load_velocity,
                   run.load_effort)
    assert dirty.counts['nonfinite'] == 11
    assert dirty.counts['backwards'] == 5
    assert dirty.summary()['u'] == pytest.approx(clean.summary()['u'], abs=3e-4)


def test_backwards_stamps_reset_the_estimator_when_policy_is_reset() -> None:
    run = lever_plant(4, 60.0, 0.1)
    pipeline = EstimatorPipeline(CONFIG)
    _feed(pipeline, run)
    updates = pipeline.filter.updates
    out = _feed(pipeline, run)                         # the bag loops
    assert pipeline.counts['stamp_reset'] == 1
    assert pipeline.filter.updates == updates          # fresh filter, same data
    stamps = [o.stamp_ns for o in out]
    assert stamps == sorted(stamps)


def test_sensor_timeout_is_flagged_publishes_nothing_and_live_equals_offline() -> None:
    """A timeout is a status (WARN, counted once), not an output group.

    The open window is closed by the next sample, as offline, so the outputs equal a run without
    on_silence.
    """
    run = lever_plant(4, 40.0, 0.1)
    pipeline = EstimatorPipeline(CONFIG)
    out = _feed(pipeline, run, 0, 10000)
    assert pipeline.on_silence(0.1) == []
    assert pipeline.on_silence(2.0) == []
    assert pipeline.timed_out and pipeline.counts['timeout'] == 1
    assert pipeline.status('x').level == WARN and 'sensor timeout' in pipeline.status('x').message
    assert pipeline.on_silence(3.0) == []
    assert pipeline.counts['timeout'] == 1
    out += _feed(pipeline, run, 30000, 31000)
    assert not pipeline.timed_out and pipeline.counts['timeout'] == 1
    offline = EstimatorPipeline(CONFIG)
    expected = _feed(offline, run, 0, 10000) + _feed(offline, run, 30000, 31000)
    assert [(o.topic, o.stamp_ns, o.x) for o in out] == \
        [(o.topic, o.stamp_ns, o.x) for o in expected]
    assert offline.counts['timeout'] == 1


def test_one_output_group_per_stamp() -> None:
    """A window closing on a publish-grid sample gives one group, not two with one stamp."""
    run = lever_plant(4, 120.0, 0.1)
    pipeline = EstimatorPipeline(CONFIG)
    out = _feed(pipeline, run)
    stamps = [o.stamp_ns for o in out if o.topic == interfaces.FRICTION]
    assert len(stamps) > 100 and stamps == sorted(set(stamps))


def _cdr(stamp_ns: int, names, velocity, effort) -> bytes:
    """Return a serialized JointState (no positions)."""
    types = TYPESTORE.types
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    msg = types['sensor_msgs/msg/JointState'](
        header=types['std_msgs/msg/Header'](
            stamp=types['builtin_interfaces/msg/Time'](sec=sec, nanosec=nanosec), frame_id=''),
        name=list(names), position=np.zeros(0), velocity=np.array(velocity, dtype=float),
        effort=np.array(effort, dtype=float))
    return bytes(TYPESTORE.serialize_cdr(msg, 'sensor_msgs/msg/JointState'))


def test_single_messages_count_bad_ones_and_match_batch_path() -> None:
    run = lever_plant(8, 12.0, 0.1)
    single = EstimatorPipeline(CONFIG)
    decoder = JointStateDecoder('motor', 'load')
    out = []
    for i in range(run.t.size):
        stamp = int(run.stamp_ns[i])
        out += _on_message(single, decoder, _cdr(stamp, ['load', 'motor'],
                                                 [run.load_velocity[i], run.motor_velocity[i]],
                                                 [run.load_effort[i], run.motor_effort[i]]))
        if i % 1000 == 0:
            good = _cdr(stamp, ['motor', 'load'], [1.0, 1.0], [1.0, 1.0])
            _on_message(single, decoder, _cdr(stamp, ['a', 'b'], [1.0, 1.0], [1, 1]))
            _on_message(single, decoder, _cdr(stamp, [], [], []))
            _on_message(single, decoder, _cdr(stamp, ['motor', 'load'], [1.0], []))
            _on_message(single, decoder, good[:-3])
            _on_message(single, decoder, good[:1] + b'\x00' + good[2:])
    batch = EstimatorPipeline(CONFIG)
    expected = _feed(batch, run)
    assert [(o.topic, o.stamp_ns) for o in out] == [(o.topic, o.stamp_ns) for o in expected]
    assert single.counts['missing_joint'] == 24 and single.counts['short_arrays'] == 12
    assert single.counts['truncated'] == 12 and single.counts['bad_encoding'] == 12
    assert single.samples_rejected == batch.samples_rejected + 60


def test_process_noise_adapts_to_a_wear_rate_jump_and_stays_small_on_slow_wear() -> None:
    """The wear rate of u jumps from 0 to 5e-4 1/s at 200 s of operation.

    q rises by decades and u tracks within 3 sigma soon after; on constant u, q falls below
    1e-13 1/s^3 (prior 1e-11).
    """
    jump = lambda s: 0.1 + 5e-4 * np.clip(s - 200.0, 0.0, None)  # noqa: E731
    run = lever_plant(3, 400.0, jump, wear_clock='operating')
    pipeline = EstimatorPipeline(CONFIG)
    _feed(pipeline, run)
    fr = pipeline.filter
    assert fr.process_noise > 1e-10
    assert abs(fr.x[0] - run.u[-1]) <= 3.0 * math.sqrt(fr.P[0, 0])
    flat = EstimatorPipeline(CONFIG)
    _feed(flat, lever_plant(4, 400.0, 0.1))
    assert flat.filter.process_noise < 1e-13
