"""The records of an offline analysis: :class:`Analysis` and its column histories.

Their own module so that :mod:`gear_phm.offline.histories`, which makes them, and
:mod:`gear_phm.offline.plot`, which draws them, import them without importing each other.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from gear_phm.estimation import FrictionEstimate, Measurement
from gear_phm.offline.summary import Summary
from gear_phm.prognostics import HealthState


@dataclass(frozen=True)
class EstimateHistory:
    """Every :class:`FrictionEstimate` of a run, as columns (same units and meanings)."""

    stamp_ns: np.ndarray
    u: np.ndarray
    rate: np.ndarray
    p_uu: np.ndarray
    p_ur: np.ndarray
    p_rr: np.ndarray
    eta_opposing: np.ndarray
    eta_aiding: np.ndarray
    measured_efficiency: np.ndarray
    innovation: np.ndarray
    innovation_variance: np.ndarray
    nis: np.ndarray
    samples_used: np.ndarray
    samples_rejected: np.ndarray
    power_flow: np.ndarray
    operating_time: np.ndarray

    @property
    def t(self) -> np.ndarray:
        """Stamps [s]."""
        return self.stamp_ns * 1e-9

    @property
    def u_sigma(self) -> np.ndarray:
        """Return the standard deviation of u [-]."""
        sigma: np.ndarray = np.sqrt(np.maximum(self.p_uu, 0.0))
        return sigma

    @classmethod
    def of(cls, estimates: Sequence[FrictionEstimate]) -> EstimateHistory:
        rows = [(e.stamp_ns, e.u, e.rate, *e.covariance, e.eta_opposing, e.eta_aiding,
                 e.measured_efficiency, e.innovation, e.innovation_variance, e.nis,
                 e.samples_used, e.samples_rejected, e.power_flow, e.operating_time)
                for e in estimates]
        table = np.array(rows, dtype=float).reshape(-1, 16)
        columns = {f.name: table[:, i] for i, f in enumerate(fields(cls))}
        columns['stamp_ns'] = np.fromiter((e.stamp_ns for e in estimates), dtype=np.int64,
                                          count=len(estimates))
        for name in ('samples_used', 'samples_rejected', 'power_flow'):    # exact as float64
            columns[name] = columns[name].astype(np.int64)
        return cls(**columns)


@dataclass(frozen=True)
class HealthHistory:
    """Every :class:`HealthState` of a run, as columns.

    The columns: level (0 OK .. 3 STALE), RUL median, p5 and p95 [s] of elapsed time (inf:
    no degradation detectable), end-of-life u [-]; ``messages`` holds each state's reason;
    the RUL in operating time [s], the operating time [s] and the utilisation [-] (see
    :mod:`gear_phm.prognostics.assessor`).
    """

    stamp_ns: np.ndarray
    level: np.ndarray
    rul_median: np.ndarray
    rul_p5: np.ndarray
    rul_p95: np.ndarray
    u_eol: np.ndarray
    messages: tuple[str, ...]
    rul_operating_median: np.ndarray
    rul_operating_p5: np.ndarray
    rul_operating_p95: np.ndarray
    operating_time: np.ndarray
    utilisation: np.ndarray

    @property
    def t(self) -> np.ndarray:
        """Stamps [s]."""
        return self.stamp_ns * 1e-9

    @classmethod
    def of(cls, states: Sequence[HealthState]) -> HealthHistory:
        def column(values: list[float]) -> np.ndarray:
            return np.array(values, dtype=float)
        return cls(np.array([s.stamp_ns for s in states], dtype=np.int64),
                   np.array([s.level for s in states], dtype=np.int64),
                   column([s.rul.median for s in states]), column([s.rul.p5 for s in states]),
                   column([s.rul.p95 for s in states]), column([s.u_eol for s in states]),
                   tuple(s.message for s in states),
                   column([s.rul_operating.median for s in states]),
                   column([s.rul_operating.p5 for s in states]),
                   column([s.rul_operating.p95 for s in states]),
                   column([s.operating_time for s in states]),
                   column([s.utilisation for s in states]))


#: Keys of :attr:`Analysis.envelopes`: the estimates' and the health states' (the truth
#: topics' are their topic names, the measurements' those of :func:`measurements_key`), and
#: with the no-load model the no-load torque's (``no_load_torque``, its 2-sigma band
#: ``no_load_low``/``no_load_high``).
ESTIMATES, HEALTH, NO_LOAD = 'estimates', 'health', 'no_load'


def measurements_key(code: int, accepted: bool) -> str:
    """Return the :attr:`Analysis.envelopes` key of the measured windows of one ``code``.

    ``code``: the power flow; ``accepted`` by the filter, or gated.
    """
    return f'measurements/{code}/{"accepted" if accepted else "gated"}'


@dataclass(frozen=True)
class Envelope:
    """A series in bins of consecutive records: each bin's first record, least and greatest.

    ``stamp_ns``: the first record's stamp of each bin [ns]; ``count``: records per bin;
    ``first[name]``: the first record's value; ``low[name]`` / ``high[name]``: the least and
    greatest value in the bin (NaN only where all are NaN). A bin of one record is that record.
    """

    stamp_ns: np.ndarray
    count: np.ndarray
    first: dict[str, np.ndarray]
    low: dict[str, np.ndarray]
    high: dict[str, np.ndarray]


#: The fields of :class:`~gear_phm.estimation.Measurement` kept for each measured window.
MEASUREMENT_FIELDS = ('t', 'eta', 'eta_variance', 'u', 'u_variance')


class MeasuredWindows(Sequence[tuple[int, Measurement, bool]]):
    """The kept measured windows as a sequence of (stamp [ns], Measurement, accepted).

    Held as columns (``stamp_ns``, ``code``, ``accepted`` and :data:`MEASUREMENT_FIELDS`,
    57 bytes a window); each item is built when it is read, so the up to 2 ``history``
    windows an analysis keeps cost no Python objects until they are used. Equal to any
    sequence of the same items, in the same order.
    """

    def __init__(self, columns: dict[str, np.ndarray]) -> None:
        self._columns = columns
        self._size = len(columns['stamp_ns']) if columns else 0

    def __len__(self) -> int:
        return self._size

    def _item(self, index: int) -> tuple[int, Measurement, bool]:
        c = self._columns
        values = (float(c[name][index]) for name in MEASUREMENT_FIELDS)
        t, eta, eta_variance, u, u_variance = values
        return (int(c['stamp_ns'][index]),
                Measurement(t, int(c['code'][index]), eta, eta_variance, u, u_variance),
                bool(c['accepted'][index]))

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, slice):
            return tuple(self._item(i) for i in range(*index.indices(self._size)))
        position = index + self._size if index < 0 else index
        if not 0 <= position < self._size:
            raise IndexError('measured window index out of range')
        return self._item(position)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Sequence) or len(other) != self._size:
            return False
        return all(a == b for a, b in zip(self, other))

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f'MeasuredWindows({self._size} windows)'


@dataclass(frozen=True)
class Analysis:
    """Result of :func:`analyze_bag`: histories, the summary, and where it was written.

    ``summary``: one transmission's :class:`~gear_phm.offline.summary.DriveSummary`, or for
    many drives the :class:`~gear_phm.offline.summary.RunSummary` of them all (summary.json
    is its ``to_json()``).
    """

    estimates: EstimateHistory
    health: HealthHistory
    summary: Summary
    #: (stamp of the window end [ns], the window's measurement, accepted by the filter) of
    #: the windows kept (up to 2 ``history``: each bin's first), built on reading
    measurements: Sequence[tuple[int, Measurement, bool]]
    truth: dict[str, np.ndarray]
    out: Path | None = None
    #: The plotted series in a bounded number of bins with their min/max (:class:`Envelope`),
    #: whatever ``history``: :data:`ESTIMATES` (u, eta_opposing, eta_aiding; low/high also of
    #: u_low, u_high = u -/+ 2 sigma), :data:`HEALTH` (level, rul_median, rul_p5, rul_p95,
    #: u_eol, rul_unknown = 1 where the median is not finite), the measured windows' eta
    #: (:func:`measurements_key`) and each truth topic's x, y, z (by topic name).
    envelopes: dict[str, Envelope] = field(default_factory=dict)
    #: Stamp [ns] of the first ground-truth sample whose u reaches the health assessor's u_eol
    #: (:func:`~gear_phm.prognostics.metrics.true_end_of_life_index`, over every truth
    #: sample), or None.
    true_end_of_life_ns: int | None = None
    #: Many drives (``analyze_bag(..., transmissions=...)``): each drive's own Analysis by
    #: name; this one then holds only the combined summary. Empty for one transmission.
    transmissions: dict[str, Analysis] = field(default_factory=dict)

    def to_dataframe(self) -> Any:
        """Return one row per estimate.

        A row holds the estimate columns, ``t`` [s] and the health columns of the same stamp
        (pandas required: ``pip install pandas``).
        """
        try:
            import pandas as pd
        except ImportError as exc:
            raise ImportError('Analysis.to_dataframe needs pandas: pip install pandas') from exc
        e = self.estimates
        frame = pd.DataFrame({f.name: getattr(e, f.name) for f in fields(e)})
        frame.insert(1, 't', e.t)
        h = self.health
        health = pd.DataFrame({'stamp_ns': h.stamp_ns, 'level': h.level,
                               'rul_median': h.rul_median, 'rul_p5': h.rul_p5,
                               'rul_p95': h.rul_p95, 'u_eol': h.u_eol,
                               'health_message': list(h.messages),
                               'rul_operating_median': h.rul_operating_median,
                               'rul_operating_p5': h.rul_operating_p5,
                               'rul_operating_p95': h.rul_operating_p95,
                               'utilisation': h.utilisation})
        return frame.merge(health, on='stamp_ns', how='left')
