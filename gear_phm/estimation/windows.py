"""Energy windows within one power-flow phase, integrated in batches (vectorised).

A window holds consecutive usable samples of one phase. It closes when the phase changes,
an unusable sample (idle, NaN, ...) or a gap longer than ``max_gap`` [s] interrupts it, or
when the next sample lies ``window`` [s] or more after its first sample. Energies use the
trapezoid rule over the window's samples and remove the kinetic energy of the rotor::

    E_m = int P_m dt - J_m (w_m,end^2 - w_m,start^2) / 2      (likewise E_l with J_l)

so inertia, zero-speed dwell and zero-mean noise do not bias the ratio of the energies. The
variance of E from independent per-sample noise (sigma_tau [N m], sigma_w [rad/s]) is
``sum((w^2 sigma_tau^2 + tau^2 sigma_w^2) dt^2) + J^2 sigma_w^2 (w_start^2 + w_end^2)``.
Batch boundaries do not change the result: the open window is carried between calls.
"""
from __future__ import annotations

from dataclasses import astuple, dataclass, fields
import math
from typing import Any

import numpy as np

from gear_phm.estimation.config import DEFAULTS
from gear_phm.models.lever import reading_with_slope
from gear_phm.models.power_flow import AIDING, OPPOSING, SELF_LOCKING
from gear_phm.persistence import decode_float, encode_float


@dataclass(frozen=True)
class Window:
    """A closed energy window. Times [s], energies [J], variances [J^2].

    ``close_index`` is the index, in the batch that closed it, of the first sample after it
    (0 when the window ended in an earlier batch).
    """

    code: int
    t_start: float
    t_end: float
    samples: int
    motor_energy: float
    load_energy: float
    motor_energy_variance: float
    load_energy_variance: float
    close_index: int
    #: (w_m,end^2 - w_m,start^2) / 2 [rad^2/s^2]: a motor inertia J leaves J times this in
    #: the motor energy (:mod:`gear_phm.estimation.inertia`)
    motor_kinetic: float = 0.0
    #: int |w_m| dt [rad] and int w_m^2 dt [rad^2/s]: a no-load torque T_0 sign(w_m) + c_v w_m
    #: costs T_0 times the first and c_v times the second (:mod:`gear_phm.estimation.no_load`)
    motor_travel: float = 0.0
    motor_travel_square: float = 0.0
    #: sign of w_m over the window (+1 or -1; 0 if unknown)
    motion: int = 0

    @property
    def duration(self) -> float:
        """t_end - t_start [s]."""
        return self.t_end - self.t_start


@dataclass(frozen=True)
class Measurement:
    """Efficiency of one window and the pseudo-measurement of u it gives."""

    t: float
    code: int
    eta: float
    eta_variance: float
    u: float
    u_variance: float


@dataclass
class _Open:
    code: int
    t_start: float
    t_end: float
    samples: int
    w_m_start: float
    w_l_start: float
    w_m_end: float
    w_l_end: float
    e_m: float = 0.0
    e_l: float = 0.0
    v_m: float = 0.0
    v_l: float = 0.0
    a: float = 0.0          # int |w_m| dt
    b: float = 0.0          # int w_m^2 dt


class EnergyIntegrator:
    """Integrates usable samples into windows; ``process`` returns the windows it closed."""

    def __init__(self, window: float, max_gap: float,
                 motor_inertia: float = float(DEFAULTS['motor_inertia']),
                 load_inertia: float = float(DEFAULTS['load_inertia']),
                 noise: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0),
                 min_duration: float = 0.0) -> None:
        self.window = float(window)
        self.max_gap = float(max_gap)
        #: Windows that open and close inside one batch, shorter than this [s] or of one
        #: sample, are not built: they are only counted in ``dropped_short`` (the estimator
        #: would reject them as ``short_window``; noisy phase edges make thousands of them).
        self.min_duration = float(min_duration)
        self.dropped_short = 0
        self._dropped_at: list[np.ndarray] = []     # where those windows closed
        self.motor_inertia = float(motor_inertia)
        self.load_inertia = float(load_inertia)
        # sigma of motor torque, motor speed, load torque, load speed
        self.noise = tuple(float(n) for n in noise)
        self.reset()

    def reset(self) -> None:
        """Forget the open window and the previous sample."""
        self._open: _Open | None = None
        # t, P_m, P_l, code, w_m of the previous sample
        self._last: tuple[float, float, float, int, float] | None = None
        self._last_usable = False

    def to_state(self) -> dict[str, Any]:
        """Return the open window and the previous sample (JSON-safe): a restart continues them."""
        open_ = None if self._open is None else [
            v if isinstance(v, int) else encode_float(v) for v in astuple(self._open)]
        last = None if self._last is None else [
            *(encode_float(v) for v in self._last[:3]), self._last[3],
            encode_float(self._last[4])]
        return {'open': open_, 'last': last, 'last_usable': self._last_usable}

    def from_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`to_state`.

        KeyError/ValueError/TypeError on a malformed dict (the integrator is then unchanged).
        """
        open_, last = state['open'], state['last']
        restored = None
        if open_ is not None:
            # a state written before the travel integrals has two values fewer (0 travel)
            if len(open_) not in (len(fields(_Open)), len(fields(_Open)) - 2):
                raise ValueError(f'open window of {len(open_)} values')
            restored = _Open(int(open_[0]), decode_float(open_[1]), decode_float(open_[2]),
                             int(open_[3]), *(decode_float(v) for v in open_[4:]))
        previous = None if last is None else (
            decode_float(last[0]), decode_float(last[1]), decode_float(last[2]), int(last[3]),
            decode_float(last[4]) if len(last) > 4 else 0.0)
        self._open, self._last = restored, previous
        self._last_usable = bool(state['last_usable'])

    def take_dropped_short(self) -> np.ndarray:
        """Return and reset ``dropped_short``.

        The windows are given as the positions in their batch of the samples that closed them (the
        first after each).
        """
        dropped = np.concatenate(self._dropped_at) if self._dropped_at else np.empty(0, int)
        self._dropped_at, self.dropped_short = [], 0
        return dropped

    def _finish(self, w: _Open, close_index: int) -> Window:
        jm, jl = self.motor_inertia, self.load_inertia
        _, s_wm, _, s_wl = self.noise
        e_m = w.e_m - 0.5 * jm * (w.w_m_end ** 2 - w.w_m_start ** 2)
        e_l = w.e_l - 0.5 * jl * (w.w_l_end ** 2 - w.w_l_start ** 2)
        v_m = w.v_m + (jm * s_wm) ** 2 * (w.w_m_start ** 2 + w.w_m_end ** 2)
        v_l = w.v_l + (jl * s_wl) ** 2 * (w.w_l_start ** 2 + w.w_l_end ** 2)
        return Window(w.code, w.t_start, w.t_end, w.samples, e_m, e_l, v_m, v_l, close_index,
                      0.5 * (w.w_m_end ** 2 - w.w_m_start ** 2), w.a, w.b,
                      1 if w.w_m_start > 0.0 else -1 if w.w_m_start < 0.0 else 0)

    def flush(self, close_index: int = 0) -> list[Window]:
        """Close the open window now (e.g. on a sensor timeout)."""
        if self._open is None:
            return []
        window = self._finish(self._open, close_index)
        self._open = None
        self._last_usable = False
        return [window]

    def process(self, t: np.ndarray, w_m: np.ndarray, tau_m: np.ndarray, w_l: np.ndarray,
                tau_l: np.ndarray, code: np.ndarray, usable: np.ndarray) -> list[Window]:
        """Add one batch (time-ordered); return the windows closed by this batch.

        ``usable`` marks samples of phases 1-3 to integrate; any other sample breaks the current
        window.
        """
        n_raw = len(t)
        if n_raw == 0:
            return []
        idx = np.flatnonzero(usable)
        closed: list[Window] = []
        if idx.size == 0:
            closed += self.flush(0)
            self._last_usable = False
            return closed
        t_c, code_c = t[idx], code[idx]
        wm_c, wl_c = w_m[idx], w_l[idx]
        tm_c, tl_c = tau_m[idx], tau_l[idx]
        p_m, p_l = tm_c * wm_c, -tl_c * wl_c
        if self._last is not None:
            t_prev0, pm_prev0, pl_prev0, code_prev0, wm_prev0 = self._last
        else:
            t_prev0, pm_prev0, pl_prev0, code_prev0, wm_prev0 = -math.inf, 0.0, 0.0, -9, 0.0
        t_prev = np.concatenate(([t_prev0], t_c[:-1]))
        dt = t_c - t_prev
        breaks = np.empty(idx.size, dtype=bool)
        breaks[0] = not (self._last_usable and idx[0] == 0 and code_c[0] == code_prev0)
        breaks[1:] = (np.diff(idx) != 1) | (code_c[1:] != code_c[:-1])
        breaks |= dt > self.max_gap
        dt = np.where(breaks, 0.0, dt)
        pm_prev = np.concatenate(([pm_prev0], p_m[:-1]))
        pl_prev = np.concatenate(([pl_prev0], p_l[:-1]))
        s_tm, s_wm, s_tl, s_wl = self.noise
        dt2 = dt * dt
        c_em = np.concatenate(([0.0], np.cumsum(0.5 * (pm_prev + p_m) * dt)))
        c_el = np.concatenate(([0.0], np.cumsum(0.5 * (pl_prev + p_l) * dt)))
        c_vm = np.concatenate(([0.0], np.cumsum(
            (wm_c * wm_c * s_tm * s_tm + tm_c * tm_c * s_wm * s_wm) * dt2)))
        c_vl = np.concatenate(([0.0], np.cumsum(
            (wl_c * wl_c * s_tl * s_tl + tl_c * tl_c * s_wl * s_wl) * dt2)))
        wm_prev = np.concatenate(([wm_prev0], wm_c[:-1]))
        c_a = np.concatenate(([0.0], np.cumsum(0.5 * (np.abs(wm_prev) + np.abs(wm_c)) * dt)))
        c_b = np.concatenate(([0.0], np.cumsum(0.5 * (wm_prev * wm_prev + wm_c * wm_c) * dt)))
        break_at = np.flatnonzero(breaks)
        n = idx.size
        skippable, resume = self._short_segments(t_c, break_at, n, bool(usable[-1]))
        pos = 0
        while pos < n:
            if self._open is not None and breaks[pos]:
                closed.append(self._finish(self._open, int(idx[pos - 1]) + 1 if pos else 0))
                self._open = None
            if breaks[pos] and skippable.size:
                k = int(np.searchsorted(break_at, pos))
                if skippable[k]:             # a run of short one-window segments
                    nxt = int(resume[k])
                    self.dropped_short += nxt - k
                    ends = np.append(break_at, n)[k + 1:nxt + 1]    # where each one ends
                    self._dropped_at.append(idx[ends - 1] + 1)
                    pos = int(break_at[nxt]) if nxt < break_at.size else n
                    continue
            if self._open is None:
                self._open = _Open(int(code_c[pos]), float(t_c[pos]), float(t_c[pos]), 1,
                                   float(wm_c[pos]), float(wl_c[pos]), float(wm_c[pos]),
                                   float(wl_c[pos]))
                first = pos + 1
            else:
                first = pos
            win = self._open
            k = int(np.searchsorted(break_at, pos, side='right'))
            seg_end = int(break_at[k]) if k < break_at.size else n
            lim = pos + int(np.searchsorted(t_c[pos:seg_end], win.t_start + self.window,
                                            side='left'))
            if lim > pos:
                win.e_m += float(c_em[lim] - c_em[first])
                win.e_l += float(c_el[lim] - c_el[first])
                win.v_m += float(c_vm[lim] - c_vm[first])
                win.v_l += float(c_vl[lim] - c_vl[first])
                win.a += float(c_a[lim] - c_a[first])
                win.b += float(c_b[lim] - c_b[first])
                win.samples += lim - first
                win.t_end = float(t_c[lim - 1])
                win.w_m_end, win.w_l_end = float(wm_c[lim - 1]), float(wl_c[lim - 1])
            if lim < seg_end:       # the sample at lim is one window length after the start
                closed.append(self._finish(win, int(idx[lim - 1]) + 1 if lim else 0))
                self._open = None
            pos = lim
        self._last = (float(t_c[-1]), float(p_m[-1]), float(p_l[-1]), int(code_c[-1]),
                      float(wm_c[-1]))
        self._last_usable = bool(usable[-1])
        if not self._last_usable and self._open is not None:
            closed.append(self._finish(self._open, int(idx[-1]) + 1))
            self._open = None
        return closed

    def _short_segments(self, t_c: np.ndarray, break_at: np.ndarray, n: int,
                        last_usable: bool) -> tuple[np.ndarray, np.ndarray]:
        """Find the segments that are one whole window that is too short.

        For each segment starting at ``break_at[k]``: whether it is one whole window that is too
        short (and closes in this batch), and the index of the next segment that is not. Empty
        arrays when ``min_duration`` is 0.
        """
        if self.min_duration <= 0.0 or break_at.size == 0:
            return np.empty(0, dtype=bool), np.empty(0, dtype=np.int64)
        ends = np.append(break_at[1:], n)
        first, last = t_c[break_at], t_c[ends - 1]
        skippable = (last < first + self.window) \
            & ((last - first < self.min_duration) | (ends - break_at < 2))
        if last_usable:
            skippable[-1] = False           # the last segment stays open for the next batch
        keep = np.append(np.flatnonzero(~skippable), skippable.size)
        resume = keep[np.searchsorted(keep, np.arange(skippable.size))]
        return skippable, resume


def to_measurement(window: Window, ratio: float, min_window: float, min_energy: float,
                   model_sigma: float = 0.0, inertia: tuple[float, float] = (0.0, 0.0),
                   no_load: tuple[float, float] = (0.0, 0.0)) -> Measurement | str:
    """Efficiency and pseudo-measurement of u for ``window``, or the rejection reason.

    ``inertia``: a learned rotor inertia dJ [kg m^2] still in the window's motor energy and
    its variance: E_m - dJ K is used, its variance increased by K^2 var(dJ). ``no_load``: the
    no-load loss energy [J] in the motor energy and its variance [J^2]
    (:mod:`gear_phm.estimation.no_load`), removed likewise.

    Opposing: eta_D = -E_l / E_m, u from eq 13. Aiding and self-locking: eta_I = -E_m / E_l,
    u from eq 13 (aiding). var(eta) to first order from the energy variances; var(u) =
    (du/deta)^2 var(eta) + model_sigma^2. Reasons: ``short_window``, ``low_energy``,
    ``wrong_energy_sign``, ``out_of_domain``.
    """
    if window.duration < min_window or window.samples < 2:
        return 'short_window'
    e_l = window.load_energy
    e_m = window.motor_energy - inertia[0] * window.motor_kinetic - no_load[0]
    if abs(e_m) < min_energy or abs(e_l) < min_energy or e_m == 0.0 or e_l == 0.0:
        return 'low_energy'
    motor_variance = (window.motor_energy_variance + window.motor_kinetic ** 2 * inertia[1]
                      + no_load[1])
    rel_var = motor_variance / e_m ** 2 + window.load_energy_variance / e_l ** 2
    if window.code == OPPOSING:
        if not (e_m > 0.0 > e_l):
            return 'wrong_energy_sign'
        eta = -e_l / e_m
        u, slope = reading_with_slope(eta, ratio, aiding=False)
    elif window.code in (AIDING, SELF_LOCKING):
        if not e_l > 0.0 or (window.code == AIDING and e_m > 0.0):
            return 'wrong_energy_sign'
        eta = -e_m / e_l
        u, slope = reading_with_slope(eta, ratio, aiding=True)
    else:
        raise ValueError(f'window.code must be 1, 2 or 3, got {window.code!r}')
    if not (math.isfinite(u) and math.isfinite(slope)):
        return 'out_of_domain'
    eta_variance = eta * eta * rel_var
    u_variance = slope * slope * eta_variance + model_sigma * model_sigma
    if not u_variance > 0.0:
        u_variance = 1e-18
    return Measurement(window.t_end, window.code, float(eta), float(eta_variance), float(u),
                       float(u_variance))
