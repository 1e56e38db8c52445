"""The ground truth a run is scored against: a truth bag, a truth CSV, a random life's record.

Truth: a simulated bag with ``gear_phm/truth/friction`` (the end of life is the first stamp
where the true u reaches u_eol, :func:`~gear_phm.prognostics.metrics.true_end_of_life_index`)
or a CSV with the header ``time,true_eol`` (seconds, finite, true_eol > 0; the last row's
true_eol is used). A truth bag written by ``gear-phm simulate --random-life`` has
:data:`~gear_phm.simulation.lives.LIFE_FILE` beside it (:func:`read_life`).
"""
from __future__ import annotations

from collections.abc import Mapping
import csv
from dataclasses import dataclass
import json
import math
from pathlib import Path

from gear_phm.bagio.series import read_vector_topic
from gear_phm.errors import GearPhmError
from gear_phm.interfaces import TRUTH_FRICTION
from gear_phm.jsonfields import flag, number, RecordError
from gear_phm.prognostics.metrics import true_end_of_life_index
from gear_phm.run import DriveNames
from gear_phm.simulation.lives import LIFE_FILE

#: life.json fields an evaluation reads.
LIFE_FIELDS = ('ratio', 'eta_opposing_min', 'u_eol', 'onset_s', 'end_of_life_s', 'healthy')
#: life.json fields that are the defaults of the health options of the same name.
LIFE_HEALTH = ('eta_opposing_min',)
#: Columns of a truth CSV, in its header line.
CSV_COLUMNS = ('time', 'true_eol')


class TruthError(GearPhmError, ValueError):
    """Ground truth that cannot be read or gives no end of life: one line, for the user."""


@dataclass(frozen=True)
class LifeRecord:
    """What an evaluation reads of a random life's record (:data:`LIFE_FIELDS` of life.json).

    The gearbox ratio [-] and eta_opposing_min [-] it was drawn with, its u_eol [-], its wear
    onset and true end of life [s] (None: none), and whether it is a healthy life.
    """

    ratio: float
    eta_opposing_min: float
    u_eol: float
    onset_s: float | None
    end_of_life_s: float | None
    healthy: bool

    def health_defaults(self) -> dict[str, float]:
        """Return the health options the life gives defaults of (:data:`LIFE_HEALTH`)."""
        return {name: float(getattr(self, name)) for name in LIFE_HEALTH}


def topic_of(topic: str, drive: str | None) -> str:
    """Return ``topic``, or one drive's own (``gear_phm/<drive>/...``)."""
    return DriveNames.chosen(drive).topic(topic)


def read_life(truth: Path) -> LifeRecord | None:
    """Return the random life's record beside a truth bag (in it or beside its file), or None.

    Raises TruthError if that file is unreadable, lacks a field of :data:`LIFE_FIELDS` or
    holds one of the wrong type.
    """
    path = (truth if truth.is_dir() else truth.parent) / LIFE_FILE
    if not path.is_file():
        return None
    try:
        life = json.loads(path.read_text(encoding='utf-8'))
    except (OSError, ValueError) as exc:
        msg = f'cannot read {path}: {exc}'
        raise TruthError(msg) from None
    missing = [key for key in LIFE_FIELDS if not isinstance(life, dict) or key not in life]
    if missing:
        msg = (f'{path} is not a life record of gear-phm simulate --random-life '
               f'(missing {", ".join(missing)})')
        raise TruthError(msg) from None
    try:
        return LifeRecord(number(life, 'ratio'), number(life, 'eta_opposing_min'),
                          number(life, 'u_eol'), _seconds(life, 'onset_s'),
                          _seconds(life, 'end_of_life_s'), flag(life, 'healthy'))
    except RecordError as exc:
        msg = f'{path}: {exc}'
        raise TruthError(msg) from None


def _seconds(values: Mapping[str, object], key: str) -> float | None:
    """Return the time [s] ``values[key]``, or None where it is null."""
    return None if values[key] is None else number(values, key)


def read_truth_csv(path: Path) -> float:
    """Return the true end of life [s] of a CSV ``time,true_eol`` [s]: its last row's.

    The first line that is not empty nor a ``#`` comment is the header naming both columns;
    every value must be a finite number, time >= 0 and true_eol > 0. Raises TruthError naming
    the file, line and column otherwise.
    """
    try:
        with open(path, newline='', encoding='utf-8') as stream:
            lines = [(number, row) for number, row in enumerate(csv.reader(stream), 1)
                     if row and ''.join(row).strip() and not row[0].lstrip().startswith('#')]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        reason = exc.strerror if isinstance(exc, OSError) else exc
        msg = f'cannot read {path}: {reason}'
        raise TruthError(msg) from None
    if not lines:
        msg = f'{path} holds no header {",".join(CSV_COLUMNS)} and no row'
        raise TruthError(msg) from None
    number, header = lines[0]
    names = [name.strip() for name in header]
    missing = [name for name in CSV_COLUMNS if name not in names]
    if missing:
        msg = (f'{path} line {number}: the header must name the columns '
               f'{",".join(CSV_COLUMNS)}, got {",".join(header)!r} (missing '
               f'{", ".join(missing)})')
        raise TruthError(msg) from None
    columns = [names.index(name) for name in CSV_COLUMNS]
    eol = math.nan
    for number, row in lines[1:]:
        values = []
        for name, column in zip(CSV_COLUMNS, columns):
            text = row[column].strip() if column < len(row) else ''
            try:
                value = float(text)
            except ValueError:
                value = math.nan
            low, bound = (0.0, '>= 0') if name == 'time' else (math.ulp(0.0), '> 0')
            if not (math.isfinite(value) and value >= low):
                msg = (f'{path} line {number} column {name}: expected a finite number '
                       f'{bound} [s], got {text!r}')
                raise TruthError(msg) from None
            values.append(value)
        eol = values[1]
    if math.isnan(eol):
        msg = f'{path} holds a header but no {",".join(CSV_COLUMNS)} row'
        raise TruthError(msg) from None
    return eol


def truth_eol(truth: Path, u_eol: float, drive: str | None = None) -> float:
    """Return the true end of life [s], from a truth bag or a CSV (module docstring).

    ``drive``: one drive of many, whose truth is ``gear_phm/<drive>/truth/friction``. Raises
    TruthError if the truth gives no end of life, BagError if the bag cannot be read.
    """
    return truth_eol_and_span(truth, u_eol, drive)[0]


def truth_eol_and_span(truth: Path, u_eol: float, drive: str | None = None
                       ) -> tuple[float, tuple[float, float] | None]:
    """Return :func:`truth_eol` and the truth's stamp range [s] (None for a CSV)."""
    if truth.suffix.lower() == '.csv':
        return read_truth_csv(truth), None
    times, vectors = read_vector_topic(truth, topic_of(TRUTH_FRICTION, drive))
    index = true_end_of_life_index(vectors[:, 0], u_eol)
    if index is None:
        msg = (f'true u in {truth} never reaches u_eol = {u_eol:.4g} (max '
               f'{vectors[:, 0].max():.4g}): no end of life to score against')
        raise TruthError(msg) from None
    return float(times[index]), (float(times[0]), float(times[-1]))
