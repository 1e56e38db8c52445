"""Where the publisher node's messages come from: a simulation, or a recorded bag.

A source yields ``(elapsed_ns, item)`` pairs in order, lazily: ``elapsed_ns`` is the source
time since its first item [ns] (before any speed-up), ``item`` either a :class:`Sample` (one
simulated instant: joint states and the truth) or a :class:`Recorded` message (CDR bytes from
a bag, published as they are). Sources are free of ROS: they never publish, sleep or read a
clock. The node (:mod:`gear_phm.nodes.publisher`) owns everything live: the clock, pacing,
stamps, QoS, publishers and /diagnostics.

Split:

- :mod:`gear_phm.sources.simulate`: :class:`~gear_phm.sources.simulate.SimulateSource`, the
  seeded plant of :mod:`gear_phm.simulation` sampled at a fixed rate, in chunks;
- :mod:`gear_phm.sources.replay`: :class:`~gear_phm.sources.replay.ReplaySource`, a bag read
  through :mod:`gear_phm.bagio`, checked completely when built and then streamed (read again)
  on every pass, so the bag is never held in memory.

Both check their configuration when built and raise :class:`SourceError` with one line.
"""
from __future__ import annotations

from collections.abc import Generator, Sequence
from dataclasses import dataclass
from typing import Any, Literal, Protocol

#: Output of a recorded message: joint states, or one of the two truth topics.
Channel = Literal['joint_states', 'truth_friction', 'truth_efficiency']


class SourceError(ValueError):
    """A source cannot be built from its configuration; the text is one line."""


def one_line(exc: BaseException) -> str:
    """Return the text of ``exc`` on one line (its type name if it has none)."""
    return ' '.join(str(exc).split()) or type(exc).__name__


@dataclass(frozen=True, slots=True)
class Sample:
    """One simulated instant: (motor, load) joint states and the truth at the same time.

    position [rad], velocity [rad/s], effort [N m]; friction = (lever u [-], plant friction
    value [-]); efficiency = (eta_D, eta_I) [-].
    """

    position: tuple[float, float]
    velocity: tuple[float, float]
    effort: tuple[float, float]
    friction: tuple[float, float]
    efficiency: tuple[float, float]


@dataclass(frozen=True, slots=True)
class Recorded:
    """One bag message: its output channel, log time [ns] and serialized CDR payload."""

    channel: Channel
    log_ns: int
    raw: bytes


Item = Sample | Recorded


class Source(Protocol):
    """What the publisher node needs from a source."""

    #: Node parameter ``mode`` of this source ('simulate' or 'replay').
    mode: str
    #: Source seconds per wall-clock second (replay ``rate_factor``; 1 for a simulation).
    speed: float
    #: Messages left out when the source was built, by reason (e.g. ``missing_joint``).
    dropped: dict[str, int]
    #: Completed passes (a looping replay); 0 otherwise.
    loops: int

    def items(self) -> Generator[tuple[int, Item], None, None]:
        """``(elapsed_ns, item)`` in order, until the source ends (never, if unbounded)."""
        ...

    def describe(self) -> Sequence[tuple[str, Any]]:
        """Source-specific key-values for /diagnostics."""
        ...


__all__ = ['Channel', 'Item', 'Recorded', 'Sample', 'Source', 'SourceError', 'one_line']
