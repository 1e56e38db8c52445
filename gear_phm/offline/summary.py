"""The summary of an offline analysis as records: :attr:`Analysis.summary` and summary.json.

One transmission's analysis is summarised by a :class:`DriveSummary`: the estimator's final
state (:class:`~gear_phm.estimation.summary.EstimatorSummary`), what was read
(:class:`RunInfo`), the estimator's parameters and the health (:class:`HealthSummary`). Many
drives in one stream give a :class:`RunSummary` holding each drive's. Each record's
``to_dict()`` is its part of summary.json (the keys in the file's order), ``to_json()`` the
file's text; :func:`summary_from_dict` and :func:`read_summary` read a file back.

In summary.json a :class:`DriveSummary` is flat: the estimator's keys, then ``bag``,
``topic``, ``messages``, ``reader``, ``seconds``, ``samples_per_second``,
``windows_measured``, ``config``, ``health`` and, for a drive that made no measurement,
``no_measurement``. ``bag`` and ``reader`` are a string for one bag, a list for several.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
import json
import math
from pathlib import Path

from gear_phm.estimation import EstimatorConfig
from gear_phm.estimation.summary import EstimatorSummary
from gear_phm.jsonfields import (counts, integer, JsonObject, number, obj, one_or_list,
                                 one_or_many, RecordError, text, texts)


@dataclass(frozen=True)
class TrendSummary:
    """The fitted wear law at the end: its model, its shape (0 if it has none), the u_eol [-]."""

    model: str
    shape: float
    u_eol: float

    def to_dict(self) -> JsonObject:
        """Return the record as summary.json's ``health.trend``."""
        return {'model': self.model, 'shape': self.shape, 'u_eol': self.u_eol}

    @classmethod
    def from_dict(cls, values: Mapping[str, object]) -> TrendSummary:
        """Return the record of summary.json's ``health.trend`` (RecordError if malformed)."""
        return cls(text(values, 'model'), number(values, 'shape'), number(values, 'u_eol'))


@dataclass(frozen=True)
class HealthSummary:
    """The health at the end of the run, as the diagnostics node last reported it.

    ``level``: 'OK', 'WARN', 'ERROR' or 'STALE' (a drive with no measurement), 'none' before
    any health state; ``first_seen_ns``: the first stamp [ns] of each level reported;
    ``dropped``: the estimates the assessor could not use, by reason. With a health state,
    ``message`` is its reason, ``values`` its status key values (decimal strings,
    :data:`~gear_phm.interfaces.STATUS_KEYS`) and ``trend`` the fitted wear law; without,
    these are None (``message`` aside for a drive with no measurement).
    """

    level: str
    first_seen_ns: Mapping[str, int]
    dropped: Mapping[str, int]
    message: str | None = None
    values: Mapping[str, str] | None = None
    trend: TrendSummary | None = None

    def value(self, key: str) -> float:
        """Return the status value ``key`` as a number (NaN without a health state).

        Raises KeyError for a key that is not one of
        :data:`~gear_phm.interfaces.STATUS_KEYS`.
        """
        return math.nan if self.values is None else float(self.values[key])

    def to_dict(self) -> JsonObject:
        """Return the record as summary.json's ``health``."""
        if self.values is None:
            found: JsonObject = {'level': self.level, 'first_seen_ns': dict(self.first_seen_ns),
                                 'dropped': dict(self.dropped)}
            if self.message is not None:
                found['message'] = self.message
            return found
        return {'level': self.level, 'message': self.message, 'values': dict(self.values),
                'first_seen_ns': dict(self.first_seen_ns), 'dropped': dict(self.dropped),
                'trend': None if self.trend is None else self.trend.to_dict()}

    @classmethod
    def from_dict(cls, values: Mapping[str, object]) -> HealthSummary:
        """Return the record of summary.json's ``health`` (RecordError if malformed)."""
        state = 'values' in values
        return cls(text(values, 'level'), counts(values, 'first_seen_ns'),
                   counts(values, 'dropped'),
                   text(values, 'message') if state or 'message' in values else None,
                   texts(values, 'values') if state else None,
                   TrendSummary.from_dict(obj(values, 'trend')) if state else None)


@dataclass(frozen=True)
class RunInfo:
    """What a run read: its bags in order, the topic, the messages, each bag's reader, time.

    ``seconds``: the processing loop's wall time [s] (it varies from run to run).
    """

    bags: tuple[str, ...]
    topic: str
    messages: int
    readers: tuple[str, ...]
    seconds: float

    @property
    def samples_per_second(self) -> float:
        """Return the messages read per second of the loop (inf for no time)."""
        return self.messages / self.seconds if self.seconds > 0 else math.inf

    def to_dict(self) -> JsonObject:
        """Return the record as summary.json's keys ``bag`` to ``samples_per_second``."""
        return {'bag': one_or_list(self.bags), 'topic': self.topic, 'messages': self.messages,
                'reader': one_or_list(self.readers), 'seconds': self.seconds,
                'samples_per_second': self.samples_per_second}

    @classmethod
    def from_dict(cls, values: Mapping[str, object]) -> RunInfo:
        """Return the record of those keys of summary.json (RecordError if malformed)."""
        return cls(one_or_many(values, 'bag'), text(values, 'topic'),
                   integer(values, 'messages'), one_or_many(values, 'reader'),
                   number(values, 'seconds'))


@dataclass(frozen=True)
class DriveSummary:
    """The summary of one transmission's analysis (summary.json of one, or one drive's).

    ``windows_measured``: the estimator's measured windows; ``config``: its parameters;
    ``no_measurement``: why a drive of many made no filter update (its level is then
    STALE), None if it made one.
    """

    estimator: EstimatorSummary
    run: RunInfo
    windows_measured: int
    config: EstimatorConfig
    health: HealthSummary
    no_measurement: str | None = None

    @property
    def at_end_of_life(self) -> bool:
        """Whether the final u reached the end-of-life u of the fitted wear law."""
        trend = self.health.trend
        return trend is not None and self.estimator.u >= trend.u_eol

    def to_dict(self) -> JsonObject:
        """Return the record as summary.json's object (its keys, in the file's order)."""
        found: JsonObject = {**self.estimator.to_dict(), **self.run.to_dict(),
                             'windows_measured': self.windows_measured,
                             'config': self.config.as_dict(), 'health': self.health.to_dict()}
        if self.no_measurement is not None:
            found['no_measurement'] = self.no_measurement
        return found

    def to_json(self) -> str:
        """Return summary.json's text (indented by 2, no final newline)."""
        return json.dumps(self.to_dict(), indent=2)

    @classmethod
    def from_dict(cls, values: Mapping[str, object]) -> DriveSummary:
        """Return the record of one transmission's summary.json object.

        Raises :class:`~gear_phm.jsonfields.RecordError` if it is malformed.
        """
        config = obj(values, 'config')
        given: dict[str, float | str | bool] = {}
        for name, value in config.items():
            if not isinstance(value, (int, float, str)):
                msg = f'field config: {name} is {value!r}, not a parameter value'
                raise RecordError(msg) from None
            given[name] = value
        try:
            parameters = EstimatorConfig(ratio=number(config, 'ratio')).replace(**given)
        except (TypeError, ValueError) as exc:
            msg = f'field config: {exc}'
            raise RecordError(msg) from None
        keys = list(values)         # the estimator's keys come first, up to 'bag'
        ends = keys.index('bag') if 'bag' in keys else len(keys)
        estimator = EstimatorSummary.from_dict({key: values[key] for key in keys[:ends]})
        return cls(estimator, RunInfo.from_dict(values),
                   integer(values, 'windows_measured'), parameters,
                   HealthSummary.from_dict(obj(values, 'health')),
                   text(values, 'no_measurement') if 'no_measurement' in values else None)


@dataclass(frozen=True)
class RunSummary:
    """The summary of many drives analysed in one pass: the run, each drive's summary.

    ``workers``: the worker processes the drives ran in (0: all in the analysing process).
    """

    run: RunInfo
    workers: int
    transmissions: Mapping[str, DriveSummary]

    def to_dict(self) -> JsonObject:
        """Return the record as summary.json's object (its keys, in the file's order)."""
        return {**self.run.to_dict(), 'workers': self.workers,
                'transmissions': {name: drive.to_dict()
                                  for name, drive in self.transmissions.items()}}

    def to_json(self) -> str:
        """Return summary.json's text (indented by 2, no final newline)."""
        return json.dumps(self.to_dict(), indent=2)

    @classmethod
    def from_dict(cls, values: Mapping[str, object]) -> RunSummary:
        """Return the record of a many-drive summary.json object (RecordError if malformed)."""
        drives = obj(values, 'transmissions')
        return cls(RunInfo.from_dict(values), integer(values, 'workers'),
                   {name: DriveSummary.from_dict(obj(drives, name)) for name in drives})


#: The summary of an analysis: one transmission's, or many drives'.
Summary = DriveSummary | RunSummary


def summary_from_dict(values: object) -> Summary:
    """Return the record of a parsed summary.json: a RunSummary if it has ``transmissions``.

    Raises :class:`~gear_phm.jsonfields.RecordError` if it is malformed.
    """
    if not isinstance(values, Mapping) or not all(isinstance(key, str) for key in values):
        msg = f'expected a JSON object, got {type(values).__name__}'
        raise RecordError(msg) from None
    if 'transmissions' in values:
        return RunSummary.from_dict(values)
    return DriveSummary.from_dict(values)


def read_summary(path: str | Path) -> Summary:
    """Return the summary.json at ``path`` (a file, or an analysis's output directory).

    Raises :class:`~gear_phm.jsonfields.RecordError` if it cannot be read or is malformed.
    """
    file = Path(path)
    if file.is_dir():
        file = file / 'summary.json'
    try:
        values = json.loads(file.read_text(encoding='utf-8'))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        msg = f'cannot read {file}: {exc}'
        raise RecordError(msg) from None
    try:
        return summary_from_dict(values)
    except RecordError as exc:
        msg = f'{file}: {exc}'
        raise RecordError(msg) from None
