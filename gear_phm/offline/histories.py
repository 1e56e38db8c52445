"""What ``gear-phm analyze`` keeps of one drive's run: bounded histories and plot envelopes.

The live nodes publish each record and keep none; the offline engine keeps these for the
returned :class:`~gear_phm.offline.records.Analysis` (:meth:`DriveHistories.analysis`).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import fields

import numpy as np

from gear_phm import interfaces
from gear_phm.estimation import FrictionEstimate, Measurement
from gear_phm.offline.decimate import Binned, ENVELOPE_BINS
from gear_phm.offline.records import (Analysis, Envelope, EstimateHistory, ESTIMATES, HEALTH,
                                      HealthHistory, MeasuredWindows, MEASUREMENT_FIELDS,
                                      measurements_key, NO_LOAD)
from gear_phm.offline.summary import Summary
from gear_phm.prognostics import HealthState
from gear_phm.prognostics.metrics import true_end_of_life_index

HEALTH_COLUMNS = tuple(f.name for f in fields(HealthHistory) if f.name != 'messages')
_TRUTH_COLUMNS = ('stamp_ns', 'x', 'y', 'z')
#: The measured windows' history: (stamp [ns], Measurement, accepted) as numpy columns,
#: read as items by :class:`MeasuredWindows` (the same values: each an int, a float or a bool).
#: Kept as objects they took about 350 bytes each, 7 MB at the cap of 20 000 reached after
#: about 7M samples of 1 kHz; as columns, 57 bytes.
_MEASUREMENT_COLUMNS = ('stamp_ns', 'code', 'accepted', *MEASUREMENT_FIELDS)
#: The no-load envelope's columns (:data:`gear_phm.offline.records.NO_LOAD`).
_NO_LOAD_COLUMNS = ('no_load_torque', 'no_load_low', 'no_load_high')


class DriveHistories:
    """One drive's histories (``history`` records at the most, None: all) and envelopes."""

    def __init__(self, history: int | None, no_load: bool) -> None:
        self.history = history
        self.measurements = Binned(history, _MEASUREMENT_COLUMNS)    # as columns (above)
        self.pending: list[tuple[int, Measurement, bool]] = []    # of the batch
        self.measured: dict[str, Binned] = {}    # envelopes of eta by measurements_key
        self.estimates = Binned(history, [f.name for f in fields(EstimateHistory)])
        self.states = Binned(history, HEALTH_COLUMNS, objects=True)
        self.envelopes = {
            ESTIMATES: Binned(ENVELOPE_BINS, ('stamp_ns', 'u', 'eta_opposing', 'eta_aiding'),
                              ('u', 'eta_opposing', 'eta_aiding', 'u_low', 'u_high')),
            HEALTH: Binned(ENVELOPE_BINS, ('stamp_ns', 'level', 'rul_median', 'rul_p5',
                                           'rul_p95', 'u_eol'),
                           ('level', 'rul_median', 'rul_p5', 'rul_p95', 'u_eol', 'rul_unknown'))}
        if no_load:
            self.envelopes[NO_LOAD] = Binned(ENVELOPE_BINS, ('stamp_ns', *_NO_LOAD_COLUMNS),
                                             _NO_LOAD_COLUMNS)
        self.truth: dict[str, tuple[Binned, Binned]] = {}    # by topic: history, envelope
        self.true_end_of_life_ns: int | None = None

    def measured_window(self, stamp_ns: int, measurement: Measurement, accepted: bool) -> None:
        """Note one measured window (kept with the batch's estimates)."""
        self.pending.append((stamp_ns, measurement, accepted))

    def keep_estimates(self, history: EstimateHistory,
                       estimates: Sequence[FrictionEstimate]) -> None:
        """Add a batch's estimates and measured windows to the histories."""
        if history.stamp_ns.size:
            columns = {f.name: getattr(history, f.name) for f in fields(history)}
            self.estimates.extend(columns)
            sigma = history.u_sigma
            self.envelopes[ESTIMATES].extend(
                {**columns, 'u_low': history.u - 2 * sigma, 'u_high': history.u + 2 * sigma})
            if NO_LOAD in self.envelopes:
                torque, spread = np.array([(e.no_load_torque, 2.0 * e.no_load_sigma)
                                           for e in estimates], dtype=float).reshape(-1, 2).T
                self.envelopes[NO_LOAD].extend(
                    {'stamp_ns': history.stamp_ns, 'no_load_torque': torque,
                     'no_load_low': torque - spread, 'no_load_high': torque + spread})
        self.keep_measurements()

    def keep_states(self, states: Sequence[HealthState]) -> None:
        """Add a batch's health states to the histories."""
        if states:
            health = HealthHistory.of(states)
            columns = {name: getattr(health, name) for name in HEALTH_COLUMNS}
            self.states.extend(columns, health.messages)
            self.envelopes[HEALTH].extend(
                {**columns, 'rul_unknown': (~np.isfinite(health.rul_median)).astype(float)})

    def keep_measurements(self) -> None:
        """Add the measured windows of the batch to their history and envelopes."""
        if not self.pending:
            return
        stamps = np.fromiter((stamp for stamp, _, _ in self.pending), dtype=np.int64,
                             count=len(self.pending))
        values = np.array([[getattr(m, name) for name in MEASUREMENT_FIELDS]
                           for _, m, _ in self.pending], dtype=float)
        eta = values[:, MEASUREMENT_FIELDS.index('eta')]
        code = np.array([m.code for _, m, _ in self.pending], dtype=np.int64)
        ok = np.array([accepted for _, _, accepted in self.pending], dtype=bool)
        self.measurements.extend({'stamp_ns': stamps, 'code': code, 'accepted': ok,
                                  **{name: values[:, i]
                                     for i, name in enumerate(MEASUREMENT_FIELDS)}})
        for value in np.unique(code).tolist():
            for accepted in (True, False):
                chosen = (code == value) & (ok == accepted)
                if chosen.any():
                    self.measured.setdefault(
                        measurements_key(value, accepted),
                        Binned(ENVELOPE_BINS, ('stamp_ns', 'eta'), ('eta',))).extend(
                            {'stamp_ns': stamps[chosen], 'eta': eta[chosen]})
        self.pending.clear()

    def keep_truth(self, name: str, stamps: np.ndarray, values: np.ndarray,
                   u_eol: float) -> None:
        """Add ground-truth rows (stamps [ns], x, y, z) of topic ``name``.

        ``u_eol``: the friction at the end of life, for the true end of life's stamp.
        """
        columns = {'stamp_ns': stamps, 'x': values[:, 0], 'y': values[:, 1],
                   'z': values[:, 2]}
        if name not in self.truth:
            self.truth[name] = (Binned(self.history, _TRUTH_COLUMNS),
                                Binned(ENVELOPE_BINS, _TRUTH_COLUMNS, ('x', 'y', 'z')))
        for kept in self.truth[name]:
            kept.extend(columns)
        if name == interfaces.TRUTH_FRICTION and self.true_end_of_life_ns is None:
            index = true_end_of_life_index(values[:, 0], u_eol)
            if index is not None:
                self.true_end_of_life_ns = int(stamps[index])

    def analysis(self, summary: Summary) -> Analysis:
        """Return the Analysis of what was kept, with ``summary``."""
        estimates = (EstimateHistory(**self.estimates.first()) if self.estimates.count
                     else EstimateHistory.of([]))
        health = (HealthHistory(**self.states.first(), messages=tuple(self.states.objects()))
                  if self.states.count else HealthHistory.of([]))
        truth = {}
        envelopes: dict[str, Envelope] = {
            name: kept.envelope() for name, kept in self.envelopes.items() if kept.count}
        for name, (kept, envelope) in self.truth.items():
            columns = kept.first()
            truth[name] = np.column_stack([columns[c].astype(float) for c in _TRUTH_COLUMNS])
            envelopes[name] = envelope.envelope()
        envelopes.update((key, kept.envelope()) for key, kept in self.measured.items())
        return Analysis(estimates, health, summary, self.windows(), truth, None,
                        envelopes, self.true_end_of_life_ns)

    def windows(self) -> MeasuredWindows:
        """Return the kept measured windows: (stamp [ns], Measurement, accepted) on reading."""
        if not self.measurements.count:
            return MeasuredWindows({})
        return MeasuredWindows(self.measurements.first())
