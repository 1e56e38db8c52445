"""Campaign equivalence, offline: analyze over a recording's parts equals the whole (issue 13).

The parts are cut from ``bags/wearing`` by log time, as a recorder restarted between runs
would have written them, and are given to ``gear-phm analyze`` shuffled: it orders them by
start time and carries the estimator and the prognostics across them.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gear_phm.bagio import BagReader, Rosbag2McapWriter
from gear_phm.cli.main import main

REPO = Path(__file__).resolve().parents[2]
WEARING = REPO / 'bags' / 'wearing'
OPTIONS = ['--ratio', '3.0', '--eta-opposing-min', '0.7333', '--no-progress', '--no-plot']
FLEET = REPO / 'bags' / 'fleet'
FLEET_OPTIONS = ['--ratio', '3.0', '--no-progress', '--no-plot']


def split_bag(bag: Path, out: Path, parts: int) -> list[Path]:
    """Cut ``bag`` into ``parts`` bags of equal log-time spans; every topic is kept."""
    with BagReader(bag) as reader:
        topics = reader.topics
        messages = list(reader.raw_messages())
    times = np.array([t for _, t, _ in messages])
    edges = np.linspace(times.min(), times.max() + 1, parts + 1)
    paths = []
    for k in range(parts):
        path = out / f'part_{k}'
        with Rosbag2McapWriter(path, flush_period_s=None) as writer:
            for topic, msgtype in topics.items():
                writer.add_topic(topic, msgtype)
            for topic, t, raw in messages:
                if edges[k] <= t < edges[k + 1]:
                    writer.write_raw(topic, t, raw)
        paths.append(path)
    return paths


def summary(out: Path) -> dict:
    return json.loads((out / 'summary.json').read_text())


def test_five_parts_in_any_order_give_the_whole_recordings_result(tmp_path: Path) -> None:
    parts = split_bag(WEARING, tmp_path, 5)
    assert main(['analyze', str(WEARING), '--out', str(tmp_path / 'whole'), *OPTIONS]) == 0
    shuffled = [str(parts[k]) for k in (3, 0, 4, 1, 2)]
    assert main(['analyze', *shuffled, '--out', str(tmp_path / 'campaign'), *OPTIONS]) == 0
    whole, campaign = summary(tmp_path / 'whole'), summary(tmp_path / 'campaign')
    assert campaign['bag'] == [str(p) for p in parts]                 # ordered by start time
    assert campaign['messages'] == whole['messages'] == 30000
    assert campaign['samples_used'] == whole['samples_used']
    for key in ('u', 'u_rate', 'sigma_u', 'eta_opposing', 'operating_time_s'):
        assert campaign[key] == pytest.approx(whole[key], rel=1e-9, abs=1e-15), key
    assert campaign['filter_updates'] == whole['filter_updates']
    health, expected = campaign['health'], whole['health']
    assert health['level'] == expected['level'] == 'ERROR'
    assert health['first_seen_ns'].keys() == expected['first_seen_ns'].keys()
    for level, stamp in expected['first_seen_ns'].items():        # the same transitions
        assert abs(health['first_seen_ns'][level] - stamp) <= 10**9, level
    for key in ('rul_s', 'rul_p5_s', 'rul_p95_s', 'u'):
        assert float(health['values'][key]) == pytest.approx(float(expected['values'][key]),
                                                             rel=1e-6, abs=1e-9), key
    rul = {}
    for name in ('whole', 'campaign'):
        with BagReader(tmp_path / name) as bag:
            rul[name] = {t: (m.vector.x, m.vector.y, m.vector.z)
                         for _, t, m in bag.messages(['/gear_phm/health/rul'])}
    assert rul['campaign'].keys() == rul['whole'].keys() and len(rul['whole']) > 2000
    stamps = sorted(rul['whole'])
    finite = [t for t in stamps if np.isfinite(rul['whole'][t][0])]
    assert len(finite) > 1000                           # the trend is found during the life
    assert np.allclose([rul['campaign'][t] for t in stamps], [rul['whole'][t] for t in stamps],
                       rtol=1e-6, atol=1e-9, equal_nan=True)


def test_a_folder_of_recordings_is_the_campaign_of_its_recordings(tmp_path: Path) -> None:
    """``gear-phm analyze FOLDER`` takes the recordings in it, as the explicit list does."""
    unit = FLEET / 'unit_00'
    listed = sorted(str(p) for p in unit.glob('rec_*'))
    assert len(listed) == 5
    assert main(['analyze', *reversed(listed), '--out', str(tmp_path / 'listed'),
                 *FLEET_OPTIONS]) == 0
    assert main(['analyze', str(unit), '--out', str(tmp_path / 'folder'), *FLEET_OPTIONS]) == 0
    listed_summary, folder = summary(tmp_path / 'listed'), summary(tmp_path / 'folder')
    assert folder['bag'] == listed_summary['bag'] == listed               # by start time
    for key in ('u', 'sigma_u', 'operating_time_s', 'messages', 'filter_updates'):
        assert folder[key] == listed_summary[key], key
    assert folder['health']['values'] == listed_summary['health']['values']
    empty = tmp_path / 'empty'
    empty.mkdir()
    assert main(['analyze', str(empty), '--out', str(tmp_path / 'none'), *FLEET_OPTIONS]) == 2
    assert not (tmp_path / 'none').exists()
