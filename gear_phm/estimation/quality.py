"""Checks of the input data that no filter update can make: signs, units and the ratio.

:class:`DataQuality` counts, over the samples and windows the estimator sees, the evidence of
three setup mistakes that look like wear to the filter: a torque whose sign is the opposite
of the README's convention (:meth:`DataQuality.reversed_torque`), torques in different units or
scales (:meth:`DataQuality.over_unity`) and a ``ratio`` parameter the speeds disagree with
(:meth:`DataQuality.ratio_check`). Each check returns its advice as text, '' when there is
nothing to report. The counts are not persisted: a restart gathers them anew.
"""
from __future__ import annotations

import math

import numpy as np

#: :meth:`DataQuality.reversed_torque`: the share of samples out of the deadband that give
#: out power at both shafts, and their least number, from which a sign looks reversed.
REVERSED_SHARE = 0.25
REVERSED_MIN = 200
#: :meth:`DataQuality.ratio_check`: the relative difference between the ratio parameter and
#: the speeds' ratio that is reported, from this many moving samples.
RATIO_CHECK_TOLERANCE = 0.02
RATIO_CHECK_MIN = 500
#: :meth:`DataQuality.over_unity`: a window's efficiency this many sigma above 1 is
#: impossible; from this share of the measured windows, and this many, it is reported.
OVER_UNITY_Z = 5.0
OVER_UNITY_SHARE = 0.25
OVER_UNITY_MIN = 5


class DataQuality:
    """The evidence of a reversed sign, wrong units or a wrong ratio; see the module docstring."""

    def __init__(self) -> None:
        #: samples out of the power deadband; of them, those giving out power at both shafts
        #: (``impossible``), and of those, the ones whose load power is the larger
        self.power_samples = 0
        self.impossible_samples = 0
        self.impossible_load_larger = 0
        #: windows measured, those whose efficiency is above 1 by OVER_UNITY_Z sigma, and the
        #: largest of these
        self.windows_measured = 0
        self.windows_over_unity = 0
        self.largest_efficiency = 0.0
        #: moving samples, and their sums of |w_m| and of w_l sign(w_m)
        self.speed_samples = 0
        self.motor_travel = 0.0
        self.load_travel = 0.0

    def add_samples(self, w_m: np.ndarray, w_l: np.ndarray, p_m: np.ndarray, p_l: np.ndarray,
                    moving: np.ndarray, powered: np.ndarray, impossible: np.ndarray) -> None:
        """Count a batch's samples: speeds [rad/s], powers [W] and masks of the same length.

        ``moving``: timely, finite samples out of the speed threshold; ``powered``: those out
        of the power deadband; ``impossible``: those giving out power at both shafts.
        """
        # the speeds' own ratio while moving, with the motor speed's sign as the instrument
        # (speed_ratio). Element-wise sums, not ``@``: a BLAS dot of a batch runs OpenBLAS's
        # threads, whose spinning doubled the CPU time of an 8-drive analysis
        w_m_moving = w_m[moving]
        self.speed_samples += int(np.count_nonzero(moving))
        self.motor_travel += float(np.sum(np.abs(w_m_moving)))
        self.load_travel += float(np.sum(w_l[moving] * np.sign(w_m_moving)))
        # evidence of a reversed torque sign: samples out of the deadband, those that give out
        # power at both shafts, and of them those where the load's is larger
        self.power_samples += int(np.count_nonzero(powered))
        self.impossible_samples += int(np.count_nonzero(impossible))
        self.impossible_load_larger += int(np.count_nonzero(impossible
                                                            & (np.abs(p_l) > np.abs(p_m))))

    def add_window(self, eta: float, eta_variance: float) -> None:
        """Count a measured window's efficiency [-] and its variance."""
        self.windows_measured += 1
        if eta - 1.0 > OVER_UNITY_Z * math.sqrt(max(eta_variance, 0.0)):
            self.windows_over_unity += 1
            self.largest_efficiency = max(self.largest_efficiency, eta)

    def reversed_torque_fix(self, motor_effort_sign: int, load_effort_sign: int
                            ) -> tuple[str, int] | None:
        """Return the parameter and value that :meth:`reversed_torque` advises, or None.

        Given the effort signs now set.
        """
        n, bad = self.power_samples, self.impossible_samples
        if bad < REVERSED_MIN or bad < REVERSED_SHARE * n:
            return None
        if 2 * self.impossible_load_larger > bad:
            return 'load_effort_sign', -int(load_effort_sign)
        return 'motor_effort_sign', -int(motor_effort_sign)

    def reversed_torque(self, motor_effort_sign: int, load_effort_sign: int) -> str:
        """Return which effort's sign looks reversed, as advice; '' when nothing does.

        A gearbox never gives out power at both shafts. Samples that seem to (``impossible``)
        come from noise near the deadband: at most 11 % of the samples out of the deadband in
        149 random lives. If one torque's sign is the opposite of the README's convention,
        the phases of one load direction all look so (43 % of them on bags/healthy with the
        load's reversed). Which one: there, the shaft that feeds the losses gives out the
        larger power; the load in an aiding phase read with its sign reversed, the motor in an
        opposing phase. At least :data:`REVERSED_SHARE` of the samples out of the deadband and
        :data:`REVERSED_MIN` samples. A stream with one load direction only shows nothing.
        """
        fix = self.reversed_torque_fix(motor_effort_sign, load_effort_sign)
        if fix is None:
            return ''
        name, value = fix
        return (f'{100.0 * self.impossible_samples / self.power_samples:.3g} % of the samples '
                f'give out power at both shafts, which no gearbox does: the '
                f'{name.split("_")[0]} torque\'s sign looks reversed (README "Conventions"); '
                f'set {name} to {value}')

    def over_unity(self) -> str:
        """Return why the windows' energies look wrong when many give out more than they take.

        No gearbox gives out more energy than it takes in: an efficiency above 1 by
        :data:`OVER_UNITY_Z` of its own sigma is noise in one window of several hundred. When
        at least :data:`OVER_UNITY_SHARE` of the measured windows (and :data:`OVER_UNITY_MIN`)
        are so, the torques are most likely in different units or scales (a motor torque in
        mN m made a healthy bags/healthy read u 2.99 and ERROR "end of life": its aiding
        windows had efficiencies near 900). '' otherwise.
        """
        n, bad = self.windows_measured, self.windows_over_unity
        if bad < OVER_UNITY_MIN or bad < OVER_UNITY_SHARE * n:
            return ''
        return (f'{100.0 * bad / n:.3g} % of the windows give out more energy than they take '
                f'in (efficiency up to {self.largest_efficiency:.4g}), which no gearbox does: '
                f"are both torques in N m, the motor's at the motor and the load's at the "
                f'load (README "Conventions")?')

    def speed_ratio(self) -> float:
        """Return the ratio the speeds give, sum |w_m| / |sum w_l sign(w_m)| [-] (NaN before).

        The motor speed's sign is the instrument: an error of the load speed that does not
        follow it averages out. The least squares of w_m on w_l read low by the load speed's
        noise over its spread (errors in the variable): with a load speed differenced from a
        coarse encoder at 1 kHz, 3 % low, and 8 of 28 bench-prior lives were refused.
        """
        if not abs(self.load_travel) > 0.0:
            return math.nan
        return abs(self.motor_travel / self.load_travel)

    def ratio_check(self, ratio: float) -> str:
        """Return why the ``ratio`` parameter disagrees with the speeds; '' when it does not.

        A gear train's speeds hold its ratio exactly: velocity_motor = R velocity_load
        (README "Conventions"). The least-squares ratio of the moving samples was within
        0.17 % of the true one in all 149 re-analysed random lives (lever and spur plants, R 2
        to 80, 100 Hz and 1 kHz). From :data:`RATIO_CHECK_MIN` moving samples, a ratio
        parameter more than :data:`RATIO_CHECK_TOLERANCE` away is reported: every u and the
        end of life computed with it would be wrong, silently (bags/healthy, R 3, read with
        5.0: u 0.055 instead of 0.050, level OK). The sign is not compared (a load joint whose
        axis points the other way).
        """
        implied = self.speed_ratio()
        if self.speed_samples < RATIO_CHECK_MIN or not math.isfinite(implied) \
                or abs(implied / ratio - 1.0) <= RATIO_CHECK_TOLERANCE:
            return ''
        return (f'the speeds give ratio {implied:.5g} (velocity_motor / velocity_load), the '
                f"ratio parameter is {ratio:.6g}: set ratio to the gearbox's R = z2/z1")
