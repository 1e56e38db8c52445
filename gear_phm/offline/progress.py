"""The progress bar of ``gear-phm analyze`` (tqdm on stderr), or none."""
from __future__ import annotations

import sys
from typing import Protocol


class Progress(Protocol):
    """What the stream loop tells a progress bar."""

    def update(self, n: int) -> object: ...

    def close(self) -> object: ...


class NoProgress:
    """A progress bar that shows nothing."""

    def update(self, n: int) -> None:
        """Count ``n`` more messages (shown nowhere)."""

    def close(self) -> None:
        """End the bar (nothing to end)."""


def progress_bar(total: int, disabled: bool) -> Progress:
    """Return a bar of ``total`` messages on stderr, or :class:`NoProgress` if ``disabled``."""
    if disabled:
        return NoProgress()
    from tqdm import tqdm
    bar: Progress = tqdm(total=total, unit='msg', unit_scale=True, file=sys.stderr,
                         mininterval=0.5, desc='analyze')
    return bar
