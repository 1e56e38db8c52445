"""The offline engine: recorded JointState in, the live nodes' estimates and health out.

:func:`analyze_bag` runs one :class:`~gear_phm.offline.drive.DriveRun` per drive (the
estimator and diagnostics nodes' code of :mod:`gear_phm.run`, plus the histories the Analysis
returns) over one bag, or several in order of their start time, as fast as the bag can be
read. It returns an :class:`~gear_phm.offline.records.Analysis` of numpy histories and,
given ``out``, writes the same topics the nodes publish as a rosbag2 MCAP directory, plus
``summary.json`` and ``analysis.png``. This module holds the stream loop; the options are
:mod:`gear_phm.offline.options`, the bags' discovery :mod:`gear_phm.bagio.discovery`, the
output checks :mod:`gear_phm.offline.outputs`, the summaries :mod:`gear_phm.offline.results`
and the progress bar :mod:`gear_phm.offline.progress`.

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

from collections.abc import Iterator, Sequence
from contextlib import nullcontext
from dataclasses import dataclass, replace
from pathlib import Path
import time
from typing import Any, TYPE_CHECKING

import numpy as np

from gear_phm import codec, interfaces, stopping
from gear_phm.offline.drive import DriveRun
from gear_phm.offline.options import (AnalysisError, AnalyzeOptions, bag_paths, drive_setups,
                                      HISTORY)
from gear_phm.offline.outputs import check_out
from gear_phm.offline.parallel import drives_for, Finished, LocalDrives, Made, start_plotter
from gear_phm.offline.progress import progress_bar
from gear_phm.offline.records import Analysis
from gear_phm.offline.results import combined, run_info, summary_of, unmeasured
from gear_phm.parameters import STAMP_SOURCE
from gear_phm.staging import Staged

if TYPE_CHECKING:
    from gear_phm.bagio.chunks import RawBatch

__all__ = ['AnalysisError', 'AnalyzeOptions', 'DriveRun', 'HISTORY', 'Stream', 'analyze',
           'analyze_bag']

#: Messages per batch when the bag is read through rosbags (indexed MCAP goes by chunk).
BATCH = 20000


def analyze_bag(path_or_paths: str | Path | Sequence[str | Path],
                ratio: float | AnalyzeOptions | None = None, **keywords: Any) -> Analysis:
    """Run the estimator and diagnostics nodes' code over recorded bags.

    ``analyze_bag(bags, options)`` with one :class:`~gear_phm.offline.options.AnalyzeOptions`
    (:func:`analyze`), or ``analyze_bag(bags, ratio, **keywords)`` with its fields and the
    estimator or health parameters as keywords (``AnalyzeOptions.of(ratio, **keywords)``).

    ``path_or_paths``: a rosbag2 directory, a ``.mcap``/``.db3`` file or a ROS1 ``.bag``, a
    folder of them, or a list of these (analysed as one run, in order of their start
    times). ``ratio`` is the gearbox's R = z2/z1 [-]. The other keywords are estimator or
    health parameters by name, as in config/estimator.yaml and config/diagnostics.yaml (e.g.
    ``eta_opposing_min=0.7333``).
    With ``out``, writes the output bag, ``summary.json`` and (``plot``) ``analysis.png`` into
    that directory, which must not exist (or, with ``overwrite``, hold an earlier analysis and
    nothing else), nor hold a bag being analysed; nothing is left there if the analysis fails.

    ``transmissions`` (instead of ``ratio`` and the joints): many drives in one JointState
    stream (:mod:`gear_phm.transmissions`), as a file path, its parsed YAML document, or
    :class:`~gear_phm.transmissions.Transmission` records; the parameters then apply to each
    drive that does not set its own. The bags are read once; each drive has its own estimator
    and assessor, its outputs under ``gear_phm/<drive>/...``, its statuses ``gear_phm:
    <drive>`` (hardware_id ``<drive>``) and ``gear_phm estimator: <drive>``; ``summary.json``
    holds ``transmissions: {<drive>: <a single-transmission summary>}`` and the plots are
    ``analysis_<drive>.png``. The returned Analysis holds the combined summary and each
    drive's own Analysis in ``transmissions``. ``jobs``: worker processes, 0 for one per core
    (:mod:`gear_phm.offline.parallel`; 1, the default: all in this process): with many drives
    each worker runs its share of them; one drive's health assessment runs in a worker beside
    its estimator. The results are the same whatever ``jobs``.

    Memory does not grow with the bags. The returned histories (estimates, health states,
    measured windows and, with ``plot``, the ground truth) keep between ``history`` (default
    :data:`~gear_phm.offline.options.HISTORY`) and twice as many records each, evenly spaced
    from the first, plus the last record; ``history=None`` keeps every record (memory then
    grows with the bags). The output bag and the summary always cover every record.
    ``Analysis.envelopes`` holds the plotted series in at most 2 x
    :data:`~gear_phm.offline.decimate.ENVELOPE_BINS` bins with each bin's min and max,
    whatever ``history``. ``prior``: a population prior on the wear law's shape
    (:class:`~gear_phm.prognostics.ShapePrior`, ``gear-phm fleet --population-prior``).
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
    if isinstance(ratio, AnalyzeOptions):
        if keywords:
            raise AnalysisError(f'give the options or keywords, not both: {sorted(keywords)}')
        return analyze(path_or_paths, ratio)
    return analyze(path_or_paths, AnalyzeOptions.of(ratio, **keywords))


def analyze(path_or_paths: str | Path | Sequence[str | Path],
            options: AnalyzeOptions) -> Analysis:
    """Run the drives of ``options`` over the bags (:func:`analyze_bag`, which documents it)."""
    from gear_phm.bagio import BagError
    from gear_phm.bagio.discovery import order_bags
    options = options.checked()
    setups = drive_setups(options)
    runs = [DriveRun(setup, options.topic, options.history, options.prior)
            for setup in setups]
    paths = bag_paths(path_or_paths)
    try:
        bags = order_bags(paths)
    except BagError as exc:
        raise AnalysisError(str(exc)) from None
    target = None if options.out is None else check_out(Path(options.out), options.overwrite,
                                                        bags)
    stream = Stream(runs, options.topic, options.diagnostics_rate, options.plot,
                    options.stamp_source, options.checked_jobs())
    # the plots' process imports matplotlib meanwhile; not where drive workers may draw them
    plotter = (start_plotter() if options.plot and target is not None
               and (len(runs) == 1 or stream.jobs == 1) else None)
    staged = None if target is None else Staged(target, AnalysisError, replace=True)
    try:
        finished, readers, elapsed = stream.execute(
            bags, None if staged is None else staged.path, options.progress)  # closed: finally
        analyses = _analyses(finished, runs, options)
        if not any(run.names.listed for run in runs):     # the single transmission's own
            analysis = analyses[0]
        else:                                   # a transmissions list: the summary of all
            info = run_info(bags, stream.topic, summary_of(analyses[0]).run.messages, readers,
                            elapsed)
            analysis = combined([run.names.drive for run in runs], analyses, info,
                                0 if stream.drives is None else stream.drives.workers)
        if staged is not None:
            _write(staged.path, analysis, analyses, options.plot, stream, plotter, bags)
            staged.commit()
            analysis = replace(analysis, out=target)
        return analysis
    finally:
        stream.close()
        if plotter is not None:
            plotter.close()
        if staged is not None:
            staged.discard()


def _analyses(finished: list[Finished], runs: list[DriveRun], options: AnalyzeOptions
              ) -> list[Analysis]:
    """Return each drive's Analysis; AnalysisError for a drive's error or refusal.

    Also when the stamps do not advance, and when no drive has a filter update.
    """
    analyses = []
    for end in finished:
        if end.analysis is None:
            raise AnalysisError(end.error)
        analyses.append(end.analysis)
    for end in finished:
        if end.refusal:
            raise AnalysisError(end.refusal)
    summaries = [summary_of(analysis) for analysis in analyses]
    topic = options.topic
    stalled = summaries[0].estimator.stalled_stamps()     # the drives share the stamps
    if stalled:
        remedy = ("; analyse on the bag's record times instead: stamp_source='log' "
                  '(gear-phm analyze --stamp-source log)' if options.stamp_source == 'header'
                  else '')
        raise AnalysisError(f'topic {topic}: no efficiency measurement, {stalled}{remedy}')
    # no filter update: the filter's prior is no estimate of the gearbox (results.unmeasured)
    why = unmeasured(summaries, [run.names.label for run in runs])
    if why:
        raise AnalysisError(f'topic {topic}: no efficiency measurement, {why}')
    return analyses


def _write(written: Path, analysis: Analysis, analyses: list[Analysis], plot: bool,
           stream: Stream, plotter: Any, bags: list[Path]) -> None:
    """Write ``summary.json`` and (``plot``) each drive's plot into ``written``."""
    (written / 'summary.json').write_text(analysis.summary.to_json() + '\n')
    if not plot:
        return
    runs = stream.runs
    pngs = [written / run.names.plot_file for run in runs]
    if plotter is not None:
        plotter.plot([(png, drive, run.estimator_config.ratio, bags, run.names.drive)
                      for png, run, drive in zip(pngs, runs, analyses)])
    else:                   # each drive's in its worker, if any
        stream.plot(pngs, bags)


class Stream:
    """One JointState stream read once for one or many drives (:class:`DriveRun` each).

    The single transmission is a list of one run (:meth:`gear_phm.run.DriveNames.single`): its
    outputs, statuses and summary are those of the nodes. Each batch is decoded once for all drives
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
        #: drives of a transmissions list: chunks joined into batches of BATCH messages (the
        #: drives' per-batch work then amortised); the single transmission: batch by batch as
        #: the reader gives them, so that its results stay those of earlier versions to the
        #: last bit
        self.join = any(run.names.listed for run in self.runs)

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
                topic = bag.resolve_topic(run.names.topic(name))
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
            bar = progress_bar(total, not progress)
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
