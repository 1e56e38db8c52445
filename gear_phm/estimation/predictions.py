"""The estimates published between two filter updates, predicted from one posterior at once.

Between two of its updates the filter's state only moves forward in time: each estimate
published on the ``publish_rate`` grid is the posterior of the update before it, predicted
to the operating time of its sample. :class:`PredictionBase` holds what such a run of
estimates is predicted from; :func:`predicted_estimates` makes the estimates of a batch's
runs with one stacked prediction (:func:`~gear_phm.estimation.kalman.predicted_stacked`),
bit-identical to one prediction each.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
import itertools
import math

import numpy as np

from gear_phm.estimation.kalman import predicted_stacked
from gear_phm.estimation.records import FrictionEstimate
from gear_phm.models.lever import efficiencies_array


@dataclass(frozen=True)
class PredictionBase:
    """A filter state the published estimates until the next update are predicted from.

    Its x, P, time t [s] (inf: none yet), q [1/s^3], each direction's bias, the newest window's
    efficiency and the last update's innovation, its variance and NIS, the mismatch variances,
    and the no-load torque, its sigma and the total efficiency (NaN without the no-load model).
    """

    x: np.ndarray
    p: np.ndarray
    t: float
    q: float
    bias: tuple[float, float]
    fixed: tuple[float, float, float, float]
    mismatch: tuple[float, float]
    no_load: tuple[float, float, float]


@dataclass(frozen=True)
class BatchCounts:
    """A batch's per-sample columns an estimate carries.

    ``stamps`` [ns], the power-flow ``code``, the cumulative samples used and rejected, and
    the operating time at each sample [s].
    """

    stamps: np.ndarray
    code: np.ndarray
    used_cum: np.ndarray
    rejected_cum: np.ndarray
    operating_at: np.ndarray


def predicted_estimates(runs: Sequence[tuple[np.ndarray, PredictionBase]], batch: BatchCounts,
                        ratio: float) -> list[list[FrictionEstimate]]:
    """Return the estimates of each run: (the samples published, the state of their base).

    Each estimate is the base's posterior predicted to its sample's operating time, with the
    efficiencies of gear ``ratio`` [-] as each direction's windows read them.
    """
    sizes = [run.size for run, _ in runs]
    bases = [base for _, base in runs]
    index = np.concatenate([run for run, _ in runs])
    operating = batch.operating_at[index]

    def per_row(values: Sequence[object]) -> np.ndarray:
        return np.repeat(np.array(values, dtype=float), sizes, axis=0)

    x, p = predicted_stacked(per_row([b.x for b in bases]), per_row([b.p for b in bases]),
                             per_row([b.t for b in bases]), per_row([b.q for b in bases]),
                             operating)
    u = x[:, 0]
    bias = per_row([b.bias for b in bases])
    eta_d = efficiencies_array(u + bias[:, 0], ratio)[0]
    eta_i = efficiencies_array(u + bias[:, 1], ratio)[1]
    nan = math.nan
    rows = zip(batch.stamps[index].tolist(), u.tolist(), x[:, 1].tolist(), p[:, 0, 0].tolist(),
               p[:, 0, 1].tolist(), p[:, 1, 1].tolist(), eta_d.tolist(), eta_i.tolist(),
               batch.used_cum[index].tolist(), batch.rejected_cum[index].tolist(),
               batch.code[index].tolist(), operating.tolist())
    estimates = []
    for base, size in zip(bases, sizes):
        fixed, q, mismatch = base.fixed, base.q, base.mismatch
        offset = base.bias[1] - base.bias[0]
        torque, sigma, total = base.no_load
        estimates.append([
            FrictionEstimate(stamp, u_k, rate, (p_uu, p_ur, p_rr), e_d, e_i, *fixed, used,
                             rejected, flow, process_noise=q, mismatch_variance=mismatch,
                             operating_time=time, measurement=nan,
                             measurement_variance=nan, direction_offset=offset,
                             no_load_torque=torque, no_load_sigma=sigma,
                             total_efficiency=total)
            for stamp, u_k, rate, p_uu, p_ur, p_rr, e_d, e_i, used, rejected, flow, time
            in itertools.islice(rows, size)])
    return estimates
