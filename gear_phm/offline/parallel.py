"""The drives of one stream over the machine's cores: each drive's work in a worker process.

A bag's drives are independent once each message is decoded: each has its own estimator and
assessor (:class:`gear_phm.offline.drive.DriveRun`). The stream reads and decodes each batch
once, in the calling process, and hands each drive its columns; it then writes what the
drives made, in drive order, as :class:`Made` records. :class:`LocalDrives` runs the drives
in the calling process; :class:`DrivePool` in worker processes, each owning a fixed share of
the drives (drive i in worker i mod N) for the whole run, while the calling process reads and
decodes the next batch and writes the last one. Each drive's arithmetic is the same either
way, and the stream writes the same records in the same order: the output bag, the summaries
and the plots do not depend on ``jobs``.

Each worker is a one-process :class:`concurrent.futures.ProcessPoolExecutor` on the ``fork``
start method (:class:`_Worker`): forked with its share of the drives as they are, it runs
their requests in the order they are sent, so their state in it follows the batches. Workers
are forked only from a process that runs no thread but the pools' own; where that is not so,
the drives stay in the calling process. A worker ignores SIGINT (the caller stops it), and on
Linux it is killed with its caller (``PR_SET_PDEATHSIG``), so it does not outlive a caller
that was killed.
"""
from __future__ import annotations

import collections
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
import multiprocessing
import multiprocessing.process
import os
import signal
import sys
import threading
import time
from typing import Any, Protocol, Sequence, TYPE_CHECKING
import warnings

import numpy as np

from gear_phm.errors import GearPhmError
from gear_phm.status import StatusOut

if TYPE_CHECKING:
    from gear_phm.codec import JointBatch
    from gear_phm.offline.decimate import Binned
    from gear_phm.offline.records import Analysis
    from gear_phm.prognostics import HealthAssessor

#: An output column: (topic, stamps [ns], values (N, 3)), as ``write_vector3_columns`` takes.
Column = tuple[str, np.ndarray, np.ndarray]


class ParallelError(GearPhmError, RuntimeError):
    """A drive worker process failed or ended without answering."""


_GONE = 'a drive worker process ended without answering (killed, or out of memory?)'


@dataclass(frozen=True)
class Made:
    """What one drive made of one batch, as the stream writes it (picklable).

    ``statuses[i]``: the drive's statuses at /diagnostics tick ``i``; ``limits[i]``: the stamp
    [ns] of its last estimate before tick ``i`` (-1: none); ``increasing``: its estimates'
    stamps increase through the batch; ``columns``: the outputs of all its estimates (the
    first ``estimate_columns`` one row per estimate, the others one row per health state);
    ``ends[i]``: its estimates before tick ``i``; ``state_ends[i]``: its health states before
    the first estimate after tick ``i`` (the last: all of them); ``estimates``: how many.
    """

    statuses: tuple[tuple[StatusOut, ...], ...]
    limits: tuple[int, ...]
    increasing: bool
    columns: tuple[Column, ...]
    estimate_columns: int
    ends: tuple[int, ...]
    state_ends: tuple[int, ...]
    estimates: int

    def part(self, i: int) -> list[Column]:
        """Return the outputs of the estimates between tick ``i - 1`` and tick ``i``.

        ``i`` = the number of ticks: those after the last tick.
        """
        done = self.ends[i - 1] if i else 0
        end = self.ends[i] if i < len(self.ends) else self.estimates
        first = self.state_ends[i - 1] if i else 0
        last = self.state_ends[i]
        return [(topic, stamps[done:end], values[done:end]) if k < self.estimate_columns
                else (topic, stamps[first:last], values[first:last])
                for k, (topic, stamps, values) in enumerate(self.columns)]


@dataclass(frozen=True)
class Estimated:
    """The estimator's half of what one drive made of one batch (``DriveRun.estimate``).

    ``ends[i]``: its estimates before /diagnostics tick ``i``; ``statuses[i]``: the
    estimator's status there; ``limits[i]``: the stamp [ns] of the last estimate before it
    (-1: none); ``increasing``: the estimates' stamps increase through the batch;
    ``columns``: their outputs (if written).
    """

    estimates: list[Any]
    ends: tuple[int, ...]
    statuses: tuple[StatusOut, ...]
    limits: tuple[int, ...]
    increasing: bool
    columns: tuple[Column, ...]

    def made(self, assessed: Assessed) -> Made:
        """Return the batch's :class:`Made`, with the assessor's half."""
        return Made(tuple((status, *health) for status, health in
                          zip(self.statuses, assessed.statuses)),
                    self.limits, self.increasing, self.columns + assessed.columns,
                    len(self.columns), self.ends, assessed.state_ends,
                    len(self.estimates))


@dataclass(frozen=True)
class Assessed:
    """The assessor's half of what one drive made of one batch (``DriveRun.assess``).

    ``statuses[i]``: the health status at /diagnostics tick ``i`` (none before a state);
    ``columns``: the health states' outputs (if written); ``state_ends[i]``: the states
    before the first estimate after tick ``i`` (the last: all of them).
    """

    statuses: tuple[tuple[StatusOut, ...], ...]
    columns: tuple[Column, ...]
    state_ends: tuple[int, ...]


@dataclass(frozen=True)
class HealthHalf:
    """A run's assessor and what it kept, handed from the process that ran it."""

    assessor: HealthAssessor
    states: Binned
    envelope: Binned
    first_seen: dict[str, int]


@dataclass(frozen=True)
class Finished:
    """A drive's end of run: its Analysis and refusal ('' if none), or its error's text."""

    analysis: Analysis | None
    error: str
    refusal: str


class DriveRun(Protocol):
    """One drive's estimator and assessor (:class:`gear_phm.offline.drive.DriveRun`)."""

    def advance(self, decoded: JointBatch, messages: int, cuts: list[int], ticks: list[int],
                write: bool) -> Made: ...

    def keep_truth(self, name: str, stamps: np.ndarray, values: np.ndarray) -> None: ...

    def final_statuses(self, stamp_ns: int) -> tuple[StatusOut, ...]: ...

    def estimate(self, decoded: JointBatch, messages: int, cuts: list[int],
                 write: bool) -> Estimated: ...

    def assess(self, estimates: Sequence[Any], ends: Sequence[int], ticks: Sequence[int],
               write: bool) -> Assessed: ...

    def final_health(self, stamp_ns: int) -> tuple[StatusOut, ...]: ...

    def final_estimator(self) -> StatusOut: ...

    def health_half(self) -> HealthHalf: ...

    def take_health(self, half: HealthHalf) -> None: ...

    def finish(self, bags: list[Any], readers: list[str], elapsed: float,
               names: Sequence[tuple[str, ...]] = ()) -> Finished: ...

    def plot(self, path: Any, bags: list[Any]) -> None: ...


class LocalDrives:
    """The drives in the calling process, in order."""

    #: worker processes (none: the drives run in the calling process)
    workers = 0
    #: the caller may :meth:`submit` the next batch before it collects the last one
    ahead = False

    def __init__(self, runs: Sequence[DriveRun]) -> None:
        self.runs = list(runs)
        self._made: list[Made] = []

    def submit(self, decoded: Sequence[JointBatch], messages: int, cuts: list[int],
               ticks: list[int], write: bool) -> None:
        """Start one batch (:meth:`advance`); :meth:`collect` returns what it made."""
        self._made = self.advance(decoded, messages, cuts, ticks, write)

    def collect(self) -> list[Made]:
        """Return what the drives made of the batch submitted last, in drive order."""
        made, self._made = self._made, []
        return made

    def advance(self, decoded: Sequence[JointBatch], messages: int, cuts: list[int],
                ticks: list[int], write: bool) -> list[Made]:
        """Run each drive over its columns of one batch (``decoded``, in drive order).

        A :class:`DrivePool` worker's request for its drives, too.
        """
        return [run.advance(batch, messages, cuts, ticks, write)
                for run, batch in zip(self.runs, decoded)]

    def keep_truth(self, index: int, name: str, stamps: np.ndarray, values: np.ndarray) -> None:
        """Give drive ``index`` ground-truth rows (stamps [ns], x, y, z) of topic ``name``."""
        self.runs[index].keep_truth(name, stamps, values)

    def final(self, stamp_ns: int) -> list[tuple[StatusOut, ...]]:
        """Return each drive's statuses of the final /diagnostics array at ``stamp_ns``."""
        return [run.final_statuses(stamp_ns) for run in self.runs]

    def finish(self, bags: list[Any], readers: list[str], elapsed: float,
               names: Sequence[tuple[str, ...]] = ()) -> list[Finished]:
        """Return each drive's end of run."""
        return [run.finish(bags, readers, elapsed, names) for run in self.runs]

    def plot(self, paths: Sequence[Any], bags: list[Any]) -> None:
        """Draw each finished drive's plot into its path (``paths`` in drive order)."""
        for run, path in zip(self.runs, paths):
            run.plot(path, bags)

    def close(self) -> None:
        """Release the drives' processes (none here)."""


def usable_cores() -> int:
    """Return the cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


#: ``jobs`` 0 starts workers for at least this many samples (messages times drives) in the
#: first bag: fewer are read faster than workers start and trade data.
AUTO_MIN_SAMPLES = 100_000


def drives_for(runs: Sequence[DriveRun], jobs: int, messages: int = 0) -> LocalDrives:
    """Return the drives in worker processes, or in this one.

    ``jobs``: worker processes, at most one per drive; 1: none. 0: one per usable core, for a
    bag of at least :data:`AUTO_MIN_SAMPLES` ``messages`` times drives. One drive with two
    or more: its assessor in a worker (:class:`SplitDrive`). None where workers cannot be
    forked (:func:`can_fork`).
    """
    if jobs == 0:
        jobs = usable_cores() if messages * len(runs) >= AUTO_MIN_SAMPLES else 1
    if jobs <= 1 or not can_fork():
        return LocalDrives(runs)
    if len(runs) == 1:
        return SplitDrive(runs[0])
    return DrivePool(runs, min(jobs, len(runs)))


def can_fork() -> bool:
    """Whether workers may be forked here: POSIX ``fork``, no other thread, no ROS running.

    A thread holding a lock (of a stream, of logging) at the fork would leave it locked in
    the child for good; Python 3.12 warns of the same. In a process with threads (a notebook's
    kernel, a Dask worker) the drives stay in the calling process. The threads of this
    module's own pools (:func:`_pool_thread`) do not count: they wait on their queues, and the
    child never uses them. A process with an rclpy context up (a DDS participant: native
    threads and shared memory that ``threading`` does not see) does not fork either.
    """
    others = [thread for thread in threading.enumerate()
              if thread is not threading.current_thread() and not _pool_thread(thread)]
    return ('fork' in multiprocessing.get_all_start_methods() and not others
            and not _ros_running())


def _pool_thread(thread: threading.Thread) -> bool:
    """Whether ``thread`` is a concurrent.futures pool's manager or its queue's feeder."""
    return (type(thread).__name__ == '_ExecutorManagerThread'
            or thread.name == 'QueueFeederThread')


def _ros_running() -> bool:
    """Whether rclpy is imported and its default context is initialised."""
    rclpy = sys.modules.get('rclpy')
    try:
        return rclpy is not None and bool(rclpy.ok())
    except Exception:                   # noqa: B902 - an rclpy in any state: assume it runs
        return True


class DrivePool(LocalDrives):
    """The drives in ``workers`` forked processes: drive i in worker i mod ``workers``."""

    def __init__(self, runs: Sequence[DriveRun], workers: int) -> None:
        super().__init__(runs)
        self.workers = workers
        self.groups = [list(range(w, len(self.runs), workers)) for w in range(workers)]
        self.pools: list[_Worker] = []
        #: requests without an answer (ground truth), sent with the next that has one, so a
        #: worker's requests keep the order of the batches they belong to
        self.queued: list[list[tuple[Any, ...]]] = [[] for _ in self.groups]
        #: the workers' processes
        self.processes: list[multiprocessing.process.BaseProcess] = []
        try:
            for group in self.groups:
                worker = _Worker(LocalDrives([self.runs[i] for i in group]))
                self.pools.append(worker)
                self.processes.append(worker.process)
        except BaseException:
            self.close()
            raise

    def _send(self, requests: Sequence[tuple[Any, ...]]) -> None:
        """Send each worker its queued requests, then ``requests[w]``.

        ParallelError if a worker is gone (killed between two batches).
        """
        for worker, queued, request in zip(self.pools, self.queued, requests):
            for earlier in queued:
                _request(worker, earlier)
            _request(worker, request)
            queued.clear()

    def _ask(self, requests: Sequence[tuple[Any, ...]]) -> list[Any]:
        """Send each worker its request; return their answers, in worker order."""
        self._send(requests)
        return [_answer(worker) for worker in self.pools]

    def submit(self, decoded: Sequence[JointBatch], messages: int, cuts: list[int],
               ticks: list[int], write: bool) -> None:
        """Send each worker its drives' columns of one batch; :meth:`collect` waits."""
        self._send([('advance', [decoded[i] for i in group], messages, cuts, ticks, write)
                    for group in self.groups])

    def collect(self) -> list[Made]:
        """Return what the drives made of the batch submitted last, in drive order."""
        return self._ordered([_answer(worker) for worker in self.pools])

    def _ordered(self, answers: list[list[Any]]) -> list[Any]:
        """Return the workers' answers (a list per worker) in drive order."""
        ordered: list[Any] = [None] * len(self.runs)
        for group, answer in zip(self.groups, answers):
            for i, value in zip(group, answer):
                ordered[i] = value
        return ordered

    def advance(self, decoded: Sequence[JointBatch], messages: int, cuts: list[int],
                ticks: list[int], write: bool) -> list[Made]:
        """Run each drive over its columns of one batch, in its worker."""
        self.submit(decoded, messages, cuts, ticks, write)
        return self.collect()

    def keep_truth(self, index: int, name: str, stamps: np.ndarray, values: np.ndarray) -> None:
        """Give drive ``index`` ground-truth rows, in its worker (no answer)."""
        w = index % len(self.groups)
        self.queued[w].append(('keep_truth', self.groups[w].index(index), name, stamps, values))

    def final(self, stamp_ns: int) -> list[tuple[StatusOut, ...]]:
        """Return each drive's statuses of the final /diagnostics array at ``stamp_ns``."""
        return self._ordered(self._ask([('final', stamp_ns)] * len(self.groups)))

    def finish(self, bags: list[Any], readers: list[str], elapsed: float,
               names: Sequence[tuple[str, ...]] = ()) -> list[Finished]:
        """Return each drive's end of run, from its worker."""
        return self._ordered(self._ask(
            [('finish', bags, readers, elapsed, names)] * len(self.groups)))

    def plot(self, paths: Sequence[Any], bags: list[Any]) -> None:
        """Draw each finished drive's plot into its path, in its worker."""
        self._ask([('plot', [paths[i] for i in group], bags) for group in self.groups])

    def close(self) -> None:
        """End the workers: their pools shut down (an idle worker returns), then joined.

        A worker still busy with a batch (the caller stopped on an error or a signal) is
        terminated after a second.
        """
        _end(self.pools)
        self.pools, self.processes = [], []


class SplitDrive(LocalDrives):
    """One drive over two processes: its estimator here, its assessor in a forked worker.

    A single drive's time goes about half to reading, estimating and writing, half to the
    health assessment (the RUL refits, per estimate the levels); they run side by side, one
    batch apart. :meth:`submit` runs the estimator over a batch at once and hands its
    estimates to the worker when the worker is free; :meth:`collect` returns the oldest
    batch's :class:`Made` (``ahead``: the caller submits the next batch first, so that its
    estimation overlaps this one's assessment). The worker is this process forked before the
    first batch: its copy of the run assesses, and :meth:`finish` takes its assessor back.
    """

    ahead = True
    workers = 1

    def __init__(self, run: DriveRun) -> None:
        super().__init__([run])
        #: estimated batches not yet collected, the oldest first; the oldest is the worker's
        self.waiting: list[tuple[Estimated, list[int], bool]] = []
        # the worker serves its copy of the run: assess, final_health, health_half
        self.worker = _Worker(run)
        self.process = self.worker.process

    def submit(self, decoded: Sequence[JointBatch], messages: int, cuts: list[int],
               ticks: list[int], write: bool) -> None:
        """Run the estimator over one batch; the worker assesses it once it is free."""
        estimated = self.runs[0].estimate(decoded[0], messages, cuts, write)
        self.waiting.append((estimated, ticks, write))
        if len(self.waiting) == 1:
            self._hand()

    def _hand(self) -> None:
        """Send the worker the estimates of the oldest waiting batch."""
        estimated, ticks, write = self.waiting[0]
        _request(self.worker, ('assess', estimated.estimates, estimated.ends, ticks, write))

    def collect(self) -> list[Made]:
        """Return what the drive made of the oldest batch submitted; start the next one's."""
        assessed = _answer(self.worker)
        estimated, _, _ = self.waiting.pop(0)
        if self.waiting:
            self._hand()
        return [estimated.made(assessed)]

    def advance(self, decoded: Sequence[JointBatch], messages: int, cuts: list[int],
                ticks: list[int], write: bool) -> list[Made]:
        """Run the drive over one batch (nothing else waiting)."""
        self.submit(decoded, messages, cuts, ticks, write)
        return self.collect()

    def final(self, stamp_ns: int) -> list[tuple[StatusOut, ...]]:
        """Return the drive's statuses of the final /diagnostics array at ``stamp_ns``."""
        run = self.runs[0]
        _request(self.worker, ('final_health', stamp_ns))
        return [(run.final_estimator(), *_answer(self.worker))]

    def finish(self, bags: list[Any], readers: list[str], elapsed: float,
               names: Sequence[tuple[str, ...]] = ()) -> list[Finished]:
        """Take the worker's assessor back; return the drive's end of run."""
        _request(self.worker, ('health_half',))
        self.runs[0].take_health(_answer(self.worker))
        return super().finish(bags, readers, elapsed, names)

    def close(self) -> None:
        """End the worker (terminated after a second if it is still assessing)."""
        _end([self.worker])


class _Worker:
    """One worker process serving ``target``: a one-process ProcessPoolExecutor (fork).

    The process is forked at once, with ``target`` as it is (not pickled); the pool's one
    process runs the requests in the order they are sent, so ``target``'s state in it
    follows them. Each request (``(method name, *args)``) gets a future; :meth:`answer`
    returns the oldest request's answer, those of ``keep_truth`` (no answer) only checked for
    an error on the way.
    """

    def __init__(self, target: Any) -> None:
        self.pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context('fork'),
                                        initializer=_adopt, initargs=(target, os.getpid()))
        self.pending: collections.deque[tuple[Future[Any], bool]] = collections.deque()
        with warnings.catch_warnings():
            # Python >= 3.12 warns of any fork beside another thread; those here are the
            # other workers' pools' (can_fork), which the child never uses
            warnings.filterwarnings('ignore', 'This process .* is multi-threaded',
                                    DeprecationWarning)
            self.request(('start',))    # forks now; the target's start runs meanwhile
        processes = list(self.pool._processes.values())     # its one process, to join
        self.process: multiprocessing.process.BaseProcess = processes[0]

    def request(self, request: tuple[Any, ...]) -> None:
        """Send a request; ParallelError if the worker is gone."""
        kind, *args = request
        try:
            future = self.pool.submit(_call, kind, *args)
        except (BrokenProcessPool, RuntimeError):   # broken, or shut down
            raise ParallelError(_GONE) from None
        self.pending.append((future, kind not in ('start', 'keep_truth')))

    def answer(self) -> Any:
        """Return the oldest request's answer; raise its error, or ParallelError if gone."""
        while self.pending:
            future, answered = self.pending.popleft()
            try:
                value = future.result()
            except BrokenProcessPool:
                raise ParallelError(_GONE) from None
            if answered:
                return value
        raise ParallelError(_GONE)

    def close(self) -> None:
        """Shut the pool down: an idle worker returns, a busy one finishes its request."""
        self.pool.shutdown(wait=False, cancel_futures=True)


#: The worker process's target (:func:`_adopt`).
_target: Any = None


def _adopt(target: Any, caller: int) -> None:
    """Start a worker: keep ``target``; the caller stops the analysis, not SIGINT.

    On Linux the worker is killed when its caller ends (``PR_SET_PDEATHSIG``); if the caller
    has already ended, the worker does not start.
    """
    global _target
    try:
        import ctypes
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)     # PR_SET_PDEATHSIG
    except (OSError, AttributeError):   # not Linux: the worker ends with its pool's queue
        pass
    if os.getppid() != caller:
        os._exit(1)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _target = target


def _call(kind: str, *args: Any) -> Any:
    """Run the worker's target's method ``kind`` (``start``: its start, if it has one)."""
    if kind == 'start':
        return getattr(_target, 'start', lambda: None)()
    return getattr(_target, kind)(*args)


def _end(workers: Sequence[_Worker]) -> None:
    """Shut the workers' pools down (an idle worker returns), then join the workers.

    A worker still busy (the caller stopped on an error or a signal) is terminated after a
    second.
    """
    for worker in workers:
        worker.close()
    for worker in workers:
        worker.process.join(timeout=1.0)
        if worker.process.is_alive():
            worker.process.terminate()
            worker.process.join()
        # the pool's manager thread joins its process too: when it reaps the process first,
        # this thread's join returns before that thread has set the exit code
        deadline = time.monotonic() + 5.0
        while worker.process.exitcode is None and time.monotonic() < deadline:
            time.sleep(0.005)


def _request(worker: _Worker, request: tuple[Any, ...]) -> None:
    """Send a worker a request; ParallelError if it is gone."""
    worker.request(request)


def _answer(worker: _Worker) -> Any:
    """Return a worker's answer; raise the error it raised, or ParallelError if it is gone."""
    return worker.answer()


#: A plot to draw: (path, Analysis, ratio R [-], bags, drive name or '').
PlotJob = tuple[Any, 'Analysis', float, list[Any], str]


class _Drawing:
    """The plotter's side: imports matplotlib at its start, then draws what it is sent."""

    def start(self) -> None:
        """Import what :func:`~gear_phm.offline.plot.plot_analysis` needs (0.5 s of CPU)."""
        import matplotlib.backends.backend_agg  # noqa: F401
        import matplotlib.figure  # noqa: F401

        import gear_phm.offline.plot  # noqa: F401

    def plot(self, jobs: Sequence[PlotJob]) -> None:
        """Draw each plot."""
        from gear_phm.offline.plot import plot_analysis
        for path, analysis, ratio, bags, drive in jobs:
            plot_analysis(path, analysis, ratio, bags, drive=drive)


class Plotter:
    """A forked process that imports matplotlib while the analysis runs, then draws its plots.

    The import is about a third of a small analysis's time (0.45-0.7 s of 1.5-2.5 s); the
    analysis keeps one core, the import takes the other. :func:`start_plotter` makes one.
    """

    def __init__(self) -> None:
        self.worker = _Worker(_Drawing())
        self.process = self.worker.process

    def plot(self, jobs: Sequence[PlotJob]) -> None:
        """Draw the plots and return once they are written (the plotter's error if any)."""
        _request(self.worker, ('plot', list(jobs)))
        _answer(self.worker)

    def close(self) -> None:
        """End the plotter (terminated after a second if it is still drawing)."""
        _end([self.worker])


def start_plotter() -> Plotter | None:
    """Return a :class:`Plotter`, or None where it cannot be forked (:func:`can_fork`)."""
    return Plotter() if can_fork() else None
