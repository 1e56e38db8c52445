"""The MCAP project's conformance inputs (``../shared/mcap-conformance``).

For every file, the package's MCAP reading (chunk reader, mcap's reader where it declines)
gives exactly the messages the file's JSON lists, per channel in log-time order; the chunk
reader alone either gives exactly them or declines, and it does answer for chunked files with
indexes and channels in the summary.
"""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from gear_phm.bagio.chunks import McapBatchReader, McapChunkReader, NotIndexed
from helpers import conformance


def expected_messages(path: Path) -> dict[str, list[tuple[int, bytes]]]:
    """Per topic, the (log time, data) of the JSON's Message records, by log time.

    Equal times in file order. Each topic has one channel in this suite (checked).
    """
    records = json.loads(path.with_suffix('.json').read_text())['records']
    topics: dict[int, str] = {}
    out: dict[str, list[tuple[int, bytes]]] = {}
    for record in records:
        fields = dict(record['fields'])
        if record['type'] == 'Channel':
            topics[int(fields['id'])] = fields['topic']
        elif record['type'] == 'Message':
            out.setdefault(topics[int(fields['channel_id'])], []).append(
                (int(fields['log_time']), bytes(int(b) for b in fields['data'])))
    assert len(set(topics.values())) == len(topics), 'one channel per topic'
    return {topic: sorted(items, key=lambda item: item[0]) for topic, items in out.items()}


def topics_of(path: Path) -> list[str]:
    records = json.loads(path.with_suffix('.json').read_text())['records']
    return sorted({dict(r['fields'])['topic'] for r in records if r['type'] == 'Channel'}
                  | {'absent'})


def collect(batches) -> dict[str, list[tuple[int, bytes]]]:
    out: dict[str, list[tuple[int, bytes]]] = {}
    for batch in batches:
        out.setdefault(batch.topic, []).extend(zip(batch.log_time_ns.tolist(),
                                                   batch.payloads()))
    return out


def test_the_suite_is_there() -> None:
    conformance.require()
    assert len(conformance.files()) == conformance.COUNT
    assert all(path.with_suffix('.json').exists() for path in conformance.files())


@pytest.mark.parametrize('path', conformance.params())
def test_conformance_file(path: Path | None) -> None:
    path = conformance.require(path)
    expected = expected_messages(path)
    topics = topics_of(path)
    reader = McapBatchReader([path])
    assert collect(reader.batches(topics, batch_size=3)) == expected, reader.kind
    try:
        with McapChunkReader([path]) as chunks:
            fast = collect(chunks.batches(topics))
    except NotIndexed:
        features = set(path.stem.split('-')[1:])
        assert not {'ch', 'chx', 'rch'} <= features, 'indexed chunks with channels: answer'
        assert reader.kind == 'mcap-scan'
    else:
        assert fast == expected
        assert reader.kind == 'mcap-chunks'
