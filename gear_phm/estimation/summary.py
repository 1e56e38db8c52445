"""The estimator's final state and counters as a record: :class:`EstimatorSummary`."""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields
import math

from gear_phm.jsonfields import (counts, flag, integer, JsonObject, JsonValue, number, scalar,
                                 text)


def stalled_stamps(samples_seen: int, filter_updates: int, repeated: int) -> str:
    """Return why the estimator has no measurement if its samples' stamps do not advance.

    No filter update yet, and at least half of the ``samples_seen`` repeated the stamp before
    them (``repeated``: the ``duplicate_stamp`` count): the publisher most likely leaves
    ``header.stamp`` unset (0), and every sample after the first is dropped. '' otherwise.
    """
    if filter_updates or not samples_seen or 2 * repeated < samples_seen:
        return ''
    return (f'the header stamps do not advance: {repeated} of {samples_seen} samples repeat '
            f'the stamp before them (is header.stamp set by the publisher?)')


@dataclass(frozen=True)
class EstimatorSummary:
    """What :meth:`~gear_phm.estimation.EstimatorPipeline.summary` reports, typed.

    The filter's last posterior (u [-], its rate [1/s] and sigma), the efficiencies it gives,
    the adaptive noises, the direction offset, the motor inertia [kg m^2], the operating time
    [s], the sample counters, ``counts`` (each rejection reason and event of
    :data:`~gear_phm.estimation.pipeline.SAMPLE_REASONS` and the others: how often) and the
    data checks (each '' when it found nothing, else the advice). ``extra``: the summary's
    keys this record does not name (those of optional parts of the estimator), after the
    others in the summary's order.
    """

    u: float
    u_rate: float
    sigma_u: float
    eta_opposing: float
    eta_aiding: float
    last_measured_efficiency: float
    filter_updates: int
    samples_seen: int
    process_noise: float
    mismatch_sigma_opposing: float
    mismatch_sigma_aiding: float
    direction_offset: float
    direction_offset_sigma: float
    direction_offset_drift_z: float
    motor_inertia: float
    operating_time_s: float
    samples_used: int
    samples_rejected: int
    samples_missing: int
    sample_period_s: float
    counts: Mapping[str, int]
    timed_out: bool
    reversed_torque: str
    speed_ratio: float
    ratio_check: str
    windows_over_unity: int
    over_unity: str
    extra: Mapping[str, JsonValue] = field(default_factory=dict)

    def to_dict(self) -> JsonObject:
        """Return the record as the pipeline's summary dict (its keys, in its order)."""
        return {
            'u': self.u, 'u_rate': self.u_rate, 'sigma_u': self.sigma_u,
            'eta_opposing': self.eta_opposing, 'eta_aiding': self.eta_aiding,
            'last_measured_efficiency': self.last_measured_efficiency,
            'filter_updates': self.filter_updates, 'samples_seen': self.samples_seen,
            'process_noise': self.process_noise,
            'mismatch_sigma_opposing': self.mismatch_sigma_opposing,
            'mismatch_sigma_aiding': self.mismatch_sigma_aiding,
            'direction_offset': self.direction_offset,
            'direction_offset_sigma': self.direction_offset_sigma,
            'direction_offset_drift_z': self.direction_offset_drift_z,
            'motor_inertia': self.motor_inertia, 'operating_time_s': self.operating_time_s,
            'samples_used': self.samples_used, 'samples_rejected': self.samples_rejected,
            'samples_missing': self.samples_missing, 'sample_period_s': self.sample_period_s,
            'counts': dict(self.counts), 'timed_out': self.timed_out,
            'reversed_torque': self.reversed_torque, 'speed_ratio': self.speed_ratio,
            'ratio_check': self.ratio_check, 'windows_over_unity': self.windows_over_unity,
            'over_unity': self.over_unity, **self.extra,
        }

    @classmethod
    def from_dict(cls, values: Mapping[str, object]) -> EstimatorSummary:
        """Return the record of the pipeline's summary dict (a summary.json's keys up to bag).

        Keys the record does not name go to ``extra`` (each a JSON scalar). Raises
        :class:`~gear_phm.jsonfields.RecordError` for a missing or mistyped field.
        """
        extra = {key: scalar(values, key) for key in values if key not in _NAMED}
        return cls(
            u=number(values, 'u'), u_rate=number(values, 'u_rate'),
            sigma_u=number(values, 'sigma_u'), eta_opposing=number(values, 'eta_opposing'),
            eta_aiding=number(values, 'eta_aiding'),
            last_measured_efficiency=number(values, 'last_measured_efficiency'),
            filter_updates=integer(values, 'filter_updates'),
            samples_seen=integer(values, 'samples_seen'),
            process_noise=number(values, 'process_noise'),
            mismatch_sigma_opposing=number(values, 'mismatch_sigma_opposing'),
            mismatch_sigma_aiding=number(values, 'mismatch_sigma_aiding'),
            direction_offset=number(values, 'direction_offset'),
            direction_offset_sigma=number(values, 'direction_offset_sigma'),
            direction_offset_drift_z=number(values, 'direction_offset_drift_z'),
            motor_inertia=number(values, 'motor_inertia'),
            operating_time_s=number(values, 'operating_time_s'),
            samples_used=integer(values, 'samples_used'),
            samples_rejected=integer(values, 'samples_rejected'),
            samples_missing=integer(values, 'samples_missing'),
            sample_period_s=number(values, 'sample_period_s'),
            counts=counts(values, 'counts'), timed_out=flag(values, 'timed_out'),
            reversed_torque=text(values, 'reversed_torque'),
            speed_ratio=number(values, 'speed_ratio'),
            ratio_check=text(values, 'ratio_check'),
            windows_over_unity=integer(values, 'windows_over_unity'),
            over_unity=text(values, 'over_unity'), extra=extra)

    def stalled_stamps(self) -> str:
        """Return why the estimator has no measurement if its samples' stamps do not advance.

        :func:`stalled_stamps` of this summary's counters.
        """
        return stalled_stamps(self.samples_seen, self.filter_updates,
                              self.counts.get('duplicate_stamp', 0))

    def extra_number(self, key: str) -> float:
        """Return the unnamed summary value ``key`` as a float (NaN if absent or no number).

        E.g. the no-load model's ``no_load_torque``, which runs without the model lack.
        """
        value = self.extra.get(key)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return math.nan
        return float(value)

    @property
    def held(self) -> bool:
        """Return whether u never moved because no window's no-load loss was identified."""
        return not self.filter_updates and self.counts.get('not_identifiable', 0) > 0

    def unmeasured(self, windows_measured: int) -> str:
        """Return why the run made no filter update ('' if it made one).

        The samples' reasons (the counts, most first) and the windows measured: with no
        update, u is the filter's prior, not an estimate. A run whose windows the no-load
        model held (:attr:`held`) measured: it says why u did not move.
        """
        if self.filter_updates or self.held:
            return ''
        found = {name: count for name, count in self.counts.items() if count}
        reasons = ', '.join(f'{name} {count}' for name, count in sorted(
            found.items(), key=lambda item: -item[1])) or 'none counted'
        return (f'{self.samples_seen} samples, {self.samples_used} used, '
                f'{windows_measured} windows measured (rejections: {reasons})')


#: The keys of the pipeline's summary that :class:`EstimatorSummary` names.
_NAMED = frozenset(f.name for f in fields(EstimatorSummary)) - {'extra'}
