"""RUL from the whole posterior history: wear-law choice by AICc, early finite RUL, memory."""
from __future__ import annotations

from collections.abc import Callable
import math

import numpy as np
import pytest

from gear_phm.prognostics.changepoint import rise, rise_sigma
from gear_phm.prognostics.fits import (crossing_offsets, crossing_slopes, fit_laws, fit_trend,
                                       Trend)
from gear_phm.prognostics.history import WearHistory
from gear_phm.prognostics.predictor import RulPredictor
from gear_phm.simulation.wear import Wear

LIFE, U0, U_EOL = 3000.0, 0.05, 0.6
SIGMA = 2e-3                                  # noise of the synthetic u histories [-]


#: 'offset': u = c + a exp(k t) with a = OFFSET_A (the simulator's exponential has c = 0)
OFFSET_A = 0.01


def _offset_k() -> float:
    """Return k [1/s] of the 'offset' law: c + a exp(k LIFE) = U_EOL with c = U0 - a."""
    return math.log((U_EOL - U0 + OFFSET_A) / OFFSET_A) / LIFE


def _law(kind: str) -> Callable[[np.ndarray], np.ndarray]:
    """u(t) going from U0 to U_EOL in LIFE seconds (power: exponent 3)."""
    if kind == 'offset':
        return lambda t: U0 - OFFSET_A + OFFSET_A * np.exp(_offset_k() * np.asarray(t))
    wear = Wear.reaching(kind, U0, U_EOL, LIFE, exponent=3.0)
    assert wear.value(LIFE) == pytest.approx(U_EOL)
    return wear.value


def _feed(predictor: RulPredictor, kind: str, until: float, seed: int,
          step: float = 1.0) -> float:
    """Noisy u history of ``kind`` from 0 to ``until`` [s]; returns the last time."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, until, step)
    u = _law(kind)(t) + SIGMA * rng.standard_normal(t.size)
    for ti, ui in zip(t.tolist(), u.tolist()):
        predictor.add(ti, ui, SIGMA ** 2)
    return float(t[-1])


#: The law each kind of history should be fitted with: the simulator's exponential wear,
#: u0 exp(k t), is the proportional law; the exponential law has an offset.
FITTED = {'linear': 'linear', 'exponential': 'proportional', 'offset': 'exponential',
          'power': 'power'}


@pytest.mark.parametrize('kind', ['linear', 'exponential', 'offset', 'power'])
@pytest.mark.parametrize('seed', [0, 1, 2])
def test_aicc_picks_the_wear_law(kind: str, seed: int) -> None:
    predictor = RulPredictor(U_EOL)
    t_now = _feed(predictor, kind, 0.5 * LIFE, seed)
    trend = predictor.trend
    assert trend.model == FITTED[kind]
    # the line nests in the exponential and power laws, the proportional in the exponential
    assert trend.weight > (0.5 if kind in ('linear', 'exponential') else 0.9)
    if kind == 'exponential':
        assert trend.shape == pytest.approx(math.log(U_EOL / U0) / LIFE, rel=0.1)
    if kind == 'offset':
        assert trend.shape == pytest.approx(_offset_k(), rel=0.1)
    if kind == 'power':
        assert trend.shape == pytest.approx(3.0, rel=0.1)
    true_rul = LIFE - t_now
    rul = predictor.predict(t_now, float(_law(kind)(t_now)))
    assert rul.p5 <= true_rul <= rul.p95
    assert rul.median == pytest.approx(true_rul, rel=0.06)


@pytest.mark.parametrize('kind', ['linear', 'exponential', 'power'])
@pytest.mark.parametrize('seed', [0, 1, 2])
def test_rul_finite_at_a_quarter_of_life_with_a_band_holding_the_truth(kind: str,
                                                                       seed: int) -> None:
    predictor = RulPredictor(U_EOL)
    t_now = _feed(predictor, kind, 0.25 * LIFE, seed)
    rul = predictor.predict(t_now, float(_law(kind)(t_now)))
    true_rul = LIFE - t_now
    assert math.isfinite(rul.median) and math.isfinite(rul.p95)
    assert rul.p5 <= true_rul <= rul.p95, (rul, true_rul)
    # an honest band, not an arbitrarily wide one
    assert rul.p95 < 3.0 * true_rul and rul.p5 > 0.25 * true_rul


@pytest.mark.parametrize('seed', [0, 1, 2])
def test_rul_inf_on_a_flat_history(seed: int) -> None:
    predictor = RulPredictor(U_EOL)
    rng = np.random.default_rng(seed)
    for t in np.arange(0.0, 1500.0, 1.0):
        predictor.add(float(t), U0 + SIGMA * rng.standard_normal(), SIGMA ** 2)
    rul = predictor.predict(1499.0, U0)
    assert (rul.median, rul.p5, rul.p95, rul.model) == (math.inf, math.inf, math.inf, 'none')
    assert predictor.trend.model != 'none'              # fitted, but no significant growth
    assert not predictor.trend.slope > 2.0 * predictor.trend.slope_sigma


def test_growth_becomes_detectable_and_the_threshold_is_detect_z() -> None:
    """Finite exactly when both the slope and the rise are significant.

    The fitted slope exceeds detect_z sigma_r and the rise exceeds detect_z times the filter's
    uncertainty of that rise.
    """
    for detect_z in (2.0, 50.0):
        predictor = RulPredictor(U_EOL, detect_z=detect_z)
        t_now = _feed(predictor, 'linear', 300.0, 0)
        trend, rul = predictor.trend, predictor.predict(t_now, U0)
        t, u, precision = predictor.history.arrays()
        significant = trend.slope > detect_z * trend.slope_sigma \
            and rise(trend, t, u, precision) > detect_z * rise_sigma(t, precision)
        assert math.isfinite(rul.median) == significant
    assert math.isfinite(RulPredictor(U_EOL, detect_z=2.0).predict(0.0, U0).median) is False


def test_a_rise_within_the_filters_own_sigma_is_not_growth() -> None:
    """Keep the RUL inf for a climb within the filter's own sigma.

    A short history climbs by 1.5 filter sigmas, with no scatter around the climb: the fit's
    slope is significant (many smooth points), the rise is not, so the RUL stays inf; the same
    climb with a 10x more certain filter is growth.
    """
    t = np.arange(0.0, 15.0, 0.1)
    for sigma, finite in ((2e-3, False), (2e-4, True)):
        predictor = RulPredictor(U_EOL)
        for ti in t.tolist():
            predictor.add(ti, U0 + 1.5 * 2e-3 * ti / 15.0, sigma ** 2)
        trend = predictor.trend
        assert trend.slope > 2.0 * trend.slope_sigma
        assert math.isfinite(predictor.predict(15.0, U0).median) is finite


def test_memory_and_refits_bounded_on_a_long_fast_history() -> None:
    """Feed 1 kHz posteriors for 400 s: memory and refits stay bounded.

    At most max_points bins, a bounded number of fits, and between fits the RUL moves with time
    exactly.
    """
    predictor = RulPredictor(U_EOL, max_points=256)
    rate = (U_EOL - U0) / 800.0
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 400.0, 1e-3)
    u = U0 + rate * t + 1e-3 * rng.standard_normal(t.size)
    for ti, ui in zip(t.tolist(), u.tolist()):
        predictor.add(ti, ui, 1e-6)
    assert len(predictor.history) <= 256
    assert len(predictor.history._w) == 256
    first = predictor.predict(400.0, 0.3)
    assert predictor.fits < 150
    assert first.median == pytest.approx(400.0, rel=0.02)
    later = predictor.predict(410.0, 0.3)                  # no new data: same fit
    assert later.median == pytest.approx(first.median - 10.0)
    assert predictor.predict(410.0, U_EOL).median == 0.0   # the filter says worn


def test_history_bins_merge_evenly_and_restart_when_time_goes_back() -> None:
    history = WearHistory(max_points=8, initial_width=1.0)
    for t in range(20):
        history.add(float(t), 0.1 + 0.01 * t, 1e-4)
    t_mean, u_mean, precision = history.arrays()
    assert history.width == 4.0 and len(history) == 5
    assert t_mean.tolist() == pytest.approx([1.5, 5.5, 9.5, 13.5, 17.5])
    assert u_mean == pytest.approx(0.1 + 0.01 * t_mean)
    assert precision == pytest.approx(np.full(5, 1e4))     # mean, not summed, precision
    history.add(3.0, 0.2, 1e-4)
    assert len(history) == 1 and history.t_start == 3.0


@pytest.mark.parametrize('model, shape', [('linear', 0.0), ('exponential', 2e-3),
                                          ('exponential', -1e-3), ('power', 3.0),
                                          ('power', 0.5)])
def test_crossing_offsets_solve_the_law(model: str, shape: float) -> None:
    span, u_end, rate, gap = 500.0, 0.1, 1e-4, 0.05
    s = crossing_offsets(model, np.array([gap]), np.array([rate]), np.array([shape]),
                         span)[0]
    if model == 'exponential' and shape < 0.0:       # saturates at u_end + rate/|k| = 0.2
        assert s == pytest.approx(math.log1p(shape * gap / rate) / shape)
    assert math.isfinite(s) and s > 0.0
    if model == 'linear':
        g = s
    elif model == 'exponential':
        g = math.expm1(shape * s) / shape
    else:
        g = span / shape * (((span + s) / span) ** shape - 1.0)
    assert u_end + rate * g == pytest.approx(u_end + gap, rel=1e-9)
    never = crossing_offsets(model, np.array([gap, -0.01]), np.array([-rate, rate]),
                             np.array([shape, shape]), span)
    assert never[0] == math.inf and never[1] == -math.inf
    saturating = crossing_offsets('exponential', np.array([0.5]), np.array([rate]),
                                  np.array([-1e-3]), span)
    assert saturating[0] == math.inf                  # u_end + rate/|k| = 0.2 < 0.6


def test_rul_deterministic_and_trend_choice_fixed() -> None:
    first, second = RulPredictor(U_EOL, seed=4), RulPredictor(U_EOL, seed=4)
    t_now = _feed(first, 'exponential', 1500.0, 3)
    _feed(second, 'exponential', 1500.0, 3)
    assert first.predict(t_now, 0.2) == second.predict(t_now, 0.2)
    forced = RulPredictor(U_EOL, trend='linear')
    _feed(forced, 'exponential', 1500.0, 3)
    assert forced.trend.model == 'linear'
    with pytest.raises(ValueError, match='trend'):
        RulPredictor(U_EOL, trend='quadratic')
    t = np.arange(5.0)
    assert fit_trend(t, t, np.ones(5)) == Trend(points=5)       # too few points


def test_detection_has_hysteresis() -> None:
    """Keep growth that was seen while the evidence stays above half the threshold.

    Evidence between half the threshold and the threshold: no growth for a predictor that has
    not seen any, still growth for one that has (no finite/inf toggling).
    """
    sigma, slope = 2e-3, 2.5 * 2e-3 / 15.0        # climbs 2.5 filter sigmas in 15 s
    predictors = [RulPredictor(U_EOL), RulPredictor(U_EOL)]
    for ti in np.arange(0.0, 15.0, 0.1).tolist():
        for predictor in predictors:
            predictor.add(ti, U0 + slope * ti, sigma ** 2)
    assert [(p.trend, p.detected)[1] for p in predictors] == [False, False]
    state = predictors[1].to_state()
    state['detected'] = True                       # as if growth had been seen earlier
    predictors[1].from_state(state)
    for ti in np.arange(15.0, 17.0, 0.1).tolist():
        for predictor in predictors:
            predictor.add(ti, U0 + slope * ti, sigma ** 2)
    ruls = [p.predict(17.0, U0 + slope * 17.0) for p in predictors]
    assert predictors[0].fits == predictors[1].fits > 1      # both refitted on the new points
    assert math.isinf(ruls[0].median) and math.isfinite(ruls[1].median)
    assert predictors[1].detected and not predictors[0].detected


@pytest.mark.parametrize('seed', [0, 1, 2])
def test_a_settling_start_is_not_extrapolated_as_an_asymptote(seed: int) -> None:
    """The first 30 s of a filter's history: a fast rise while it settles, then slow wear.

    Shaped after the 300 s exponential matrix run, seed 1 (2026-11-25). Before P_FLOOR the
    power law fitted p = 0.25 (the grid's edge) with weight 1 and extrapolated an
    asymptote: RULs of 1e4-1e6 s, a WARN -> OK -> WARN. Wear laws now only accelerate.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(0.1, 30.0, 0.1)
    u = (0.05 + 0.008 * (1.0 - np.exp(-t / 6.0)) + 1.5e-4 * t
         + 3e-4 * rng.standard_normal(t.size))
    predictor = RulPredictor(U_EOL)
    for ti, ui in zip(t.tolist(), u.tolist()):
        predictor.add(ti, ui, 2e-6)
    trend = predictor.trend
    assert trend.model == 'linear' or trend.shape >= 1.0, trend
    rul = predictor.predict(float(t[-1]), float(u[-1]))
    slope_rul = (U_EOL - float(u[-1])) / 1.5e-4            # the late slope's RUL, 3.6e3 s
    assert math.isfinite(rul.median)
    assert rul.median < 1.5 * slope_rul, rul


@pytest.mark.parametrize('model, shape', [('linear', 0.0), ('exponential', 2e-3),
                                          ('power', 3.0)])
def test_crossing_slopes_are_the_laws_derivative(model: str, shape: float) -> None:
    span, rate, gap = 500.0, 1e-4, 0.05
    s = crossing_offsets(model, np.array([gap]), np.array([rate]), np.array([shape]), span)
    slope = crossing_slopes(model, s, np.array([rate]), np.array([shape]), span)[0]
    h = 1e-3 * float(s[0])
    ahead = crossing_offsets(model, np.array([gap]), np.array([rate]), np.array([shape]),
                             span)
    # du/dt at the crossing, by the inverse: d(offset)/d(gap) = 1 / (du/dt)
    nearby = crossing_offsets(model, np.array([gap + slope * h]), np.array([rate]),
                              np.array([shape]), span)
    assert float(nearby[0] - ahead[0]) == pytest.approx(h, rel=1e-3)
    edge = crossing_slopes(model, np.array([math.inf, -math.inf]), np.array([rate, rate]),
                           np.array([shape, shape]), span)
    assert edge.tolist() == [math.inf, math.inf]          # no shift of a crossing not there


def _band(predictor: RulPredictor, step: float, seed: int) -> tuple[float, float, float]:
    """RUL (median, width p95 - p5, truth) after half of a linear life sampled every step."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 0.5 * LIFE, step)
    u = _law('linear')(t) + 1e-4 * rng.standard_normal(t.size)
    for ti, ui in zip(t.tolist(), u.tolist()):
        predictor.add(ti, ui, 1e-8, independent=True)
    rul = predictor.predict(float(t[-1]), float(u[-1]))
    return rul.median, rul.p95 - rul.p5, LIFE - float(t[-1])


def test_the_band_holds_the_history_resolution_and_the_systematic_uncertainty() -> None:
    """Two terms no fit residual shows widen the band (calibration.py).

    - Resolution: wear between two points is unseen, so the crossing is uniform within one
      spacing: p95 - p5 >= 0.9 spacing even on an almost noiseless line.
    - Systematic: u known to +/- u_systematic at end of life (a calibration that does not
      average out) moves the crossing by u_systematic / (du/dt), normal: about
      2 x 1.645 x that wider.
    """
    slope = (U_EOL - U0) / LIFE                     # du/dt of the linear life [1/s]
    # the two terms alone: without the history's own forecast errors (calibration.py), which
    # widen even this band of a second by their few 1e-4 (test_predictor_regimes.py for those)
    for step in (1.0, 4.0):
        median, width, truth = _band(RulPredictor(U_EOL, calibrated=False), step, 0)
        assert 0.9 * step <= width <= 1.2 * step, (step, width)
        assert median == pytest.approx(truth, abs=0.5 * step + 0.2)
    narrow = _band(RulPredictor(U_EOL, calibrated=False), 1.0, 0)[1]
    for u_systematic in (1e-3, 4e-3):
        median, width, truth = _band(RulPredictor(U_EOL, u_systematic=u_systematic,
                                                  calibrated=False), 1.0, 0)
        sigma = u_systematic / slope
        assert width == pytest.approx(math.hypot(2 * 1.645 * sigma, narrow), rel=0.1)
        assert abs(median - truth) < 0.2 * sigma
    with pytest.raises(ValueError, match='u_systematic'):
        RulPredictor(U_EOL, u_systematic=-1.0)


def test_a_law_extrapolates_only_once_its_own_slope_is_significant() -> None:
    """Early power-law wear: the line's slope is significant, the curved laws' are not.

    A curved law's slope now is uncertain with its shape. Measured (power wear, 30 000 s life,
    0.114 of it): an exponential with k = 0.0032/s and a power law with p = 8.8 (their slopes
    at 1.2 sigma) put the RUL median at 2700 s against a true 23 000 s, a false WARN. Such a
    law stays out of the RUL until its slope passes detect_z; the RUL is the line's and the
    proportional law's meanwhile (two parameters each: their curvature is not free).
    """
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 0.3 * LIFE, 2.0)
    u = _law('power')(t) + SIGMA * rng.standard_normal(t.size)
    early = t < 0.15 * LIFE
    fitted = {law.model: law.slope / law.slope_sigma
              for law in fit_laws(t[early], u[early], np.full(early.sum(), SIGMA ** -2))}
    assert fitted['linear'] > 2.0 and max(fitted['power'], fitted['exponential']) < 2.0
    # the rule on one whole history: the change point (changepoint.regime_start) would start
    # this power law from 0 later, where the proportional law fits it as well
    predictor = RulPredictor(U_EOL, regimes=False)
    models = []
    for ti, ui in zip(t.tolist(), u.tolist()):
        predictor.add(ti, ui, SIGMA ** 2, independent=True)
        rul = predictor.predict(ti, ui)
        if math.isfinite(rul.median):
            models.append((ti, predictor.trend.model, rul.median))
    at = {ti: (model, median) for ti, model, median in models}
    model, median = at[float(t[early][-1])]
    assert model in ('linear', 'proportional')                 # the free-shape laws are out
    assert median > 0.5 * (LIFE - float(t[early][-1]))          # no early end of life
    assert models[-1][1] == 'power'                             # ... until their slope is in
    first_curved = next(ti for ti, model, _ in models if model in ('exponential', 'power'))
    assert 0.15 * LIFE < first_curved < 0.3 * LIFE


def test_before_min_points_growth_needs_evidence_in_proportion() -> None:
    """Below DETECT_MIN_POINTS effective points, growth needs detect_z * that / n_eff sigma.

    A steep rise (a 300 s life at windows 1 s apart) is plain at 16 points: the RUL is finite
    there (a hard minimum of 24 points kept it inf for the first 0.1 of the life). A marginal
    one, at 2.6 sigma on both tests at 16 points, is not yet growth; it is once it goes on.
    """
    t = np.arange(16.0)
    precision = np.full(t.size, SIGMA ** -2)
    histories = {}
    for name, slope, seed in (('steep', 0.0018, 0), ('marginal', 0.00035, 1)):
        rng = np.random.default_rng(seed)
        histories[name] = U0 + slope * t + SIGMA * rng.standard_normal(t.size)
    marginal = fit_laws(t, histories['marginal'], precision)[0]
    z_rise = rise(marginal, t, histories['marginal'], precision) / rise_sigma(
        t, precision, True, marginal.scale)
    assert marginal.effective_points == pytest.approx(16.0)
    assert 2.0 < z_rise < 3.0 and 2.0 < marginal.slope / marginal.slope_sigma < 3.0
    for name, expected in (('steep', True), ('marginal', False)):
        predictor = RulPredictor(U_EOL)
        for ti, ui in zip(t.tolist(), histories[name].tolist()):
            predictor.add(ti, ui, SIGMA ** 2, independent=True)
        rul = predictor.predict(15.0, float(histories[name][-1]))
        assert math.isfinite(rul.median) is expected, (name, rul)
        if name == 'steep':
            assert rul.p5 <= (U_EOL - U0) / 0.0018 - 15.0 <= rul.p95
    rng = np.random.default_rng(1)
    longer = np.arange(48.0)
    u = U0 + 0.00035 * longer + SIGMA * rng.standard_normal(longer.size)
    predictor = RulPredictor(U_EOL)
    for ti, ui in zip(longer.tolist(), u.tolist()):
        predictor.add(ti, ui, SIGMA ** 2, independent=True)
    assert math.isfinite(predictor.predict(47.0, float(u[-1])).median)
