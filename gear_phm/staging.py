"""Outputs written whole or not at all: staged in a hidden folder beside their target.

``gear-phm analyze``, ``simulate`` and ``fleet`` write into :attr:`Staged.path`;
:meth:`Staged.commit` renames it into place once it is complete, and :meth:`Staged.discard`
(also on leaving a ``with`` block) removes the staging folder: a failed, interrupted or
terminated run leaves nothing. :func:`write_atomic` does the same for one file.

A signal can stop a run between two bytecodes anywhere, also while a staging folder is being
made, before its caller holds it. Every staging folder is therefore registered *before* it
is made, and :func:`discard_all` (called by ``gear-phm`` on every exit) removes those not
yet committed or discarded.
"""
from __future__ import annotations

from collections.abc import Callable
import os
from pathlib import Path
import secrets
import shutil
import tempfile
from typing import Any

from gear_phm import stopping


def write_atomic(target: Path, text: str) -> None:
    """Write ``text`` (UTF-8) to the file ``target`` whole or not at all.

    A temporary file beside it, flushed and fsynced, renamed over ``target`` (atomic on
    POSIX), then the directory fsynced: a crash at any point leaves the old file or the new
    one, never a torn one, and a failure leaves no temporary file. Raises OSError.
    """
    directory = target.parent if str(target.parent) else Path('.')
    fd, temp = tempfile.mkstemp(prefix=f'.{target.name}.', suffix='.tmp', dir=directory)
    try:
        with os.fdopen(fd, 'w', encoding='utf-8') as stream:
            stream.write(text)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temp, target)
    except BaseException:
        try:
            os.unlink(temp)
        except OSError:
            pass
        raise
    dir_fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)


#: staging folders made (or about to be made) and neither committed nor discarded yet
_pending: set[Path] = set()


def discard_all() -> None:
    """Remove every staging folder not committed or discarded (on a stopped run's exit)."""
    for staging in list(_pending):
        shutil.rmtree(staging, ignore_errors=True)
        _pending.discard(staging)


class Staged:
    """A hidden folder ``.<name>.<random>`` beside ``target`` holding :attr:`path`.

    ``error`` makes the exception raised when the folder cannot be made or renamed (the
    caller's own error class; the message names ``--out`` and the reason). ``replace``:
    :meth:`commit` removes an existing ``target`` whatever it holds (the caller checked it
    holds an earlier output), else only an empty one. ``folder``: make :attr:`path` a folder
    at once (for writers that do not make their own).
    """

    def __init__(self, target: Path, error: Callable[[str], Exception],
                 replace: bool = False, folder: bool = False) -> None:
        self.target = target
        self._error = error
        self._replace = replace
        self._staging: Path | None = None
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
            self._staging = self._make(target)
            #: where the output is written
            self.path = self._staging / target.name
            if folder:
                self.path.mkdir()
        except OSError as exc:
            self.discard()
            raise self._failed(exc) from None

    @staticmethod
    def _make(target: Path) -> Path:
        """Make ``.<name>.<random>`` beside ``target`` (mode 0700), registered first."""
        for _ in range(100):
            staging = target.parent / f'.{target.name}.{secrets.token_hex(4)}'
            _pending.add(staging)
            try:
                staging.mkdir(mode=0o700)
            except FileExistsError:
                _pending.discard(staging)
                continue
            return staging
        raise FileExistsError(17, 'no free staging name', str(target.parent))

    def __enter__(self) -> Staged:
        return self

    def __exit__(self, *exc_info: Any) -> None:
        self.discard()

    def commit(self) -> None:
        """Rename :attr:`path` to the target (the error of ``error`` if that fails).

        A stop that a signal asked for and that was swallowed where it landed
        (:mod:`gear_phm.stopping`) is raised here instead: a stopped run commits nothing.
        """
        stopping.check()
        try:
            if self.target.exists():
                if self._replace:
                    shutil.rmtree(self.target)
                else:
                    self.target.rmdir()         # empty: the callers refuse any other
            self.path.rename(self.target)
        except OSError as exc:
            raise self._failed(exc) from None

    def discard(self) -> None:
        """Remove the staging folder and what is left in it."""
        if self._staging is not None:
            shutil.rmtree(self._staging, ignore_errors=True)
            _pending.discard(self._staging)

    def _failed(self, exc: OSError) -> Exception:
        return self._error(f'cannot write --out {self.target}: {exc.strerror or exc}')
