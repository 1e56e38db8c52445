"""Rotor inertia left in the windows' motor energy, learned from the windows (no ROS imports).

A motor torque that includes the rotor's J_m dw_m/dt (an electromagnetic torque does) leaves
dJ K in each window's motor energy, K = (w_m,end^2 - w_m,start^2) / 2 [rad^2/s^2], where dJ
is the part of J_m that ``motor_inertia`` does not remove. At a high ratio the motor turns R
times faster than the load and that term grows as R^2: on a spur plant at R = 30 with
J_m = 2e-3 kg m^2 left at 0 it biased eta_D by +0.0011 and doubled the windows' scatter
(docs/estimation.md).

Per power-flow direction, the windows are taken in blocks of ``BLOCK`` in a row. Within a
block the gearbox's gain g (E_m = g L + dJ K, L = -E_l; g = 1 / eta_D opposing, eta_I aiding)
is a nuisance that may drift linearly with time, so each block is a weighted least-squares
fit of

    E_m = g0 L + g1 L tau + dJ K          (tau: time since the block's first window [s])

No efficiency from the filter enters: a first version regressed on the filter's gain, and
on fast-wearing 300 s lever lives its lag correlated with K through L and made dJ 7-9x too
large; eliminating g between two windows (a ratio of noisy energies) was worse still. The
blocks' dJ are combined with their precisions (their variances scaled by each block's reduced
chi-square, at least 1). dJ is applied once ``MIN_BLOCKS`` blocks put it at
``INERTIA_Z`` sigma, and never below -motor_inertia (an inertia is not negative).

Until then the inertia is in the windows unremoved, and :meth:`InertiaLearner.left_variance`
tells the measurement model how much: the mean square of what the correction leaves,
from the blocks or, before ``MIN_BLOCKS`` blocks, from
a provisional fit of each open block of at least ``PROVISIONAL`` windows; before any fit, the
prior that the rotor's kinetic energy at the largest |K| seen could be as large as the
window's motor energy. Without it a window that accelerates or decelerates the rotor was
taken as precise while it read u biased by dJ K: at R 50 and 4 kHz the windows at the start of
a stroke read u +0.003..+0.03 and those at its end -0.03, for the ~200 s before dJ was
applied, which the filter saw as a model mismatch (docs/estimation.md, "Rotor inertia in the
measurement variance").
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from gear_phm.estimation.config import DEFAULTS
from gear_phm.persistence import decode_float, decode_floats, encode_float, encode_floats

#: Windows of one direction in a block.
BLOCK = 40
#: Blocks before dJ is applied.
MIN_BLOCKS = 2
#: Significance of dJ before it is applied [sigma].
INERTIA_Z = 4.0
#: Windows of an open block that give a provisional dJ for :meth:`InertiaLearner.left_variance`.
PROVISIONAL = 4


def _block_fit(rows: list[tuple[float, ...]]) -> tuple[float, float] | None:
    """Return (dJ, its variance) of one block of (t, E_m, L, K, var E_m, var E_l) rows."""
    t, e_m, load, kinetic, var_m, var_l = (np.array(c) for c in zip(*rows))
    gain = np.median(e_m / np.where(load != 0.0, load, np.nan))
    weight = 1.0 / (var_m + gain * gain * var_l)
    if not (np.all(np.isfinite(weight)) and np.all(weight > 0.0)):
        return None
    root = np.sqrt(weight)
    design = np.column_stack([load, load * (t - t[0]), kinetic]) * root[:, None]
    scale = np.linalg.norm(design, axis=0)
    if not np.all(scale > 0.0):
        return None
    normalised = design / scale
    if not np.linalg.cond(normalised) < 1e8:
        return None
    beta, *_ = np.linalg.lstsq(normalised, e_m * root, rcond=None)
    residual = e_m * root - normalised @ beta
    chi2 = float(residual @ residual) / max(len(rows) - 3, 1)
    covariance = np.linalg.inv(normalised.T @ normalised)
    return float(beta[2] / scale[2]), max(chi2, 1.0) * float(covariance[2, 2]) / scale[2] ** 2


class InertiaLearner:
    """Blockwise least squares of the rotor inertia left in the windows (module docstring)."""

    def __init__(self, motor_inertia: float = float(DEFAULTS['motor_inertia'])) -> None:
        #: the configured motor_inertia [kg m^2]: dJ is at least -motor_inertia
        self.motor_inertia = float(motor_inertia)
        self.reset()

    def reset(self) -> None:
        """Forget every window."""
        self._sums = [0.0, 0.0]             # sum dJ / var, sum 1 / var over blocks
        #: blocks fitted so far
        self.blocks = 0
        #: the open block of each direction: (t, E_m, L, K, var E_m, var E_l) rows
        self._open: list[list[tuple[float, ...]]] = [[], []]
        self._provisional: list[tuple[float, float] | None] = [None, None]
        #: largest |K| of the windows added [rad^2/s^2] (the prior of :meth:`left_variance`)
        self.kinetic_max = 0.0

    def add(self, direction: int, t: float, motor_energy: float, load_energy: float,
            kinetic: float, motor_variance: float, load_variance: float) -> None:
        """Add a fused window of ``direction`` (0 opposing, 1 aiding) ending at t [s].

        E_m, E_l [J], K [rad^2/s^2] and the energies' variances [J^2].
        """
        row = (t, motor_energy, -load_energy, kinetic, motor_variance, load_variance)
        if not all(math.isfinite(v) for v in row):
            return
        block = self._open[direction]
        block.append(row)
        self.kinetic_max = max(self.kinetic_max, abs(kinetic))
        self._provisional[direction] = None
        if len(block) < BLOCK:
            if self.blocks < MIN_BLOCKS and len(block) >= PROVISIONAL:
                self._provisional[direction] = _block_fit(block)
            return
        fit = _block_fit(block)
        self._open[direction] = []
        if fit is None or not fit[1] > 0.0:
            return
        self._sums[0] += fit[0] / fit[1]
        self._sums[1] += 1.0 / fit[1]
        self.blocks += 1

    def fitted(self) -> tuple[float, float]:
        """Return (dJ [kg m^2], its variance) over the blocks; (0, inf) before any."""
        if not self._sums[1] > 0.0:
            return 0.0, math.inf
        return self._sums[0] / self._sums[1], 1.0 / self._sums[1]

    @property
    def correction(self) -> tuple[float, float]:
        """Return (dJ [kg m^2], its variance) to apply: (0, 0) until significant."""
        d_j, variance = self.fitted()
        if self.blocks < MIN_BLOCKS or not abs(d_j) > INERTIA_Z * math.sqrt(variance):
            return 0.0, 0.0
        return max(d_j, -self.motor_inertia), variance

    def left_variance(self, motor_energy: float, kinetic: float) -> float:
        """Mean square [kg^2 m^4] of the inertia the correction leaves in a window.

        Applied: (fitted dJ - applied dJ)^2 + var(dJ); none applied yet: fitted dJ^2 - var(dJ)
        (at least 0), the unbiased estimate of dJ^2. The fit is the blocks' from
        ``MIN_BLOCKS`` blocks on, before that combined with the provisional fits of the open
        blocks; with no fit at all, the prior (E_m / max(|K|, largest |K| seen))^2 of a window
        of motor energy ``motor_energy`` [J] and ``kinetic`` K [rad^2/s^2].
        """
        applied = self.correction[0]
        total, weight = self._sums
        prior = self.prior(motor_energy, kinetic)
        if prior is not None:
            return prior
        if self.blocks < MIN_BLOCKS:
            for fit in self._provisional:
                if fit is not None and fit[1] > 0.0:
                    total, weight = total + fit[0] / fit[1], weight + 1.0 / fit[1]
        if weight > 0.0:
            fitted, variance = total / weight, 1.0 / weight
            if applied != 0.0:      # what the applied correction leaves: its error
                return (fitted - applied) ** 2 + variance
            # none applied: dJ^2 estimated without bias (E fitted^2 = dJ^2 + var), so a drive
            # without inertia left is not made conservative by the fit's own noise
            return max(fitted * fitted - variance, 0.0)
        return self._prior(motor_energy, kinetic)     # no fit with a positive weight

    def prior(self, motor_energy: float, kinetic: float) -> float | None:
        """Return :meth:`left_variance`'s prior [kg^2 m^4], or None once dJ has a fit."""
        if self._sums[1] > 0.0 or any(fit is not None for fit in self._provisional):
            return None
        return self._prior(motor_energy, kinetic)

    def _prior(self, motor_energy: float, kinetic: float) -> float:
        """Return (E_m / max(|K|, largest |K| seen))^2 [kg^2 m^4], 0 when both are 0."""
        scale = max(abs(kinetic), self.kinetic_max)
        return (motor_energy / scale) ** 2 if scale > 0.0 else 0.0

    @property
    def inertia(self) -> float:
        """Return the motor inertia in use [kg m^2]: motor_inertia plus the applied dJ."""
        return self.motor_inertia + self.correction[0]

    def to_state(self) -> dict[str, Any]:
        """Return the sums, the block count and the open blocks (JSON-safe)."""
        return {'sums': encode_floats(self._sums), 'blocks': self.blocks,
                'open': [[encode_floats(row) for row in block] for block in self._open],
                'kinetic_max': encode_float(self.kinetic_max)}

    def from_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`to_state`; ValueError/KeyError/TypeError if malformed."""
        sums = decode_floats(state['sums'])
        blocks = [[tuple(decode_floats(row)) for row in block] for block in state['open']]
        if len(sums) != 2 or len(blocks) != 2 or any(
                len(row) != 6 for block in blocks for row in block):
            raise ValueError('inertia: sums needs 2 values, open 2 blocks of 6-value rows')
        self._sums, self.blocks = [sums[0], sums[1]], int(state['blocks'])
        self._open = [list(block) for block in blocks]
        self._provisional = [_block_fit(block) if self.blocks < MIN_BLOCKS
                             and PROVISIONAL <= len(block) < BLOCK else None
                             for block in self._open]
        # added within schema 2; an older state takes the largest |K| of its open blocks
        self.kinetic_max = decode_float(state['kinetic_max']) if 'kinetic_max' in state else max(
            (abs(row[3]) for block in self._open for row in block), default=0.0)
