"""Where an analysis may be written: the checks of ``--out`` before anything is read."""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from gear_phm.offline.options import AnalysisError


def check_out(out: Path, overwrite: bool, bags: Sequence[Path] = ()) -> Path:
    """Return ``out`` if the analysis may be written there; AnalysisError if not.

    It must not exist, be empty, or (``overwrite``) hold an earlier analysis and nothing
    else (:func:`analysis_files`): replacing it removes the directory. It must not be a
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
                        if not analysis_files(out.name, entry))
        if others:
            raise AnalysisError(f'--out {out} holds files an analysis does not write '
                                f'({", ".join(others[:5])}): not replaced')
        return out                              # replaced once the new analysis is complete
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        hint = '' if overwrite else ' (add --overwrite to replace an earlier analysis)'
        raise AnalysisError(f'--out {out} exists and is not an empty directory{hint}')
    return out


def analysis_files(name: str, entry: Path) -> bool:
    """Whether ``entry`` of an output directory ``name`` is one an analysis writes."""
    if not entry.is_file() or entry.is_symlink():
        return False
    file = entry.name
    return file in ('summary.json', 'metadata.yaml', 'analysis.png') or (
        file.startswith('analysis_') and file.endswith('.png')) or (
        file.startswith(f'{name}_') and file.endswith('.mcap')
        and file[len(name) + 1:-len('.mcap')].isdigit())
