"""The MCAP format module against mcap's own writer and records, and bagio's import graph.

``gear_phm.bagio.mcapformat`` holds the layouts that numpy reads and writes; each is checked
here against the bytes mcap's ``Writer`` and record classes produce.
"""
from __future__ import annotations

import ast
import io
from pathlib import Path
import zlib

from mcap.opcode import Opcode
from mcap.records import Chunk, Message, MessageIndex
from mcap.writer import CompressionType, Writer
import numpy as np
import pytest

from gear_phm.bagio.mcapformat import (compress, decompress, encode, FormatError, MAGIC,
                                       MESSAGE_HEAD, message_heads, message_index, NotMcap,
                                       parse_record, read_footer, records)
from gear_phm.bagio.recover_scan import unfinished

BAGIO = Path(__file__).resolve().parents[2] / 'gear_phm' / 'bagio'


def test_message_head_is_the_record_mcap_writes() -> None:
    message = Message(channel_id=7, sequence=3, log_time=1_000_000_123,
                      publish_time=1_000_000_456, data=b'payload')
    raw = encode(message)
    assert raw[:MESSAGE_HEAD.size] == MESSAGE_HEAD.pack(
        Opcode.MESSAGE, MESSAGE_HEAD.size - 9 + 7, 7, 3, 1_000_000_123, 1_000_000_456)
    assert raw[MESSAGE_HEAD.size:] == b'payload'
    data = b'\0' * 5 + raw + raw
    heads = message_heads(np.frombuffer(data, dtype=np.uint8), np.array([5, 5 + len(raw)]))
    assert heads['op'].tolist() == [Opcode.MESSAGE] * 2
    assert heads['channel'].tolist() == [7, 7]
    assert heads['log_time'].tolist() == [1_000_000_123] * 2
    walked = [(op, at) for op, at, _ in records(data, 5)]
    assert walked == [(Opcode.MESSAGE, 5), (Opcode.MESSAGE, 5 + len(raw))]
    with pytest.raises(FormatError, match='out of bounds'):
        message_heads(np.frombuffer(data, dtype=np.uint8), np.array([len(data) - 10]))
    with pytest.raises(FormatError, match='runs past the end'):
        list(records(data[:-1], 5))


def test_message_index_entries_are_mcaps() -> None:
    raw = encode(MessageIndex(channel_id=2, records=[(10, 0), (20, 40), (30, 80)]))
    channel, entries = message_index(b'xx' + raw, 2)
    assert channel == 2
    assert entries.tolist() == [[10, 0], [20, 40], [30, 80]]
    parsed = parse_record(Opcode.MESSAGE_INDEX, raw[9:])
    assert isinstance(parsed, MessageIndex) and parsed.records == [(10, 0), (20, 40), (30, 80)]
    with pytest.raises(FormatError):
        parse_record(Opcode.MESSAGE_INDEX, raw[9:-3])


@pytest.mark.parametrize('kind', [CompressionType.NONE, CompressionType.ZSTD,
                                  CompressionType.LZ4])
def test_chunk_compression_round_trip_and_checks(kind: CompressionType) -> None:
    records_bytes = bytes(range(256)) * 40
    name, packed = compress(kind, records_bytes)
    assert name == {CompressionType.NONE: '', CompressionType.ZSTD: 'zstd',
                    CompressionType.LZ4: 'lz4'}[kind]
    crc = zlib.crc32(records_bytes)
    chunk = Chunk(compression=name, data=packed, message_start_time=0, message_end_time=0,
                  uncompressed_crc=crc, uncompressed_size=len(records_bytes))
    assert decompress(chunk) == records_bytes
    chunk.uncompressed_crc = crc ^ 1
    with pytest.raises(FormatError, match='CRC mismatch'):
        decompress(chunk)
    chunk.uncompressed_crc, chunk.uncompressed_size = 0, len(records_bytes) + 1
    with pytest.raises(FormatError, match='size mismatch|does not decompress'):
        decompress(chunk)
    chunk.compression = 'bz2'
    with pytest.raises(FormatError, match="'bz2' is not supported"):
        decompress(chunk)


def test_footer_probe(tmp_path: Path) -> None:
    buffer = io.BytesIO()
    writer = Writer(buffer)
    writer.start()
    writer.finish()
    whole = buffer.getvalue()
    assert whole[:8] == MAGIC and whole[-8:] == MAGIC
    footer = read_footer(io.BytesIO(whole))
    assert footer is not None and 8 < footer.summary_start < len(whole)
    assert read_footer(io.BytesIO(whole[:-1])) is None
    with pytest.raises(NotMcap):
        read_footer(io.BytesIO(b'not mcap' + whole[8:]))
    for name, content, reason in [('whole', whole, None), ('cut', whole[:-20], 'no footer'),
                                  ('other', b'x' * 100, None)]:
        path = tmp_path / f'{name}.mcap'
        path.write_bytes(content)
        found = unfinished(path)
        assert found is None if reason is None else reason in (found or '')


def _imports(path: Path) -> set[str]:
    """Modules of gear_phm.bagio that ``path`` imports (at any depth of its code)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module \
                and node.module.startswith('gear_phm.bagio.'):
            found.add(node.module.rsplit('.', 1)[1])
    return found


def test_bagio_has_no_import_cycle() -> None:
    graph = {path.stem: _imports(path) for path in BAGIO.glob('*.py')
             if path.stem != '__init__'}
    assert {'mcapformat', 'metadata', 'recover_scan', 'recover_rewrite'} <= set(graph)
    assert graph['mcapformat'] == set()                 # the bottom of the package
    done: set[str] = set()

    def visit(module: str, path: tuple[str, ...]) -> None:
        assert module not in path, f'import cycle: {" -> ".join((*path, module))}'
        if module in done:
            return
        for imported in graph.get(module, ()):
            visit(imported, (*path, module))
        done.add(module)

    for module in graph:
        visit(module, ())
    assert len(done) == len(graph)
