"""Estimator core: power flow, energy windows, Kalman filter, pipeline (pure, seeded)."""
from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from gear_phm import interfaces
from gear_phm.bagio import TYPESTORE
from gear_phm.codec import JointStateDecoder
from gear_phm.estimation import (classify, EnergyIntegrator, EstimatorConfig, EstimatorPipeline,
                                 FrictionFilter, to_measurement)
from gear_phm.models import eta_aiding, eta_opposing, SpurGear
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


# --- power flow --------------------------------------------------------------------------------

def test_classify_codes_and_deadband() -> None:
    p_m = np.array([10.0, -10.0, 10.0, -10.0, 0.05, 10.0, 10.0])
    p_l = np.array([-9.0, 9.0, 1.0, -1.0, -0.05, -9.0, 0.0])
    w_m = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 1.0])
    codes = classify(p_m, p_l, w_m, power_threshold=0.1, speed_threshold=0.01)
    assert codes.tolist() == [1, 2, 3, -1, 0, 0, 0]


@given(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3), st.floats(0.0, 10.0))
def test_classify_is_symmetric_in_sign_of_both_powers_only(p_m: float, p_l: float,
                                                           thr: float) -> None:
    code = int(classify(p_m, p_l, 1.0, power_threshold=thr))
    if abs(p_m) <= thr or abs(p_l) <= thr:
        assert code == 0
    else:
        assert code == {(1, -1): 1, (-1, 1): 2, (1, 1): 3, (-1, -1): -1}[
            (int(np.sign(p_m)), int(np.sign(p_l)))]


# --- windows -------------------------------------------------------------------------------

def test_energy_window_removes_rotor_inertia_bias() -> None:
    run = lever_plant(3, 60.0, 0.1, noise=(0, 0, 0, 0), motor_inertia=0.05)
    code = classify(run.motor_effort * run.motor_velocity,
                    -run.load_effort * run.load_velocity, run.motor_velocity, 0.01, 0.01)
    results = {}
    for inertia in (0.0, 0.05):
        integ = EnergyIntegrator(1.0, 0.5, motor_inertia=inertia)
        windows = integ.process(run.t, run.motor_velocity, run.motor_effort, run.load_velocity,
                                run.load_effort, code, code > 0)
        meas = [to_measurement(w, 3.0, 0.2, 0.01, 1e-6) for w in windows]
        results[inertia] = np.array([m.u for m in meas if not isinstance(m, str)])
    assert np.max(np.abs(results[0.05] - 0.1)) < 2e-4
    assert np.max(np.abs(results[0.0] - 0.1)) > 5e-3      # uncorrected: biased per window


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 2**32 - 1), st.lists(st.integers(1, 400), min_size=1, max_size=6),
       st.sampled_from([0.005, 0.02, 0.2]))
def test_dropping_short_windows_early_equals_rejecting_them_later(
        seed: int, cuts: list[int], min_duration: float) -> None:
    """The integrator's shortcut (short one-segment windows are only counted) is exact.

    It gives the same windows and counts as building every window and rejecting the short ones
    afterwards, for any batch split. Phases flicker, with gaps, so most segments are short.
    """
    rng = np.random.default_rng(seed)
    n = 1200
    t = np.cumsum(rng.choice([0.001, 0.001, 0.001, 0.02], n))
    code = rng.choice([-1, 0, 1, 1, 1, 2, 2, 3], n)
    code = np.where(rng.random(n) < 0.9, np.repeat(code[::7], 7)[:n], code)
    w_m, w_l = rng.normal(5.0, 1.0, n), rng.normal(-1.5, 0.5, n)
    tau_m, tau_l = rng.normal(1.0, 0.2, n), rng.normal(2.5, 0.2, n)
    bounds = sorted({0, n, *[int(c) % n for c in np.cumsum(cuts)]})

    def windows(integrator: EnergyIntegrator) -> list:
        out = []
        for a, b in zip(bounds[:-1], bounds[1:]):
            out += [(w.code, w.t_start, w.t_end, w.samples, w.motor_energy, w.load_energy)
                    for w in integrator.process(t[a:b], w_m[a:b], tau_m[a:b], w_l[a:b],
                                                tau_l[a:b], code[a:b], code[a:b] > 0)]
        return out + [(w.code, w.t_start, w.t_end, w.samples, w.motor_energy, w.load_energy)
                      for w in integrator.flush()]

    every = windows(EnergyIntegrator(0.1, 0.015))
    fast = EnergyIntegrator(0.1, 0.015, min_duration=min_duration)
    kept = windows(fast)

    def short(w: tuple) -> bool:
        return w[2] - w[1] < min_duration or w[3] < 2
    assert fast.dropped_short > 0
    assert [w for w in kept if not short(w)] == [w for w in every if not short(w)]
    assert fast.dropped_short + sum(map(short, kept)) == sum(map(short, every))


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


# --- Kalman filter -------------------------------------------------------------------------

def test_filter_gates_outlier_and_reinitialises_after_repeated_rejections() -> None:
    kf = FrictionFilter(0.1, 0.01, 1e-4, 0.0, gate_threshold=10.83, max_consecutive_gated=3)
    assert kf.update(0.1, 1e-6, 1.0).accepted
    outlier = kf.update(0.2, 1e-6, 2.0)
    assert not outlier.accepted and outlier.nis > 10.83
    assert not kf.update(0.2, 1e-6, 3.0).accepted
    third = kf.update(0.2, 1e-6, 4.0)
    assert third.accepted and third.reinitialised and kf.x[0] == pytest.approx(0.2)


def test_filter_predict_covariance_grows_with_process_noise() -> None:
    kf = FrictionFilter(0.1, 0.01, 1e-3, 1e-6, 10.83, 3)
    kf.predict(0.0)
    x, p = kf.predicted(10.0)
    assert p[0, 0] > kf.P[0, 0] and kf.t == 0.0          # predicted() does not mutate
    kf.predict(10.0)
    assert np.allclose(kf.P, p) and np.allclose(kf.x, x)


def test_predicted_many_is_bit_identical_to_predicted_one_by_one() -> None:
    rng = np.random.default_rng(7)
    for q in (0.0, 1e-12, 3e-7):
        kf = FrictionFilter(0.1, 0.01, 1e-3, q, 10.83, 3)
        times = np.concatenate(([-3.0, 20.0], rng.uniform(-5.0, 500.0, size=38)))
        x, p = kf.predicted_many(times)             # before any update: the prior
        assert np.array_equal(x, np.tile(kf.x, (40, 1)))
        kf.update(0.12, 1e-5, 20.0)
        kf.kf.x[1, 0] = 1e-5                        # a rate, so that dt matters
        x, p = kf.predicted_many(times)
        assert x.shape == (40, 2) and p.shape == (40, 2, 2)
        for k, t in enumerate(times):               # also at or before the filter's time
            x_k, p_k = kf.predicted(float(t))
            assert np.array_equal(x[k], x_k) and np.array_equal(p[k], p_k)
        assert x[times > 20.0, 0].min() > kf.x[0] and np.array_equal(x[1], kf.x)


@settings(max_examples=200, deadline=None)
@given(st.floats(1e-6, 1e3), st.floats(1e-15, 1e2))
def test_process_covariance_is_filterpys_continuous_white_noise(dt: float, q: float) -> None:
    from filterpy.common import Q_continuous_white_noise

    from gear_phm.estimation.kalman import process_covariance
    np.testing.assert_allclose(process_covariance(dt, q),
                               Q_continuous_white_noise(dim=2, dt=dt, spectral_density=q),
                               rtol=1e-12, atol=0.0)
    assert not process_covariance(0.0, q).any() and not process_covariance(dt, 0.0).any()


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


def test_config_validation_names_field_and_value() -> None:
    with pytest.raises(ValueError, match=r'min_window must be < window .* got 2\.0'):
        EstimatorConfig(window=1.0, min_window=2.0)
    with pytest.raises(ValueError, match=r'ratio must be in .* got -1\.0'):
        EstimatorConfig(ratio=-1.0)
    with pytest.raises(ValueError, match='backwards_policy'):
        EstimatorConfig(backwards_policy='loop')
    with pytest.raises(ValueError, match='unknown'):
        CONFIG.replace(windw=2.0)
    assert eta_opposing(0.0, 3.0) == 1.0 and eta_aiding(0.0, 3.0) == 1.0


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
