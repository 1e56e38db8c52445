"""Bag discovery: a folder of recordings stands for them, in order of their start times."""
from __future__ import annotations

from pathlib import Path
import shutil

import pytest

from gear_phm.bagio import BagError
from gear_phm.bagio.discovery import metadata_start_ns, order_bags, recordings_in

BAGS = Path(__file__).resolve().parents[2] / 'bags'


def test_a_folder_of_recordings_is_read_in_start_order(tmp_path: Path) -> None:
    unit = sorted(p for p in (BAGS / 'fleet').iterdir() if p.is_dir())[0]
    found = recordings_in(unit)
    assert len(found) == 5
    starts = [metadata_start_ns(bag) for bag in found]
    assert all(isinstance(start, int) for start in starts)
    ordered = order_bags([unit])
    assert [metadata_start_ns(bag) for bag in ordered] == sorted(starts)   # type: ignore
    assert order_bags(list(reversed(found))) == ordered
    assert metadata_start_ns(tmp_path) is None


def test_bad_paths_are_refused(tmp_path: Path) -> None:
    with pytest.raises(BagError, match='does not exist'):
        order_bags([tmp_path / 'none'])
    with pytest.raises(BagError, match='holds no recording'):
        order_bags([tmp_path])
    shutil.copytree(BAGS / 'healthy', tmp_path / 'healthy')
    with pytest.raises(BagError, match='given twice'):
        order_bags([tmp_path / 'healthy', tmp_path / 'healthy' / '..' / 'healthy'])
