"""Where the publisher node's messages come from: a simulation, or a recorded bag.

A source yields ``(elapsed_ns, item)`` pairs in order, lazily. ``elapsed_ns`` is the source
time since its first item [ns], before any speed-up. ``item`` is a :class:`Sample` (one
simulated instant: joint states and the truth), a :class:`Recorded` message (CDR bytes from a
bag, published as they are), or :data:`PASS_END` after the last message of each pass through a
bag. Sources are free of ROS: they never publish, sleep or read a clock. The node
(:mod:`gear_phm.nodes.publisher`) owns everything live: the clock and the stamps, pacing, the
publishers and their QoS, and /diagnostics. It consumes a source through :func:`read_ahead`,
so that the bursts in which a source produces its items never delay a send.

- :mod:`gear_phm.sources.simulate`: :class:`~gear_phm.sources.simulate.SimulateSource`, the
  seeded plant of :mod:`gear_phm.simulation` sampled at a fixed rate, in chunks;
- :mod:`gear_phm.sources.replay`: :class:`~gear_phm.sources.replay.ReplaySource`, a bag read
  through :mod:`gear_phm.bagio`, checked completely when built and then streamed (read again)
  on every pass, so the bag is never held in memory.

Both check their configuration when built and raise :class:`SourceError` with one line.
"""
from __future__ import annotations

from collections.abc import Generator, Iterator, Sequence
from dataclasses import dataclass
import queue
import threading
from typing import Any, Literal, Protocol, TypeVar

from gear_phm.errors import GearPhmError

#: Output of a recorded message: joint states, or one of the two truth topics.
Channel = Literal['joints', 'truth_friction', 'truth_efficiency']


class SourceError(GearPhmError, ValueError):
    """A source cannot be built from its configuration; the text is one line."""


def one_line(exc: BaseException) -> str:
    """Return the text of ``exc`` on one line (its type name if it has none)."""
    return ' '.join(str(exc).split()) or type(exc).__name__


@dataclass(frozen=True, slots=True)
class Sample:
    """One simulated instant: (motor, load) joint states and the truth at the same time.

    position [rad], velocity [rad/s], effort [N m]; friction = (lever u [-], plant friction
    value [-]); efficiency = (eta_D, eta_I) [-]; with a real-gearbox effect on, no_load and oil
    hold the x, y, z of the no-load and oil truth (``gear_phm.interfaces.TRUTH_LAYOUT``) and
    temperature the oil temperature [degC] (``publish_temperature``), else they are empty.
    Many drives
    (:class:`~gear_phm.sources.simulate.SimulateDrivesSource`): each tuple holds every
    drive's pair, in the drives' order.
    """

    position: tuple[float, ...]
    velocity: tuple[float, ...]
    effort: tuple[float, ...]
    friction: tuple[float, ...]
    efficiency: tuple[float, ...]
    no_load: tuple[float, ...] = ()
    oil: tuple[float, ...] = ()
    temperature: tuple[float, ...] = ()


@dataclass(frozen=True, slots=True)
class Recorded:
    """One bag message: its output channel, log time [ns] and serialized CDR payload."""

    channel: Channel
    log_ns: int
    raw: bytes


@dataclass(frozen=True, slots=True)
class PassEnd:
    """Marks the end of one pass through a recording (a looping replay makes many)."""


#: The one PassEnd instance.
PASS_END = PassEnd()

Item = Sample | Recorded | PassEnd


class Source(Protocol):
    """What the publisher node needs from a source."""

    #: Node parameter ``mode`` of this source ('simulate' or 'replay').
    mode: str
    #: Source seconds per wall-clock second (replay ``rate_factor``; 1 for a simulation).
    speed: float
    #: Messages left out when the source was built, by reason (e.g. ``missing_joint``).
    dropped: dict[str, int]

    def items(self) -> Generator[tuple[int, Item], None, None]:
        """``(elapsed_ns, item)`` in order, until the source ends (never, if unbounded)."""
        ...

    def describe(self) -> Sequence[tuple[str, Any]]:
        """Source-specific key-values for /diagnostics."""
        ...


_T = TypeVar('_T')
#: Items handed from the read-ahead thread to the consumer at a time.
READ_AHEAD_BATCH = 256
_END = object()


def read_ahead(items: Iterator[_T], batches: int = 40) -> Generator[_T, None, None]:
    """Yield ``items`` in order, read ahead by a background thread.

    The thread stays at most ``batches`` x READ_AHEAD_BATCH items ahead. A pacing consumer
    needs this: rosbags reads a bag chunk by chunk, a burst of up to ~70 ms per chunk (and a
    simulation is computed in chunks), which must not fall between two sends. An exception of
    ``items`` is raised here after the items before it. Closing this generator stops the
    thread and closes ``items`` (if it is a generator).
    """
    handoff: queue.Queue[Any] = queue.Queue(maxsize=batches)
    stop = threading.Event()

    def put(entry: object) -> bool:
        while not stop.is_set():
            try:
                handoff.put(entry, timeout=0.1)
                return True
            except queue.Full:
                pass
        return False

    def read() -> None:
        batch: list[_T] = []
        try:
            for item in items:
                batch.append(item)
                if len(batch) >= READ_AHEAD_BATCH:
                    if not put(batch):
                        return
                    batch = []
            if put(batch):
                put(_END)
        except BaseException as exc:  # noqa: BLE001 handed to the consumer, raised there
            if put(batch):
                put(exc)
        finally:
            close = getattr(items, 'close', None)
            if close is not None:
                close()

    reader = threading.Thread(target=read, name='source-read-ahead', daemon=True)
    reader.start()
    try:
        while True:
            entry = handoff.get()
            if entry is _END:
                return
            if isinstance(entry, BaseException):
                raise entry
            yield from entry
    finally:
        stop.set()
        reader.join(timeout=5.0)


__all__ = ['PASS_END', 'Channel', 'Item', 'PassEnd', 'Recorded', 'Sample', 'Source',
           'SourceError', 'one_line', 'read_ahead']
