"""The offline engine: recorded JointState in, the live nodes' estimates and health out.

:func:`analyze_bag` runs :class:`~gear_phm.estimation.EstimatorPipeline` and
:class:`~gear_phm.prognostics.HealthAssessor` (the code of the estimator and diagnostics
nodes) over one bag, or several in order of their start time, as fast as the bag can be read.
It returns an :class:`Analysis` of numpy histories and, given ``out``, writes the same topics
the nodes publish as a rosbag2 MCAP directory, plus ``summary.json`` and ``analysis.png``.

Data path (no Python work per message): the bag reader yields raw batches of JointState CDR
(:meth:`gear_phm.bagio.BagReader.raw_batches`), :func:`gear_phm.codec.
decode_joint_state_pairs` turns each into columns (once for all drives, with
``transmissions``), the pipeline returns
:class:`~gear_phm.estimation.FrictionEstimate` records, the assessor a
:class:`~gear_phm.prognostics.HealthState` per estimate, and :mod:`gear_phm.interfaces`
maps both to the topics written by :class:`~gear_phm.bagio.Rosbag2McapWriter`. Each
``/diagnostics`` tick of bag time is a mark of the batch
(:meth:`~gear_phm.estimation.EstimatorPipeline.on_batch_marked`), so each status holds the
state after exactly the messages logged before it, as the nodes would have published it,
without cutting the batch (cutting a 100 Hz bag at every tick cost more than the estimator).
"""
from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from contextlib import nullcontext
from dataclasses import dataclass, fields, replace
import operator
from pathlib import Path
import sys
import time
from typing import Any, TYPE_CHECKING

import numpy as np

from gear_phm import codec, interfaces, stopping
from gear_phm.errors import GearPhmError
from gear_phm.estimation import (EstimatorConfig, EstimatorPipeline, FrictionEstimate,
                                 Measurement)
from gear_phm.estimation.pipeline import MESSAGE_REASON_TEXT
from gear_phm.estimation.summary import EstimatorSummary
from gear_phm.offline.decimate import Binned, ENVELOPE_BINS
from gear_phm.offline.parallel import (Assessed, Column, drives_for, Estimated, Finished,
                                       HealthHalf, LocalDrives, Made, start_plotter)
from gear_phm.offline.records import (Analysis, Envelope, EstimateHistory, ESTIMATES, HEALTH,
                                      HealthHistory, MeasuredWindows, MEASUREMENT_FIELDS,
                                      measurements_key, NO_LOAD)
from gear_phm.offline.summary import (DriveSummary, HealthSummary, RunInfo, RunSummary,
                                      TrendSummary)
from gear_phm.parameters import (DIAGNOSTICS_RATE, HARDWARE_ID, LOAD_JOINT, MOTOR_JOINT, RATIO,
                                 STAMP_SOURCE, TRANSMISSION_NAME)
from gear_phm.prognostics import HealthAssessor, HealthConfig, HealthState, ShapePrior
from gear_phm.prognostics.config import NOT_OFFLINE_OPTIONS
from gear_phm.prognostics.metrics import true_end_of_life_index
from gear_phm.staging import Staged
from gear_phm.status import LEVEL_NAMES, StatusOut
from gear_phm.transmissions import (DRIVE_OWN, drive_own_given, load_transmissions,
                                    parse_transmissions, Transmission, TransmissionsError)

if TYPE_CHECKING:
    from gear_phm.bagio.chunks import RawBatch

#: Messages per batch when the bag is read through rosbags (indexed MCAP goes by chunk).
BATCH = 20000
#: ``analyze_bag``'s default ``history``: the returned histories keep 10 000 to 20 000 records
#: each, whatever the bag (a few MiB).
HISTORY = 10_000
_HEALTH_COLUMNS = tuple(f.name for f in fields(HealthHistory) if f.name != 'messages')
_TRUTH_COLUMNS = ('stamp_ns', 'x', 'y', 'z')
#: The measured windows' history: (stamp [ns], Measurement, accepted) as numpy columns,
#: read as items by :class:`MeasuredWindows` (the same values: each an int, a float or a bool).
#: Kept as objects they took about 350 bytes each, 7 MB at the cap of 20 000 reached after
#: about 7M samples of 1 kHz; as columns, 57 bytes.
_MEASUREMENT_COLUMNS = ('stamp_ns', 'code', 'accepted', *MEASUREMENT_FIELDS)
ESTIMATOR_STATUS_NAME = 'gear_phm estimator: estimator'
#: The no-load envelope's columns (:data:`gear_phm.offline.records.NO_LOAD`).
_NO_LOAD_COLUMNS = ('no_load_torque', 'no_load_low', 'no_load_high')


class AnalysisError(GearPhmError, ValueError):
    """A problem with the input or the options: one line, meant for the user."""


def split_options(ratio: float, options: dict[str, Any]) -> tuple[EstimatorConfig, HealthConfig]:
    """Route keyword options to the estimator or the health parameters by name."""
    estimator_names = {f.name for f in fields(EstimatorConfig)} - {RATIO.name}
    health_names = {f.name for f in fields(HealthConfig)} - set(NOT_OFFLINE_OPTIONS)
    unknown = sorted(set(options) - estimator_names - health_names)
    if unknown:
        raise AnalysisError(f'unknown option(s) {unknown}; estimator: '
                            f'{sorted(estimator_names)}; health: {sorted(health_names)}')
    try:
        estimator = EstimatorConfig(ratio=float(ratio), **{
            k: v for k, v in options.items() if k in estimator_names})
        health = HealthConfig(ratio=float(ratio), **{
            k: v for k, v in options.items() if k in health_names})
    except (TypeError, ValueError) as exc:
        raise AnalysisError(str(exc)) from None
    return estimator, health


#: File suffixes of recordings (rosbag2 storage files and ROS1 bags).
BAG_SUFFIXES = ('.mcap', '.db3', '.bag')


def recordings_in(folder: Path) -> list[Path]:
    """Return the recordings in a folder, sorted by name.

    Recordings are rosbag2 directories (with metadata.yaml) and bag files; analyze_bag orders
    them by start time.
    """
    found = []
    for entry in sorted(folder.iterdir()):
        if entry.is_dir() and (entry / 'metadata.yaml').is_file():
            found.append(entry)
        elif entry.is_file() and entry.suffix in BAG_SUFFIXES:
            found.append(entry)
    return found


def _expand(path: Path) -> list[Path]:
    """Return a bag as it is, a folder of recordings as the recordings in it.

    A folder of recordings is not itself a bag: it has no metadata.yaml and no storage
    files of its own.
    """
    if not path.is_dir() or (path / 'metadata.yaml').is_file() or any(
            entry.suffix in BAG_SUFFIXES for entry in path.iterdir() if entry.is_file()):
        return [path]
    found = recordings_in(path)
    if not found:
        raise AnalysisError(f'{path} holds no recording (rosbag2 directories or bag files)')
    return found


def order_bags(paths: Sequence[str | Path]) -> list[Path]:
    """Return the bags in order of their first message (a campaign of recordings).

    A folder of recordings stands for the recordings in it.
    """
    from gear_phm.bagio import BagError, BagReader
    starts = []
    for given in paths:
        if not isinstance(given, (str, Path)):
            raise AnalysisError(f'a bag is a path (str or Path), got {given!r}')
        if not Path(given).exists():
            raise AnalysisError(f'bag {given} does not exist')
    expanded = [bag for given in paths for bag in _expand(Path(given))]
    seen: dict[Path, Path] = {}
    for path in expanded:
        first = seen.setdefault(path.resolve(), path)
        if first is not path:       # its samples would repeat in one run: time runs twice
            raise AnalysisError(f'bag {path} is given twice (also as {first})')
    for path in expanded:
        start = _metadata_start_ns(Path(path))
        if start is None:
            try:
                with BagReader(path) as bag:
                    start = bag.start_ns
            except BagError as exc:
                raise AnalysisError(str(exc)) from None
        starts.append((start, str(path)))
    return [Path(p) for _, p in sorted(starts)]


def _metadata_start_ns(path: Path) -> int | None:
    """Return a rosbag2 directory's start time [ns] from its metadata.yaml, or None.

    It is the start rosbags reports, read with libyaml: opening every bag of a campaign twice
    through rosbags' pure-Python YAML cost a third of a fleet unit's time. None where the file
    is not there or not readable; the bag is then opened, and any problem reported then.
    """
    import yaml
    metadata = path / 'metadata.yaml'
    if not metadata.is_file():
        return None
    try:
        loader = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)
        info = yaml.load(metadata.read_text(), Loader=loader)['rosbag2_bagfile_information']
        return int(info['starting_time']['nanoseconds_since_epoch'])
    except (OSError, UnicodeDecodeError, yaml.YAMLError, KeyError, TypeError, ValueError):
        return None


def analyze_bag(path_or_paths: str | Path | Sequence[str | Path], ratio: float | None = None,
                *, motor_joint: str = str(MOTOR_JOINT.default),
                load_joint: str = str(LOAD_JOINT.default),
                topic: str = interfaces.JOINT_STATES, out: str | Path | None = None,
                overwrite: bool = False, plot: bool = True, progress: bool = False,
                transmission_name: str = str(TRANSMISSION_NAME.default),
                hardware_id: str = str(HARDWARE_ID.default),
                diagnostics_rate: float = float(DIAGNOSTICS_RATE.default),
                stamp_source: str = str(STAMP_SOURCE.default),
                history: int | None = HISTORY,
                prior: ShapePrior | None = None, transmissions: Any = None,
                jobs: int = 1, **options: Any) -> Analysis:
    """Run the estimator and diagnostics nodes' code over recorded bags.

    ``path_or_paths``: a rosbag2 directory, a ``.mcap``/``.db3`` file or a ROS1 ``.bag``, a
    folder of them, or a list of these (analysed as one run, in order of their start
    times). ``ratio`` is the gearbox's R = z2/z1 [-]. ``options`` are estimator or health
    parameters by name, as in config/estimator.yaml and config/diagnostics.yaml (e.g.
    ``eta_opposing_min=0.7333``).
    With ``out``, writes the output bag, ``summary.json`` and (``plot``) ``analysis.png`` into
    that directory, which must not exist (or, with ``overwrite``, hold an earlier analysis and
    nothing else), nor hold a bag being analysed; nothing is left there if the analysis fails.

    ``transmissions`` (instead of ``ratio`` and the joints): many drives in one JointState
    stream (:mod:`gear_phm.transmissions`), as a file path, its parsed YAML document, or
    :class:`~gear_phm.transmissions.Transmission` records; ``options`` then apply to each drive
    that does not set its own. The bags are read once; each drive has its own estimator and
    assessor, its outputs under ``gear_phm/<drive>/...``, its statuses ``gear_phm: <drive>``
    (hardware_id ``<drive>``) and ``gear_phm estimator: <drive>``; ``summary.json`` holds
    ``transmissions: {<drive>: <a single-transmission summary>}`` and the plots are
    ``analysis_<drive>.png``. The returned Analysis holds the combined summary and each
    drive's own Analysis in ``transmissions``. ``jobs``: worker processes, 0 for one per core
    (:mod:`gear_phm.offline.parallel`; 1, the default: all in this process): with many drives
    each worker runs its share of them; one drive's health assessment runs in a worker beside
    its estimator. The results are the same whatever ``jobs``.

    Memory does not grow with the bags. The returned histories (estimates, health states,
    measured windows and, with ``plot``, the ground truth) keep between ``history`` (default
    :data:`HISTORY`) and twice as many records each, evenly spaced from the first, plus the
    last record; ``history=None`` keeps every record (memory then grows with the bags). The
    output bag and the summary always cover every record. ``Analysis.envelopes`` holds the
    plotted series in at most 2 x :data:`~gear_phm.offline.decimate.ENVELOPE_BINS` bins with
    each bin's min and max, whatever ``history``. ``prior``: a population prior on the wear law's
    shape (:class:`~gear_phm.prognostics.ShapePrior`, ``gear-phm fleet --population-prior``).
    ``stamp_source``: a sample's time is its JointState's ``header.stamp`` ('header', as the
    nodes) or the bag's record time of the message ('log': for a publisher that leaves the
    header unset).
    ``Analysis.summary`` is a :class:`~gear_phm.offline.summary.DriveSummary` (one
    transmission) or a :class:`~gear_phm.offline.summary.RunSummary` (``transmissions``).
    Raises :class:`AnalysisError` on bad input (a bad transmissions list included), and when
    the stamps do not advance (:meth:`~gear_phm.estimation.summary.EstimatorSummary.
    stalled_stamps`: no measurement at all; ``stamp_source='log'`` is then the remedy), and
    :class:`~gear_phm.offline.parallel.ParallelError` if a drive's worker process dies.
    """
    if not isinstance(topic, str) or not topic:
        raise AnalysisError(f'topic must be a topic name, got {topic!r}')
    if history is not None and (isinstance(history, bool) or not isinstance(history, int)
                                or history < 1):
        raise AnalysisError(f'history must be an integer >= 1 or None, got {history!r}')
    try:            # the diagnostics node's `rate` and its range
        diagnostics_rate = float(replace(DIAGNOSTICS_RATE, name='diagnostics_rate').check(
            diagnostics_rate))
    except ValueError as exc:
        raise AnalysisError(str(exc)) from None
    try:
        stamp_source = str(STAMP_SOURCE.check(stamp_source))
    except ValueError as exc:
        raise AnalysisError(str(exc)) from None
    if transmissions is None:
        if ratio is None:
            raise AnalysisError('give the ratio (one transmission) or transmissions (many)')
        estimator_config, health_config = split_options(ratio, options)
        if not isinstance(motor_joint, str) or not isinstance(load_joint, str) \
                or not motor_joint or not load_joint or motor_joint == load_joint:
            raise AnalysisError(f'motor_joint and load_joint must be distinct non-empty '
                                f'names, got {motor_joint!r} and {load_joint!r}')
        runs = [DriveRun(estimator_config, health_config, motor_joint, load_joint, topic,
                         transmission_name, hardware_id, history, prior)]
    else:
        given = [name for name, value, default in zip(DRIVE_OWN, (
            ratio, motor_joint, load_joint, transmission_name, hardware_id), (
            None, MOTOR_JOINT.default, LOAD_JOINT.default, TRANSMISSION_NAME.default,
            HARDWARE_ID.default)) if value != default]
        if given:
            raise AnalysisError(drive_own_given(given))
        runs = []
        for drive in _drives(transmissions):
            estimator_config, health_config = split_options(
                drive.ratio, {**options, **drive.offline_options()})
            runs.append(DriveRun(estimator_config, health_config, drive.motor_joint,
                                 drive.load_joint, topic, drive.name, drive.name, history, prior,
                                 drive=drive.name))
    paths = [path_or_paths] if isinstance(path_or_paths, (str, Path)) else list(path_or_paths)
    if not paths:
        raise AnalysisError('no bag given')
    bags = order_bags(paths)
    target = None if out is None else _check_out(Path(out), overwrite, bags)
    stream = Stream(runs, topic, diagnostics_rate, plot, stamp_source, _jobs(jobs))
    # the plots' process imports matplotlib meanwhile; not where drive workers may draw them
    plotter = (start_plotter() if plot and target is not None
               and (len(runs) == 1 or stream.jobs == 1) else None)
    staged = None if target is None else Staged(target, AnalysisError, replace=True)
    try:
        finished, readers, elapsed = stream.execute(
            bags, None if staged is None else staged.path, progress)     # closed: finally
        analyses = []
        for end in finished:
            if end.analysis is None:
                raise AnalysisError(end.error)
            analyses.append(end.analysis)
        for end in finished:
            if end.refusal:
                raise AnalysisError(end.refusal)
        summaries = [_drive_summary(analysis) for analysis in analyses]
        stalled = summaries[0].estimator.stalled_stamps()     # the drives share the stamps
        if stalled:
            remedy = ("; analyse on the bag's record times instead: stamp_source='log' "
                      '(gear-phm analyze --stamp-source log)' if stamp_source == 'header'
                      else '')
            raise AnalysisError(f'topic {topic}: no efficiency measurement, {stalled}{remedy}')
        # no filter update: the filter's prior is no estimate of the gearbox. One drive (or
        # every drive): an error. A bench's drive that did not move while others did: its
        # summary says so and its level is STALE, as the live node's for a drive without data
        if all(summary.no_measurement for summary in summaries):
            run, why = runs[0], summaries[0].no_measurement
            which = '' if run.drive is None else \
                f'{"no drive has one; " if len(runs) > 1 else ""}drive {run.drive}: '
            raise AnalysisError(f'topic {topic}: no efficiency measurement, {which}{why}')
        if transmissions is None:
            analysis = analyses[0]
        else:
            analysis = _combined(stream, analyses, bags, readers, elapsed)
        if staged is not None:
            written = staged.path
            (written / 'summary.json').write_text(analysis.summary.to_json() + '\n')
            if plot:
                pngs = [written / ('analysis.png' if run.drive is None
                                   else f'analysis_{run.drive}.png') for run in runs]
                if plotter is not None:
                    plotter.plot([(png, drive, run.estimator_config.ratio, bags,
                                   run.drive or '')
                                  for png, run, drive in zip(pngs, runs, analyses)])
                else:                   # each drive's in its worker, if any
                    stream.plot(pngs, bags)
            staged.commit()
            analysis = replace(analysis, out=target)
        return analysis
    finally:
        stream.close()
        if plotter is not None:
            plotter.close()
        if staged is not None:
            staged.discard()


def _jobs(jobs: Any) -> int:
    """Return ``analyze_bag``'s ``jobs`` checked (AnalysisError if not an integer >= 0)."""
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 0:
        raise AnalysisError(f'jobs must be an integer >= 0 (0: one per core), got {jobs!r}')
    return jobs


def _drive_summary(analysis: Analysis) -> DriveSummary:
    """Return the summary of one transmission's Analysis (each run's own)."""
    summary = analysis.summary
    assert isinstance(summary, DriveSummary), 'a run of one drive'
    return summary


def _refusal(run: DriveRun) -> str:
    """Return why a run's data contradict its parameters ('' when they do not).

    The estimator's checks (ratio against the speeds, energy out above energy in, a reversed
    torque sign), the first that fails, with where the user sets the parameter:
    :func:`analyze_bag` stops on it.
    """
    pipeline, drive = run.pipeline, run.drive
    fix = pipeline.reversed_torque_fix()
    entry = f'in the entry of drive {drive}'
    for problem, where in (
            (pipeline.ratio_check(), '--ratio' if drive is None else f'the ratio {entry}'),
            (pipeline.over_unity(), ''),
            (pipeline.reversed_torque(), '' if fix is None else
             f'--param {fix[0]}={fix[1]}' if drive is None else f'{fix[0]}: {fix[1]} {entry}')):
        if problem:
            return (('' if drive is None else f'drive {drive}: ') + problem
                    + (f' ({where})' if where else ''))
    return ''


def _drives(transmissions: Any) -> tuple[Transmission, ...]:
    """Return the drives of ``analyze_bag``'s ``transmissions`` (AnalysisError if bad)."""
    try:
        if isinstance(transmissions, (str, Path)):
            return load_transmissions(transmissions)
        if isinstance(transmissions, Mapping):
            return parse_transmissions(transmissions)
        drives = tuple(transmissions)
    except TransmissionsError as exc:
        raise AnalysisError(str(exc)) from None
    except TypeError:
        drives = ()
    if not drives or not all(isinstance(d, Transmission) for d in drives):
        raise AnalysisError('transmissions must be a file, its YAML document or a non-empty '
                            'sequence of Transmission records')
    return drives


def _combined(stream: Stream, analyses: list[Analysis], bags: list[Path],
              readers: list[str], elapsed: float) -> Analysis:
    """Return the Analysis of many drives: the combined summary, each drive's Analysis."""
    drives = {str(run.drive): _drive_summary(analysis)
              for run, analysis in zip(stream.runs, analyses)}
    messages = next(iter(drives.values())).run.messages
    summary = RunSummary(RunInfo(tuple(str(b) for b in bags), stream.topic, messages,
                                 tuple(readers), elapsed),
                         0 if stream.drives is None else stream.drives.workers, drives)
    return Analysis(EstimateHistory.of([]), HealthHistory.of([]), summary, (), {},
                    transmissions={str(run.drive): analysis
                                   for run, analysis in zip(stream.runs, analyses)})


def _check_out(out: Path, overwrite: bool, bags: Sequence[Path] = ()) -> Path:
    """Return ``out`` if the analysis may be written there; AnalysisError if not.

    It must not exist, be empty, or (``overwrite``) hold an earlier analysis and nothing
    else (:func:`_analysis_files`): replacing it removes the directory. It must not be a
    symbolic link, nor hold or be one of the ``bags``.
    """
    if out.is_symlink():
        raise AnalysisError(f'--out {out} is a symbolic link: give the directory it points to')
    target = out.resolve()
    for bag in bags:
        if target == bag.resolve() or target in bag.resolve().parents:
            raise AnalysisError(f'--out {out} holds the bag {bag} being analysed: write the '
                                f'analysis elsewhere')
    if overwrite and out.is_dir() and (out / 'summary.json').is_file():
        others = sorted(entry.name for entry in out.iterdir()
                        if not _analysis_files(out.name, entry))
        if others:
            raise AnalysisError(f'--out {out} holds files an analysis does not write '
                                f'({", ".join(others[:5])}): not replaced')
        return out                              # replaced once the new analysis is complete
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        hint = '' if overwrite else ' (add --overwrite to replace an earlier analysis)'
        raise AnalysisError(f'--out {out} exists and is not an empty directory{hint}')
    return out


def _analysis_files(name: str, entry: Path) -> bool:
    """Whether ``entry`` of an output directory ``name`` is one an analysis writes."""
    if not entry.is_file() or entry.is_symlink():
        return False
    file = entry.name
    return file in ('summary.json', 'metadata.yaml', 'analysis.png') or (
        file.startswith('analysis_') and file.endswith('.png')) or (
        file.startswith(f'{name}_') and file.endswith('.mcap')
        and file[len(name) + 1:-len('.mcap')].isdigit())


class DriveRun:
    """One drive's run: the pipeline, the assessor and what they produced."""

    def __init__(self, estimator_config: EstimatorConfig, health_config: HealthConfig,
                 motor_joint: str, load_joint: str, topic: str, transmission_name: str,
                 hardware_id: str, history: int | None = None, prior: ShapePrior | None = None,
                 drive: str | None = None) -> None:
        #: one drive of many: its topics are gear_phm/<drive>/..., its statuses
        #: named by it; None: the single transmission, today's names
        self.drive = drive
        self.estimator_status_name = (ESTIMATOR_STATUS_NAME if drive is None
                                      else f'gear_phm estimator: {drive}')
        # what the Analysis keeps: bounded histories (``history``) and the plot's envelopes
        self.measurements = Binned(history, _MEASUREMENT_COLUMNS)    # as columns (below)
        self.pending: list[tuple[int, Measurement, bool]] = []    # of the batch
        self.measured: dict[str, Binned] = {}    # envelopes of eta by measurements_key
        self.pipeline = EstimatorPipeline(estimator_config, on_measurement=self._on_measurement)
        self.assessor = HealthAssessor(health_config, prior)
        self.estimator_config = estimator_config
        self.motor_joint, self.load_joint, self.topic = motor_joint, load_joint, topic
        self.transmission_name = transmission_name
        self.hardware_id = hardware_id or transmission_name     # '': the drive's name
        self.history = history
        self.estimates = Binned(history, [f.name for f in fields(EstimateHistory)])
        self.states = Binned(history, _HEALTH_COLUMNS, objects=True)
        self.envelopes = {
            ESTIMATES: Binned(ENVELOPE_BINS, ('stamp_ns', 'u', 'eta_opposing', 'eta_aiding'),
                              ('u', 'eta_opposing', 'eta_aiding', 'u_low', 'u_high')),
            HEALTH: Binned(ENVELOPE_BINS, ('stamp_ns', 'level', 'rul_median', 'rul_p5',
                                           'rul_p95', 'u_eol'),
                           ('level', 'rul_median', 'rul_p5', 'rul_p95', 'u_eol', 'rul_unknown'))}
        if estimator_config.no_load_model:
            self.envelopes[NO_LOAD] = Binned(ENVELOPE_BINS, ('stamp_ns', *_NO_LOAD_COLUMNS),
                                             _NO_LOAD_COLUMNS)
        self.first_seen: dict[str, int] = {}
        self.truth: dict[str, tuple[Binned, Binned]] = {}    # by topic: history, envelope
        self.true_end_of_life_ns: int | None = None
        self.samples = 0
        #: the Analysis once the run finished (:meth:`finish`), for its plot
        self.analysis: Analysis | None = None

    def _on_measurement(self, measurement: Measurement, accepted: bool) -> None:
        stamp_ns = self.pipeline.stamp_ns(measurement.t)
        self.pending.append((stamp_ns, measurement, accepted))

    def result(self, bags: list[Path], readers: list[str], elapsed: float,
               names: Sequence[tuple[str, ...]] = ()) -> Analysis:
        """Return the Analysis of the run once every bag is read (AnalysisError: no sample).

        ``names``: the joint-name lists of the stream's first messages, for that error.
        """
        if self.pipeline.samples_seen == 0:
            drive = '' if self.drive is None else f' (drive {self.drive})'
            found = '; '.join(f'{count} messages {MESSAGE_REASON_TEXT.get(reason, reason)}'
                              for reason, count in self.pipeline.counts.items() if count)
            hint = codec.joints_hint(names, self.motor_joint, self.load_joint)
            named = f'; {hint}' if hint else ''
            raise AnalysisError(f'no message of topic {self.topic} has joints '
                                f'{self.motor_joint!r} and {self.load_joint!r}{drive} with a '
                                f'speed and a torque each: {found or "no message"}{named}')
        self._keep_measurements()
        summary = self._summary(bags, readers, elapsed)
        return self._analysis(summary)

    def _analysis(self, summary: DriveSummary) -> Analysis:
        """Return the Analysis of what was kept."""
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
        return Analysis(estimates, health, summary, self._measurements(), truth, None,
                        envelopes, self.true_end_of_life_ns)

    def _measurements(self) -> MeasuredWindows:
        """Return the kept measured windows: (stamp [ns], Measurement, accepted) on reading."""
        if not self.measurements.count:
            return MeasuredWindows({})
        return MeasuredWindows(self.measurements.first())

    def _keep_estimates(self, history: EstimateHistory,
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
        self._keep_measurements()

    def _keep_states(self, states: Sequence[HealthState]) -> None:
        """Add a batch's health states to the histories."""
        if states:
            health = HealthHistory.of(states)
            columns = {name: getattr(health, name) for name in _HEALTH_COLUMNS}
            self.states.extend(columns, health.messages)
            self.envelopes[HEALTH].extend(
                {**columns, 'rul_unknown': (~np.isfinite(health.rul_median)).astype(float)})

    def _keep_measurements(self) -> None:
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

    def keep_truth(self, name: str, stamps: np.ndarray, values: np.ndarray) -> None:
        """Add ground-truth rows (stamps [ns], x, y, z) of topic ``name``."""
        columns = {'stamp_ns': stamps, 'x': values[:, 0], 'y': values[:, 1],
                   'z': values[:, 2]}
        if name not in self.truth:
            self.truth[name] = (Binned(self.history, _TRUTH_COLUMNS),
                                Binned(ENVELOPE_BINS, _TRUTH_COLUMNS, ('x', 'y', 'z')))
        for kept in self.truth[name]:
            kept.extend(columns)
        if name == interfaces.TRUTH_FRICTION and self.true_end_of_life_ns is None:
            index = true_end_of_life_index(values[:, 0], self.assessor.u_eol)
            if index is not None:
                self.true_end_of_life_ns = int(stamps[index])

    def estimate(self, decoded: codec.JointBatch, messages: int, cuts: list[int],
                 write: bool) -> Estimated:
        """Run the estimator over one decoded batch; return its half of :meth:`advance`.

        ``cuts``: the batch's message index of each /diagnostics tick; ``write``: the
        outputs' columns are wanted (an output bag is written).
        """
        index = decoded.message_index
        marks = np.searchsorted(index, cuts, side='left').tolist()
        rejected_at = [(int(np.searchsorted(index, position)), reason)
                       for position, reason in decoded.rejected_at]
        estimates, snapshots = self.pipeline.on_batch_marked(
            decoded.stamp_ns, decoded.motor_velocity, decoded.motor_effort,
            decoded.load_velocity, decoded.load_effort, marks, rejected_at)
        history = EstimateHistory.of(estimates)     # the columns kept and written
        self._keep_estimates(history, estimates)
        statuses = tuple(replace(self.pipeline.status(self.estimator_status_name,
                                                      self.samples + cut, snapshot),
                                 hardware_id=self.hardware_id)     # as the node's
                         for cut, snapshot in zip(cuts, snapshots))
        self.samples += messages
        ends = tuple(snapshot.estimates for snapshot in snapshots)
        stamps = history.stamp_ns
        return Estimated(
            estimates, ends, statuses,
            tuple(int(stamps[end - 1]) if end else -1 for end in ends),
            bool(np.all(np.diff(stamps) > 0)),
            tuple(self._topics(estimate_columns(estimates, history,
                                                self.pipeline.config.no_load_model)))
            if write else ())

    def assess(self, estimates: Sequence[FrictionEstimate], ends: Sequence[int],
               ticks: Sequence[int], write: bool) -> Assessed:
        """Run the assessor over a batch's estimates; return its half of :meth:`advance`.

        ``ends[i]``: the estimates before /diagnostics tick ``ticks[i]`` [ns].
        """
        latest = [self.assessor.latest]         # the newest health state after i estimates
        states: list[HealthState] = []
        first_state = [0]                       # states[first_state[i]:] came after i
        for state in self.assessor.on_estimates(estimates):
            if state is not None:
                states.append(state)
            latest.append(state if state is not None else latest[-1])
            first_state.append(len(states))
        self._keep_states(states)
        statuses = tuple(self._health_statuses(tick, latest[end])
                         for tick, end in zip(ticks, ends))
        columns = (tuple(self._topics(interfaces.vector3_columns(
            states, interfaces.HEALTH_LAYOUT))) if write and states else ())
        return Assessed(statuses, columns,
                        tuple(first_state[end] for end in ends) + (first_state[-1],))

    def advance(self, decoded: codec.JointBatch, messages: int, cuts: list[int],
                ticks: list[int], write: bool) -> Made:
        """Run one decoded batch; return what the stream writes of it (:class:`Made`).

        :meth:`estimate`, then :meth:`assess` of its estimates (which
        :class:`~gear_phm.offline.parallel.SplitDrive` runs in two processes).
        ``cuts``: the batch's message index of each /diagnostics tick ``ticks`` [ns];
        ``write``: the outputs' columns are wanted (an output bag is written).
        """
        estimated = self.estimate(decoded, messages, cuts, write)
        return estimated.made(self.assess(estimated.estimates, estimated.ends, ticks, write))

    def final_statuses(self, stamp_ns: int) -> tuple[StatusOut, ...]:
        """Return the statuses of the final /diagnostics array, at ``stamp_ns`` [ns]."""
        return (self.final_estimator(), *self.final_health(stamp_ns))

    def final_estimator(self) -> StatusOut:
        """Return the estimator's status of the final /diagnostics array."""
        return replace(self.pipeline.status(self.estimator_status_name, self.samples, None),
                       hardware_id=self.hardware_id)

    def final_health(self, stamp_ns: int) -> tuple[StatusOut, ...]:
        """Return the health status of the final /diagnostics array (none before a state)."""
        return self._health_statuses(stamp_ns, self.assessor.latest)

    def health_half(self) -> HealthHalf:
        """Return what :meth:`assess` made of the run, for :meth:`take_health`."""
        return HealthHalf(self.assessor, self.states, self.envelopes[HEALTH], self.first_seen)

    def take_health(self, half: HealthHalf) -> None:
        """Take the assessor and what it made from another process's copy of this run."""
        self.assessor, self.states, self.first_seen = half.assessor, half.states, half.first_seen
        self.envelopes[HEALTH] = half.envelope

    def _topics(self, columns: list[Column]) -> Iterator[Column]:
        """Return output columns under this drive's topics (today's names for one drive)."""
        if self.drive is None:
            return iter(columns)
        return ((interfaces.drive_topic(self.drive, topic), stamps, values)
                for topic, stamps, values in columns)

    def finish(self, bags: list[Path], readers: list[str], elapsed: float,
               names: Sequence[tuple[str, ...]] = ()) -> Finished:
        """Return the run's Analysis and why its data contradict its parameters, or its error."""
        try:
            self.analysis = self.result(bags, readers, elapsed, names)
        except AnalysisError as exc:
            return Finished(None, str(exc), '')
        return Finished(self.analysis, '', _refusal(self))

    def plot(self, path: Path, bags: list[Path]) -> None:
        """Draw the finished run's plot into ``path`` (:func:`.plot.plot_analysis`)."""
        from gear_phm.offline.plot import plot_analysis
        assert self.analysis is not None, 'plot after finish'
        plot_analysis(path, self.analysis, self.estimator_config.ratio, bags,
                      drive='' if self.drive is None else self.drive)

    def _health_statuses(self, stamp_ns: int, latest: HealthState | None
                         ) -> tuple[StatusOut, ...]:
        """Return the diagnostics node's status at ``stamp_ns`` [ns] (none before a state)."""
        if latest is None:
            return ()
        self.first_seen.setdefault(LEVEL_NAMES[latest.level], stamp_ns)
        return (interfaces.health_status(latest, self.transmission_name, self.hardware_id),)

    def _summary(self, bags: list[Path], readers: list[str], elapsed: float) -> DriveSummary:
        """Return the run's summary, complete (STALE for a run with no filter update)."""
        estimator = EstimatorSummary.from_dict(self.pipeline.summary())
        windows = self.measurements.count
        why = estimator.unmeasured(windows)
        latest = self.assessor.latest
        first_seen, dropped = dict(self.first_seen), dict(self.assessor.rejected)
        if latest is None:
            health = HealthSummary('none', first_seen, dropped)
        else:
            trend = self.assessor.predictor.trend
            health = HealthSummary(
                LEVEL_NAMES[latest.level], first_seen, dropped, latest.message,
                dict(interfaces.health_key_values(latest)),
                TrendSummary(trend.model, trend.shape, self.assessor.u_eol))
        if why:     # the filter's prior is no estimate of the gearbox: no health level
            health = replace(health, level='STALE', message=f'no efficiency measurement: {why}')
        run = RunInfo(tuple(str(b) for b in bags), self.topic, self.samples, tuple(readers),
                      elapsed)
        return DriveSummary(estimator, run, windows, self.estimator_config, health, why or None)


class Stream:
    """One JointState stream read once for one or many drives (:class:`DriveRun` each).

    One drive with ``drive`` None is today's single transmission: its outputs, statuses and
    summary are those of the nodes. Each batch is decoded once for all drives
    (:func:`gear_phm.codec.decode_joint_state_pairs`); each /diagnostics tick writes one
    array with every drive's estimator and health status.
    """

    def __init__(self, runs: Sequence[DriveRun], topic: str, diagnostics_rate: float,
                 want_truth: bool, stamp_source: str = str(STAMP_SOURCE.default),
                 jobs: int = 1) -> None:
        self.runs = list(runs)
        #: worker processes for the drives (:func:`~gear_phm.offline.parallel.drives_for`)
        self.jobs = jobs
        #: the drives' processes, made once the first bag's size is known (:meth:`_read`)
        self.drives: LocalDrives | None = None
        self.topic = topic
        #: 'log': each sample is stamped with its message's record time in the bag
        self.log_stamps = stamp_source == 'log'
        #: the joint-name lists of the stream's first messages (for the error of a run that
        #: found none of its joints)
        self.names: list[tuple[str, ...]] | None = None
        self.diag_period_ns = int(1e9 / diagnostics_rate)
        self.want_truth = want_truth
        self.pairs = [(run.motor_joint, run.load_joint) for run in self.runs]
        self.next_tick: int | None = None        # next /diagnostics tick, bag time [ns]
        #: many drives: chunks joined into batches of BATCH messages (the drives' per-batch
        #: work then amortised); one transmission: batch by batch as the reader gives them,
        #: so that its results stay those of earlier versions to the last bit
        self.join = any(run.drive is not None for run in self.runs)

    def execute(self, bags: list[Path], directory: Path | None, progress: bool
                ) -> tuple[list[Finished], list[str], float]:
        """Read the bags into the runs; return each run's end, the readers, seconds.

        A run's end is its :class:`~gear_phm.offline.parallel.Finished` record. The drives'
        workers, if any, stay for the plots: :meth:`close` ends them (analyze_bag's finally).
        """
        from gear_phm.bagio import BagError, Rosbag2McapWriter
        started = time.perf_counter()
        readers = []
        try:
            with (nullcontext(None) if directory is None
                  else Rosbag2McapWriter(directory, batch=True)) as writer:
                for path in bags:
                    readers.append(self._read(path, writer, progress))
        except BagError as exc:
            raise AnalysisError(str(exc)) from None
        elapsed = time.perf_counter() - started
        assert self.drives is not None              # made by the first bag's _read
        return self.drives.finish(bags, readers, elapsed, self.names or ()), readers, elapsed

    def plot(self, paths: list[Path], bags: list[Path]) -> None:
        """Draw each finished drive's plot into its path (in its worker, if any)."""
        assert self.drives is not None
        self.drives.plot(paths, bags)

    def close(self) -> None:
        """End the drives' worker processes, if any (after :meth:`execute` and plots)."""
        if self.drives is not None:
            self.drives.close()

    def _truth_topics(self, bag: Any) -> dict[str, tuple[int, str]]:
        """Return {bag topic: (run index, canonical truth topic)} of the truth the bag holds."""
        found = {}
        for index, run in enumerate(self.runs if self.want_truth else ()):
            for name in (interfaces.TRUTH_FRICTION, interfaces.TRUTH_EFFICIENCY,
                         interfaces.TRUTH_NO_LOAD):
                topic = bag.resolve_topic(name if run.drive is None
                                          else interfaces.drive_topic(run.drive, name))
                if topic in bag.topics:
                    found[topic] = (index, name)
        return found

    def _read(self, path: Path, writer: Any, progress: bool) -> str:
        """Feed one bag; returns the reader kind used."""
        from gear_phm.bagio import BagReader
        with BagReader(path) as bag:
            topic = bag.require_topic(self.topic, interfaces.JOINT_STATE_TYPE)
            total = bag.message_count(topic)
            if total == 0:
                raise AnalysisError(f'topic {topic} in bag {path} has no message')
            truth_topics = self._truth_topics(bag)
            if self.drives is None:         # the workers (if any), for a bag of this size
                self.drives = drives_for(self.runs, self.jobs, total)
            drives = self.drives
            bar = _progress(total, not progress)
            self.next_tick = None
            last_log_ns: int | None = None       # of the bag's last JointState
            write = writer is not None
            # each batch's drives run (in their workers, if any) while the next is read and
            # decoded; then it is written, in order
            batches = (self._prepared(raw)
                       for raw in self._joint_batches(bag, topic, truth_topics))
            # (``drives.ahead``: the next batch is submitted before this one is collected)

            def submit(batch: _Prepared | None) -> None:
                if batch is not None:
                    drives.submit(batch.decoded, batch.messages, batch.cuts, batch.ticks, write)
            current = next(batches, None)
            submit(current)
            while current is not None:
                upcoming = next(batches, None)
                if drives.ahead:
                    submit(upcoming)
                self.write_batch(drives.collect(), current.ticks, writer)
                bar.update(current.messages)
                last_log_ns = current.last_log_ns
                if not drives.ahead:
                    submit(upcoming)
                current = upcoming
            if last_log_ns is not None:          # the final state, at the last message
                final = interfaces.DiagnosticsOut(last_log_ns, tuple(
                    status for statuses in drives.final(last_log_ns)
                    for status in statuses))
                if writer is not None:
                    writer.write_output(final)
            bar.close()
            return bag.reader_kind

    def _joint_batches(self, bag: Any, topic: str, truth_topics: dict[str, tuple[int, str]]
                       ) -> Iterator[RawBatch]:
        """Yield the bag's JointState batches (chunks joined by BATCH with many drives).

        The ground truth met on the way goes to its drive, for the plot.
        """
        pending: list[RawBatch] = []             # JointState chunks, processed by BATCH
        for raw in bag.raw_batches([topic, *truth_topics], batch_size=BATCH):
            stopping.check()                     # a signal's stop that was swallowed
            if raw.topic != topic:               # ground truth, for the plot only
                stamps, values = interfaces.vector3_stamped_columns(
                    raw.buffer, raw.offsets, raw.lengths)
                index, name = truth_topics[raw.topic]
                assert self.drives is not None
                self.drives.keep_truth(index, name, stamps, values)
                continue
            pending.append(raw)
            if not self.join or sum(len(p) for p in pending) >= BATCH:
                yield _joined(pending)
                pending = []
        if pending:
            yield _joined(pending)

    def _prepared(self, raw: RawBatch) -> _Prepared:
        """Return one batch of JointState decoded for every drive, with its ticks."""
        times = raw.log_time_ns
        if self.next_tick is None:
            self.next_tick = int(times[0]) + self.diag_period_ns
        ticks = []
        while self.next_tick <= int(times[-1]):
            ticks.append(self.next_tick)
            self.next_tick += self.diag_period_ns
        cuts = np.searchsorted(times, ticks, side='left').tolist()
        if self.names is None:           # the first batch's (once, even if it names none)
            self.names = codec.joint_names(raw.buffer, raw.offsets, raw.lengths)
        decoded = codec.decode_joint_state_pairs(raw.buffer, raw.offsets, raw.lengths,
                                                 self.pairs)
        if self.log_stamps:             # each drive's samples at their messages' log times
            logged = np.asarray(times, dtype=np.int64)
            decoded = [replace(batch, stamp_ns=logged[batch.message_index]) for batch in decoded]
        elif any(batch.stamp_ns.size and int(batch.stamp_ns.min()) < 0 for batch in decoded):
            msg = (f'topic {self.topic}: header stamps before 1970 (negative), which no output '
                   "bag can hold; analyse on the bag's record times: --stamp-source log")
            raise AnalysisError(msg)
        return _Prepared(decoded, len(raw), cuts, ticks, int(times[-1]))

    def write_batch(self, made: list[Made], ticks: list[int], writer: Any) -> None:
        """Write one batch: each status after the outputs of the estimates before its mark.

        ``made``: each drive's outputs and statuses (:meth:`DriveRun.advance`); ``ticks`` are the
        /diagnostics times [ns] of bag time inside the batch; the statuses report the state
        after the messages logged before each (marks of the pipeline, not cuts of the batch).
        """
        if writer is None:
            return
        outs = [interfaces.DiagnosticsOut(tick, tuple(
            status for drive in made for status in drive.statuses[i]))
            for i, tick in enumerate(ticks)]
        if all(drive.increasing for drive in made):      # one block
            between = [(max(drive.limits[i] for drive in made), out)
                       for i, out in enumerate(outs)]
            writer.write_vector3_columns([c for drive in made for c in drive.columns],
                                         between=between)
            return
        for i, out in enumerate(outs):          # stamps restarted inside the batch: by parts
            writer.write_vector3_columns([c for drive in made for c in drive.part(i)])
            writer.write_output(out)
        writer.write_vector3_columns([c for drive in made for c in drive.part(len(outs))])


def _joined(batches: list[RawBatch]) -> RawBatch:
    """Return consecutive batches of one topic as one.

    An MCAP chunk holds a few hundred messages: each drive's per-batch work is then paid once
    per :data:`BATCH` messages.
    """
    if len(batches) == 1:
        return batches[0]
    from gear_phm.bagio.chunks import RawBatch
    sizes = [len(b.buffer) for b in batches]
    starts = np.cumsum([0, *sizes[:-1]])
    return RawBatch(batches[0].topic, np.concatenate([b.log_time_ns for b in batches]),
                    b''.join(bytes(b.buffer) for b in batches),
                    np.concatenate([b.offsets + start for b, start in zip(batches, starts)]),
                    np.concatenate([b.lengths for b in batches]))


@dataclass(frozen=True)
class _Prepared:
    """One batch of the stream decoded for every drive: its messages, ticks and cuts."""

    decoded: list[codec.JointBatch]
    messages: int
    #: the batch's message index of each /diagnostics tick
    cuts: list[int]
    #: the /diagnostics ticks [ns] of bag time inside the batch
    ticks: list[int]
    #: the log time [ns] of its last message
    last_log_ns: int


#: The estimate fields written from the estimates themselves (not :class:`EstimateHistory`).
_FROM_ESTIMATES = ('measurement', 'measurement_variance', 'direction_offset',
                   'measurement_direction', 'measurement_bias', 'no_load_torque',
                   'no_load_sigma', 'total_efficiency')


def estimate_columns(estimates: Sequence[FrictionEstimate], history: EstimateHistory,
                     no_load: bool = False) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """Return :func:`gear_phm.interfaces.vector3_columns` of estimates, from their ``history``.

    The estimator's outputs as ``(topic, stamps [ns], xyz)`` columns, in publishing order
    (:data:`gear_phm.interfaces.ESTIMATE_LAYOUT`; the diagnostics node's are
    ``vector3_columns(states, HEALTH_LAYOUT)``). The measurements and the direction offset,
    which the history does not hold, are read from the estimates; with ``no_load`` also
    :data:`gear_phm.interfaces.NO_LOAD_LAYOUT`.
    """
    row = operator.attrgetter(*_FROM_ESTIMATES)
    measured = np.array([row(e) for e in estimates], dtype=float).reshape(
        -1, len(_FROM_ESTIMATES))
    source = {'u_sigma': history.u_sigma,
              **{name: measured[:, i] for i, name in enumerate(_FROM_ESTIMATES)}}
    return [(topic, history.stamp_ns,
             np.column_stack([source[name] if name in source else getattr(history, name)
                              for name in names]).astype(float))
            for topic, names in interfaces.estimate_layout(no_load)]


class _NoProgress:
    def update(self, n: int) -> None:
        pass

    def close(self) -> None:
        pass


def _progress(total: int, disabled: bool) -> Any:
    if disabled:
        return _NoProgress()
    from tqdm import tqdm
    return tqdm(total=total, unit='msg', unit_scale=True, file=sys.stderr, mininterval=0.5,
                desc='analyze')
