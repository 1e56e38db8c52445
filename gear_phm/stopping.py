"""A stop that a signal asked for, raised again by long offline loops at their next step.

``gear-phm``'s SIGINT and SIGTERM handlers raise KeyboardInterrupt or SystemExit in the main
thread, wherever Python runs at that moment. Where that is inside code that swallows
exceptions (during an import, a finalizer), the stop was lost: a ``gear-phm simulate``
terminated while it still imported its modules ran to its end and exited 0. The handlers
therefore also record the stop here, and the loops over chunks and batches call
:func:`check`, which raises it again.
"""
from __future__ import annotations

from collections.abc import Callable

_requested: list[Callable[[], BaseException]] = []


def request(make: Callable[[], BaseException]) -> None:
    """Record a stop: :func:`check` raises ``make()`` from now on."""
    _requested[:] = [make]


def check() -> None:
    """Raise the exception of a recorded stop (:func:`request`); return if there is none."""
    if _requested:
        raise _requested[0]()


def requested() -> bool:
    """Whether a stop was recorded (:func:`request`)."""
    return bool(_requested)
