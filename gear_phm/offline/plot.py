"""``analysis.png`` of an :class:`~gear_phm.offline.Analysis` (matplotlib, Agg backend)."""
from __future__ import annotations

from collections.abc import Callable, Sequence
import math
from pathlib import Path
from typing import Any

import numpy as np

from gear_phm import interfaces
from gear_phm.models import eta_aiding, eta_opposing
from gear_phm.models.power_flow import AIDING, OPPOSING, SELF_LOCKING
from gear_phm.offline.records import (Analysis, Envelope, ESTIMATES, HEALTH, measurements_key,
                                      NO_LOAD)
from gear_phm.offline.summary import DriveSummary
from gear_phm.prognostics.metrics import ALPHA, true_end_of_life_index
from gear_phm.status import ERROR, LEVEL_NAMES, OK, STALE, WARN

#: Level colours of the timeline strip: OK, WARN, ERROR, STALE.
LEVEL_COLOURS = {OK: '#2ca02c', WARN: '#ff9f1c', ERROR: '#d62728', STALE: '#7f7f7f'}


def true_end_of_life(truth_u: np.ndarray | None, u_eol: float) -> int | None:
    """Stamp [ns] of the true end of life in the truth-friction rows (stamp, u, ...), or None.

    The rule of :func:`gear_phm.prognostics.metrics.true_end_of_life_index`, as
    ``gear-phm evaluate``'s truth bag.
    """
    if truth_u is None or not truth_u.size:
        return None
    index = true_end_of_life_index(truth_u[:, 1], u_eol)
    return None if index is None else int(truth_u[index, 0])


def level_spans(t: np.ndarray, level: np.ndarray) -> list[tuple[float, float, int]]:
    """Return (start [s], end [s], level) of each run of equal levels.

    A run ends where the next starts, the last at the last stamp.
    """
    if t.size == 0:
        return []
    starts = np.concatenate(([0], np.flatnonzero(np.diff(level)) + 1))
    ends = np.concatenate((starts[1:], [t.size - 1]))
    return [(float(t[a]), float(t[b]), int(level[a])) for a, b in zip(starts, ends)]


def plot_analysis(path: Path, analysis: Analysis, ratio: float, bags: Sequence[Path],
                  drive: str = '') -> None:
    """Plot efficiency, u, the RUL and the health level against bag time [s].

    Panels, top to bottom: measured and estimated efficiency; u with its 2-sigma band and
    u_eol; the RUL median with its 5-95 % band (with ground truth: the true RUL, its
    +/- alpha cone, :data:`~gear_phm.prognostics.metrics.ALPHA`, and the true end of life); a
    strip of the health level (the worst of each bin). Drawn from ``analysis.envelopes``: a
    line through each bin's first record and, shaded, each bin's min-max range, so the cost
    is bounded whatever the length of the bags and no excursion is lost. ``drive``: the
    drive's name in the title, for one drive of many.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    e = analysis.envelopes.get(ESTIMATES)
    if e is None or e.stamp_ns.size == 0:
        return
    t0 = int(e.stamp_ns[0])

    def seconds(stamps: np.ndarray) -> np.ndarray:
        return (stamps - t0) * 1e-9

    t = seconds(e.stamp_ns)
    t_end = max(float(t[-1]), float(seconds(analysis.estimates.stamp_ns[-1:]).max(initial=0.0)))
    # a Figure on its own Agg canvas: no pyplot (its import and figure manager cost more
    # than the drawing)
    no_load = analysis.envelopes.get(NO_LOAD)
    shown = no_load is not None and bool(no_load.stamp_ns.size)
    fig = Figure(figsize=(10, 13.5 if shown else 11))
    FigureCanvasAgg(fig)
    axes = fig.subplots(5 if shown else 4, 1, sharex=True, gridspec_kw={
        'height_ratios': [3, 3, 2, 3, 0.5] if shown else [3, 3, 3, 0.5]})
    ax_eta, ax_u, ax_rul, ax_level = axes[0], axes[1], axes[-2], axes[-1]
    if shown and no_load is not None:
        _plot_no_load(axes[2], no_load, analysis, seconds)
    # fixed margins: a layout engine (tight or constrained) measures every text first and
    # cost more than the drawing
    fig.subplots_adjust(left=0.085, right=0.985, top=0.975, bottom=0.045, hspace=0.08)
    # the estimator's own efficiencies (eqs 10/12 at u_hat plus each direction's learned
    # bias), not recomputed from u_hat: on a plant whose directions disagree they differ
    for name, colour, label in (('eta_opposing', 'C0', 'eta_D from u_hat'),
                                ('eta_aiding', 'C1', 'eta_I from u_hat')):
        _band(ax_eta, t, e.low[name], e.high[name], colour)
        ax_eta.plot(t, e.first[name], color=colour, label=label)
    for value, colour, label in ((OPPOSING, 'C0', 'measured eta_D (window)'),
                                 (AIDING, 'C1', 'measured eta_I (window)'),
                                 (SELF_LOCKING, 'C3', 'measured eta_I < 0 (self-locking)')):
        for accepted in (True, False):
            m = analysis.envelopes.get(measurements_key(value, accepted))
            if m is None or not m.stamp_ns.size:
                continue
            spread = m.low['eta'] != m.high['eta']      # a bin's least and greatest
            m_t = seconds(np.concatenate((m.stamp_ns, m.stamp_ns[spread])))
            eta = np.concatenate((m.low['eta'], m.high['eta'][spread]))
            if accepted:
                ax_eta.scatter(m_t, eta, s=8, color=colour, alpha=0.5, label=label)
            else:
                ax_eta.scatter(m_t, eta, s=14, marker='x', color=colour,
                               label=label.replace('measured', 'gated'))
    truth_eta = analysis.envelopes.get(interfaces.TRUTH_EFFICIENCY)
    if truth_eta is not None and truth_eta.stamp_ns.size:
        truth_t = seconds(truth_eta.stamp_ns)
        for axis, style, label in (('x', 'k--', 'true eta_D'), ('y', 'k:', 'true eta_I')):
            _band(ax_eta, truth_t, truth_eta.low[axis], truth_eta.high[axis], 'k')
            ax_eta.plot(truth_t, truth_eta.first[axis], style, lw=1, label=label)
    ax_eta.set_ylabel('efficiency [-]')
    ax_eta.legend(loc='best', fontsize=8)
    ax_eta.grid(alpha=0.3)
    names = ', '.join(Path(b).name for b in bags[:3]) + (' ...' if len(bags) > 3 else '')
    what = f'drive {drive}, ' if drive else ''
    ax_eta.set_title(f'gear-phm analyze {names}  ({what}R = {ratio:g})')
    u = e.first['u']
    ax_u.fill_between(t, e.low['u_low'], e.high['u_high'], color='C2', alpha=0.3, lw=0,
                      label='u_hat +/- 2 sigma')
    _band(ax_u, t, e.low['u'], e.high['u'], 'C2')
    ax_u.plot(t, u, color='C2', label='u_hat')
    truth_u = analysis.envelopes.get(interfaces.TRUTH_FRICTION)
    if truth_u is not None and truth_u.stamp_ns.size:
        _band(ax_u, seconds(truth_u.stamp_ns), truth_u.low['x'], truth_u.high['x'], 'k')
        ax_u.plot(seconds(truth_u.stamp_ns), truth_u.first['x'], 'k--', lw=1, label='true u')
    finite = np.isfinite(u)
    if finite.any():
        lo, hi = np.percentile(u[finite], [1, 99])
        pad = max(0.2 * (hi - lo), 0.01)
        ax_u.set_ylim(lo - pad, hi + pad)
        lo_e = min(eta_opposing(max(hi, 0.0), ratio), eta_aiding(max(hi, 0.0), ratio))
        ax_eta.set_ylim(lo_e - 0.1, 1.02)
    h = analysis.envelopes.get(HEALTH)
    u_eol = float(h.first['u_eol'][-1]) if h is not None and h.stamp_ns.size else math.nan
    if math.isfinite(u_eol):
        ax_u.axhline(u_eol, color='C3', lw=1, ls='-.', label=f'u_eol {u_eol:.4g}')
        if finite.any() and u_eol <= ax_u.get_ylim()[1] * 1.5:
            ax_u.set_ylim(top=max(ax_u.get_ylim()[1], u_eol * 1.05))
    ax_u.set_ylabel('friction parameter u [-]')
    ax_u.legend(loc='best', fontsize=8)
    ax_u.grid(alpha=0.3)
    eol_ns = analysis.true_end_of_life_ns
    if eol_ns is None:                 # an Analysis made without it: from the truth kept
        eol_ns = true_end_of_life(analysis.truth.get(interfaces.TRUTH_FRICTION), u_eol)
    elif not math.isfinite(u_eol):
        eol_ns = None
    if h is not None and h.stamp_ns.size:
        _plot_rul(ax_rul, h, t0, None if eol_ns is None else (eol_ns - t0) * 1e-9, t_end)
        _plot_levels(ax_level, seconds(h.stamp_ns), h.high['level'].astype(int))
    ax_level.set_xlabel('bag time [s]')
    fig.savefig(path, dpi=110, pil_kwargs={'compress_level': 1})


def _plot_no_load(ax: Any, e: Envelope, analysis: Analysis,
                  seconds: Callable[[np.ndarray], np.ndarray]) -> None:
    """No-load torque at the reference speed with its 2-sigma band; the truth when known.

    The truth (``gear_phm/truth/no_load``: y = T_0, z = c_v at the oil's temperature) is
    drawn at the estimate's reference speed, T_0 + c_v w_ref.
    """
    t = seconds(e.stamp_ns)
    speed = _reference_speed(analysis)
    ax.fill_between(t, e.low['no_load_low'], e.high['no_load_high'], color='C5', alpha=0.3,
                    lw=0, label='no-load torque +/- 2 sigma')
    ax.plot(t, e.first['no_load_torque'], color='C5',
            label=f'no-load torque at {speed:.3g} rad/s (estimated)')
    truth = analysis.envelopes.get(interfaces.TRUTH_NO_LOAD)
    if truth is not None and truth.stamp_ns.size and math.isfinite(speed):
        ax.plot(seconds(truth.stamp_ns), truth.first['y'] + truth.first['z'] * speed, 'k--',
                lw=1, label='true no-load torque')
    ax.set_ylabel('no-load torque [N m]')
    ax.legend(loc='best', fontsize=8)
    ax.grid(alpha=0.3)


def _reference_speed(analysis: Analysis) -> float:
    """Return the motor speed at which the no-load torque is reported [rad/s] (NaN if none)."""
    summary = analysis.summary        # a drive's plot: its DriveSummary
    if not isinstance(summary, DriveSummary):
        return math.nan
    return summary.estimator.extra_number('no_load_reference_speed')


def _band(ax: Any, t: np.ndarray, low: np.ndarray, high: np.ndarray, colour: str) -> None:
    """Shade each bin's min-max range (nothing where the bins are single records)."""
    if np.any(low != high):
        ax.fill_between(t, low, high, color=colour, alpha=0.25, lw=0)


def _plot_rul(ax: Any, h: Envelope, t0: int, t_eol: float | None, t_end: float) -> None:
    """RUL median and p5-p95 band [s]; with t_eol [s] the true RUL and its alpha cone.

    Infinite values (no growth detectable) are not drawn; the times with an infinite median
    are shaded. The y range covers the true RUL, or the finite medians.
    """
    t = (h.stamp_ns - t0) * 1e-9
    median, p5, p95 = h.first['rul_median'], h.low['rul_p5'], h.high['rul_p95']
    if t_eol is not None:
        t_true = np.linspace(0.0, t_eol, 200)
        true_rul = t_eol - t_true
        ax.fill_between(t_true, (1 - ALPHA) * true_rul, (1 + ALPHA) * true_rul, color='k',
                        alpha=0.08, label=f'true RUL +/- {ALPHA:g} (alpha cone)')
        ax.plot(t_true, true_rul, 'k--', lw=1, label='true RUL')
        ax.axvline(t_eol, color='C3', lw=1, ls='-.', label=f'true end of life {t_eol:.0f} s')
        top = 1.3 * t_eol
    else:
        finite = median[np.isfinite(median)]
        top = 1.3 * float(np.percentile(finite, 95)) if finite.size else t_end
    top = max(top, 1.0)
    band, shown = np.isfinite(p5), np.isfinite(median).any()
    ax.fill_between(t, np.where(band, p5, np.nan), np.minimum(p95, 10.0 * top), color='C4',
                    alpha=0.3, label='RUL 5-95 %' if band.any() else None)
    ax.plot(t, np.where(np.isfinite(median), median, np.nan), color='C4',
            label='RUL median' if shown else None)
    highest = h.high['rul_median']
    above = np.isfinite(highest) & (highest > top)
    if above.any():
        ax.scatter(t[above], np.full(above.sum(), 0.985 * top), marker='^', s=10, color='C4',
                   label=f'RUL median above {top:.0f} s', clip_on=False)
    unknown = h.high['rul_unknown'] > 0
    spans = [(start, end - start) for start, end, value in level_spans(t, unknown.astype(int))
             if value]
    if spans:                                       # one artist, however many spans
        ax.broken_barh(spans, (0.0, 1.0), transform=ax.get_xaxis_transform(),
                       facecolor='none', edgecolor='C4', hatch='//', lw=0, alpha=0.35,
                       zorder=0, label='RUL inf (no growth detectable)')
    ax.set_ylim(0.0, top)
    ax.set_xlim(right=max(t_end, t_eol or 0.0) * 1.02)
    ax.set_ylabel('remaining useful life [s]')
    ax.legend(loc='upper right', fontsize=8)
    ax.grid(alpha=0.3)


def _plot_levels(ax: Any, t: np.ndarray, level: np.ndarray) -> None:
    """Draw a horizontal strip of the health level over time.

    Each run is labelled with the level and its start [s], shortened to what fits.
    """
    spans = level_spans(t, level)
    ax.broken_barh([(start, end - start) for start, end, _ in spans], (0.0, 1.0),
                   facecolors=[LEVEL_COLOURS.get(value, 'k') for _, _, value in spans], lw=0)
    width = max(float(t[-1] - t[0]), 1e-9) if t.size else 1.0
    for i, (start, end, value) in enumerate(spans):
        # about 140 characters of 8-pt bold fit across the strip: the longest label that fits
        room = 140.0 * (end - start) / width
        name = LEVEL_NAMES.get(value, str(value))
        text = next((x for x in (f' {name} {start:.0f} s ', f' {name} ', f' {name[0]} ')
                     if len(x) <= room), '')
        if not text:
            continue
        last = i == len(spans) - 1 and i > 0          # right-aligned, so it is not cut off
        ax.text(end if last else start, 0.5, text, va='center', ha='right' if last else 'left',
                fontsize=8, color='white', fontweight='bold', clip_on=True)
    ax.set_yticks([])
    ax.set_ylim(0.0, 1.0)
    ax.set_ylabel('level', rotation=0, ha='right', va='center')
