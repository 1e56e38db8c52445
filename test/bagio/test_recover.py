"""``gear-phm recover``: damaged chunks dropped and reported (never re-checksummed).

Every other record kept (schemas, schemaless channels, attachments, metadata), originals
kept, non-MCAP input refused with one line, and the "run gear-phm recover" advice only for
files that really lack their footer or summary.
"""
from __future__ import annotations

import io
import json
import os
from pathlib import Path
import shutil
import subprocess
import sys

from mcap.reader import make_reader
from mcap.records import DataEnd
from mcap.stream_reader import breakup_chunk, StreamReader
import pytest

from gear_phm.bagio import BagError, BagReader, recover, RecoverError, Rosbag2McapWriter
from gear_phm.bagio.recover import RECOVER_METADATA, scan
from gear_phm.interfaces import Vector3Out
from helpers import conformance

GEAR_PHM = Path(sys.executable).parent / 'gear-phm'
SCHEMALESS = ('OneSchemalessMessage', 'OneSchemalessMessage-ch-chx-mx-st-sum.mcap')


def cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(GEAR_PHM), *args], capture_output=True, text=True, timeout=120,
                          env=os.environ.copy())


def listing(directory: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(directory.iterdir())}


# --- a flipped byte in one chunk ----------------------------------------------------------

@pytest.fixture(scope='module')
def clean_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """60 s of simulated 100 Hz data with linear wear, in chunks of 64 KiB (about 10)."""
    root = tmp_path_factory.mktemp('clean')
    done = cli('simulate', '--out', str(root / 'sim'), '--duration', '60', '--rate', '100',
               '--seed', '4', '--wear', 'linear', '--friction-initial', '0.05',
               '--friction-final', '0.10')
    assert done.returncode == 0, done.stderr
    rechunked(root / 'sim', root / 'bag', exclude=set())
    return root / 'bag'


def rechunked(source: Path, out: Path, exclude: set[tuple[str, int, int]]) -> None:
    """Copy the bag ``source`` to ``out`` in 64 KiB chunks.

    The messages whose (topic, log time, sequence) is in ``exclude`` are left out.
    """
    [mcap_file] = source.glob('*.mcap')
    with open(mcap_file, 'rb') as stream, \
            Rosbag2McapWriter(out, chunk_size=1 << 16, flush_period_s=None) as writer:
        for schema, channel, message in make_reader(stream).iter_messages(
                log_time_order=False):
            writer.add_topic(channel.topic, schema.name)
            if (channel.topic, message.log_time, message.sequence) not in exclude:
                writer.write_raw(channel.topic, message.log_time, message.data)


def chunk_messages(mcap_file: Path, offset: int) -> set[tuple[str, int, int]]:
    """(topic, log time, sequence) of the messages of the chunk at byte ``offset``."""
    with open(mcap_file, 'rb') as stream:
        topics = {c.id: c.topic for c in make_reader(stream).get_summary().channels.values()}
        stream.seek(offset)
        chunk = next(iter(StreamReader(stream, skip_magic=True, emit_chunks=True).records))
    return {(topics[m.channel_id], m.log_time, m.sequence) for m in breakup_chunk(chunk)
            if hasattr(m, 'log_time')}


def analyze(bag: Path, out: Path) -> dict:
    done = cli('analyze', str(bag), '--ratio', '3.0', '--out', str(out), '--no-plot',
               '--no-progress')
    assert done.returncode == 0, done.stderr
    return json.loads((out / 'summary.json').read_text())


def test_flipped_byte_drops_that_chunk_only(clean_bag: Path, tmp_path: Path) -> None:
    bag = tmp_path / 'bag'
    shutil.copytree(clean_bag, bag)
    [mcap_file] = bag.glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        chunks = make_reader(stream).get_summary().chunk_indexes
    assert len(chunks) >= 6
    target = chunks[len(chunks) // 2]
    data = bytearray(mcap_file.read_bytes())
    data[target.chunk_start_offset + target.chunk_length // 2] ^= 0x20
    mcap_file.write_bytes(bytes(data))
    lost = chunk_messages(clean_bag / mcap_file.name, target.chunk_start_offset)
    assert 100 < len(lost) < 10_000

    refused = cli('analyze', str(bag), '--ratio', '3.0', '--out', str(tmp_path / 'no'),
                  '--no-plot', '--no-progress')
    assert refused.returncode == 2 and 'corrupt' in refused.stderr

    done = cli('recover', str(bag))
    assert done.returncode == 0, done.stderr
    [line] = done.stderr.splitlines()
    end = target.chunk_start_offset + target.chunk_length + target.message_index_length
    assert line.startswith(f'{mcap_file.name}: dropped chunk at bytes '
                           f'{target.chunk_start_offset}-{end}, log time '
                           f'{target.message_start_time * 1e-9:.3f}-'
                           f'{target.message_end_time * 1e-9:.3f} s, {len(lost)} messages: ')
    assert (bag / f'{mcap_file.name}.orig').read_bytes() == bytes(data)   # kept as it was
    assert (bag / 'metadata.yaml.orig').is_file()
    with BagReader(clean_bag) as reader:
        total = reader.message_count()
    assert f'recovered {total - len(lost)} messages on 3 topics' in done.stdout

    with open(mcap_file, 'rb') as stream:
        reader = make_reader(stream, validate_crcs=True)
        kept = {(c.topic, m.log_time, m.sequence) for _, c, m in reader.iter_messages()}
        [note] = [m for m in reader.iter_metadata() if m.name == RECOVER_METADATA]
    with open(clean_bag / mcap_file.name, 'rb') as stream:
        everything = {(c.topic, m.log_time, m.sequence)
                      for _, c, m in make_reader(stream).iter_messages()}
    assert kept == everything - lost
    assert note.metadata['dropped_0'] == line.split(': dropped ', 1)[1]

    # analysed u: as the clean bag without the dropped messages, and near the clean one
    rechunked(clean_bag, tmp_path / 'expected', exclude=lost)
    recovered = analyze(bag, tmp_path / 'a_recovered')
    expected = analyze(tmp_path / 'expected', tmp_path / 'a_expected')
    clean = analyze(clean_bag, tmp_path / 'a_clean')
    assert recovered['messages'] == expected['messages'] == clean['messages'] - sum(
        1 for topic, _, _ in lost if topic == '/joint_states')
    for key in ('u', 'sigma_u', 'eta_opposing', 'eta_aiding'):
        assert recovered[key] == pytest.approx(expected[key], rel=1e-9, abs=1e-12), key
    assert abs(recovered['u'] - clean['u']) < 3 * clean['sigma_u']


def test_bad_summary_or_message_index_is_rebuilt_without_loss(tmp_path: Path) -> None:
    """Damage outside the chunks loses no data: the index is rebuilt from the chunks."""
    bag = tmp_path / 'bag'
    with Rosbag2McapWriter(bag, chunk_size=4096, flush_period_s=None) as writer:
        for i in range(1000):
            writer.write_output(Vector3Out('gear_phm/friction', 10**9 + i * 10**6, i, 0, 0))
    [mcap_file] = bag.glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        chunk = make_reader(stream).get_summary().chunk_indexes[3]
    data = bytearray(mcap_file.read_bytes())
    data[chunk.chunk_start_offset + chunk.chunk_length + 20] ^= 0x01   # its message index
    mcap_file.write_bytes(bytes(data))
    found = scan(mcap_file)
    assert not found.dropped and len(found.problems) == 1 and 'message index' in \
        found.problems[0]
    result = recover(bag, tmp_path / 'out')
    assert result.messages == 1000 and not result.dropped
    assert listing(bag)[mcap_file.name] == bytes(data)                 # original untouched
    with BagReader(tmp_path / 'out') as reader:
        values = [m.vector.x for _, _, m in reader.messages()]
    assert values == [float(i) for i in range(1000)]


# --- MCAP conformance files: schemaless channels, attachments, metadata --------------------

def expected_records(mcap_file: Path) -> tuple[list, list, list]:
    """(messages, attachments, metadata) that the conformance JSON lists for the file."""
    records = json.loads(mcap_file.with_suffix('.json').read_text())['records']
    fields = [(r['type'], dict(r['fields'])) for r in records]
    schemas = {f['id']: f['name'] for kind, f in fields if kind == 'Schema'}
    channels = {f['id']: (f['topic'], f['message_encoding'], schemas.get(f['schema_id']))
                for kind, f in fields if kind == 'Channel'}
    messages = sorted((*channels[f['channel_id']], int(f['log_time']), int(f['publish_time']),
                       int(f['sequence']), bytes(int(b) for b in f['data']))
                      for kind, f in fields if kind == 'Message')
    attachments = [(f['name'], f['media_type'], int(f['log_time']), int(f['create_time']),
                    bytes(int(b) for b in f['data'])) for kind, f in fields
                   if kind == 'Attachment']
    metadata = [(f['name'], f['metadata']) for kind, f in fields if kind == 'Metadata']
    return messages, attachments, metadata


def read_records(mcap_file: Path) -> tuple[list, list, list]:
    with open(mcap_file, 'rb') as stream:
        reader = make_reader(stream, validate_crcs=True)
        messages = sorted((c.topic, c.message_encoding, None if s is None else s.name,
                           m.log_time, m.publish_time, m.sequence, m.data)
                          for s, c, m in reader.iter_messages(log_time_order=False))
        attachments = [(a.name, a.media_type, a.log_time, a.create_time, a.data)
                       for a in reader.iter_attachments()]
        metadata = [(m.name, m.metadata) for m in reader.iter_metadata()
                    if m.name != RECOVER_METADATA]
    return messages, attachments, metadata


def cut_at_data_end(mcap_file: Path, out: Path) -> int:
    """Copy ``mcap_file`` to ``out`` up to its DataEnd record (no summary, no footer)."""
    data = mcap_file.read_bytes()
    stream = io.BytesIO(data)
    position = 8
    for record in StreamReader(stream, emit_chunks=True).records:
        if isinstance(record, DataEnd):
            break
        position = stream.tell()
    out.write_bytes(data[:position])
    return position


@pytest.mark.parametrize('mcap_file', conformance.params())
def test_conformance_file_is_intact_and_its_cut_copy_recovers_every_record(
        mcap_file: Path | None, tmp_path: Path) -> None:
    mcap_file = conformance.require(mcap_file)
    assert scan(mcap_file).intact                       # valid: nothing to rewrite
    untouched = recover(mcap_file, tmp_path / 'never.mcap')
    assert untouched.nothing_to_do and not (tmp_path / 'never.mcap').exists()
    cut = tmp_path / 'cut.mcap'
    cut_at_data_end(mcap_file, cut)
    result = recover(cut)
    assert result.written == [tmp_path / 'cut.recovered.mcap']
    assert cut.read_bytes() == mcap_file.read_bytes()[:cut.stat().st_size]  # not rewritten
    assert [d.what for _, d in result.dropped] == ['end of file']
    assert read_records(result.output) == expected_records(mcap_file)


def test_schemaless_and_attachment_files(tmp_path: Path) -> None:
    """The two cases by name, through the CLI: a schemaless channel and an attachment.

    Both come out as the JSON lists them; the schemaless channel without traceback and with
    nothing rewritten in place.
    """
    suite = conformance.require()
    for name in ('OneSchemalessMessage/OneSchemalessMessage-ch-chx-mx-st-sum',
                 'OneAttachment/OneAttachment-ax-st-sum'):
        source = suite / f'{name}.mcap'
        cut = tmp_path / source.name
        cut_at_data_end(source, cut)
        before = cut.read_bytes()
        done = cli('recover', str(cut), '--out', str(tmp_path / 'out.mcap'))
        assert done.returncode == 0 and 'Traceback' not in done.stderr, done.stderr
        assert 'dropped end of file' in done.stderr
        assert cut.read_bytes() == before
        assert read_records(tmp_path / 'out.mcap') == expected_records(source)
        (tmp_path / 'out.mcap').unlink()
    messages, _, _ = expected_records(suite.joinpath(*SCHEMALESS))
    assert messages[0][2] is None                       # it really has no schema


def test_non_ros_mcap_cannot_become_a_rosbag2_directory(tmp_path: Path) -> None:
    schemaless = conformance.require().joinpath(*SCHEMALESS)
    bag = tmp_path / 'bag'
    bag.mkdir()
    cut_at_data_end(schemaless, bag / 'bag_0.mcap')
    before = listing(bag)
    done = cli('recover', str(bag))
    assert done.returncode == 2 and done.stdout == ''
    [line] = done.stderr.splitlines()
    assert line.startswith('gear-phm recover: error: ') and 'not a ROS 2 recording' in line
    assert "channel 'example' has message encoding 'text', no schema" in line
    assert listing(bag) == before


def test_corrupt_attachment_is_dropped_and_named(tmp_path: Path) -> None:
    from mcap.writer import Writer
    path = tmp_path / 'a.mcap'
    with open(path, 'wb') as stream:
        writer = Writer(stream)
        writer.start(profile='', library='test')
        writer.add_attachment(1, 2, 'good.txt', 'text/plain', b'fine')
        writer.add_attachment(3, 4, 'bad.txt', 'text/plain', b'will rot')
        writer.add_metadata('site', {'rig': '7'})
        writer.finish()
    data = path.read_bytes()
    path.write_bytes(data.replace(b'will rot', b'will rOt'))
    result = recover(path)
    [(_, dropped)] = result.dropped
    assert dropped.what == 'attachment' and "'bad.txt': CRC mismatch" in dropped.reason
    _, attachments, metadata = read_records(result.output)
    assert attachments == [('good.txt', 'text/plain', 2, 1, b'fine')]
    assert metadata == [('site', {'rig': '7'})]


# --- bad input and the advice --------------------------------------------------------------

@pytest.mark.parametrize('name, content', [
    ('notes.txt', b'hello\n'),
    ('old.bag', b'#ROSBAG V2.0\n' + bytes(100)),
    ('bag.db3', b'SQLite format 3\x00' + bytes(100)),
])
def test_non_mcap_input_one_line_error_nothing_written(tmp_path: Path, name: str,
                                                       content: bytes) -> None:
    path = tmp_path / name
    path.write_bytes(content)
    done = cli('recover', str(path))
    assert done.returncode == 2, done.stderr
    assert done.stderr.splitlines() == [
        f'gear-phm recover: error: {path}: not an MCAP file (no MCAP magic at its start)']
    assert listing(tmp_path) == {name: content}
    with pytest.raises(RecoverError):
        recover(path, tmp_path / 'x')
    assert listing(tmp_path) == {name: content}


def test_advice_only_for_files_without_footer(tmp_path: Path) -> None:
    bag = tmp_path / 'bag'
    with Rosbag2McapWriter(bag, flush_period_s=None) as writer:
        writer.write_output(Vector3Out('gear_phm/friction', 10**9, 0.1, 0.0, 0.0))
    [mcap_file] = bag.glob('*.mcap')
    loose = tmp_path / 'loose.mcap'
    shutil.copyfile(mcap_file, loose)
    (bag / 'metadata.yaml').unlink()

    def message(path: Path) -> str:
        with pytest.raises(BagError) as info:
            with BagReader(path):
                pass
        return str(info.value)

    for complete in (bag, loose):                 # complete files are read, no advice
        with BagReader(complete) as reader:
            assert reader.message_count() == 1
    data = mcap_file.read_bytes()
    mcap_file.write_bytes(data[:-40])
    loose.write_bytes(data[:-40])
    for path in (bag, loose):
        text = message(path)
        assert 'it has no footer (the writer did not finish)' in text
        assert text.endswith(f'run: gear-phm recover {path}'), text
    result = recover(loose, tmp_path / 'new_bag')
    assert result.messages == 1
    with BagReader(tmp_path / 'new_bag') as reader:
        assert [m.vector.x for _, _, m in reader.messages()] == [0.1]


# --- metadata.yaml the reader refuses, nothing to recover, --out of another format ----------

def small_bag(directory: Path, messages: int = 5) -> Path:
    """Write a complete rosbag2 directory of ``messages`` messages; return its MCAP file."""
    with Rosbag2McapWriter(directory, flush_period_s=None) as writer:
        for i in range(messages):
            writer.write_output(Vector3Out('gear_phm/friction', (i + 1) * 10**9, 0.1, 0.0, 0.0))
    [mcap_file] = directory.glob('*.mcap')
    return mcap_file


@pytest.mark.parametrize('kind', ['corrupt', 'empty', 'string', 'version', 'missing file'])
def test_metadata_the_reader_refuses_is_rebuilt(tmp_path: Path, kind: str) -> None:
    """Intact MCAP, bad metadata.yaml: rebuilt from the files, the old one kept as .orig."""
    bag = tmp_path / 'bag'
    mcap_file = small_bag(bag)
    meta = bag / 'metadata.yaml'
    good = meta.read_text()
    text = {'corrupt': 'rosbag2_bagfile_information: [', 'empty': '', 'string': 'hello',
            'version': good.replace('version: 9', 'version: 999'),
            'missing file': good.replace(mcap_file.name, 'gone_0.mcap')}[kind]
    assert text != good
    meta.write_text(text)
    data = mcap_file.read_bytes()
    with pytest.raises(BagError):
        with BagReader(bag):
            pass
    done = cli('recover', str(bag))
    assert done.returncode == 0, done.stderr
    assert 'nothing to recover' not in done.stdout
    assert 'originals kept as metadata.yaml.orig' in done.stdout
    [line] = done.stderr.splitlines()
    assert line.startswith(f'{meta}: refused by the rosbag2 reader (') and \
        line.endswith('); rebuilt from the MCAP files')
    assert (bag / 'metadata.yaml.orig').read_text() == text
    assert mcap_file.read_bytes() == data
    with BagReader(bag) as reader:
        assert reader.message_count() == 5
    done = cli('recover', str(bag))                 # now complete and intact
    assert done.returncode == 0 and 'nothing to recover, nothing written' in done.stdout


def test_magic_only_file_is_nothing_recoverable(tmp_path: Path) -> None:
    mcap_file = small_bag(tmp_path / 'bag')
    magic = tmp_path / 'magic.mcap'
    magic.write_bytes(mcap_file.read_bytes()[:8])
    (tmp_path / 'bag' / 'metadata.yaml').unlink()
    mcap_file.write_bytes(magic.read_bytes())
    for path in (magic, tmp_path / 'bag'):
        before = sorted(os.listdir(tmp_path)), listing(tmp_path / 'bag')
        done = cli('recover', str(path))
        assert done.returncode == 2 and done.stdout == ''
        [line] = done.stderr.splitlines()
        assert line.startswith('gear-phm recover: error: ') and \
            'nothing recoverable (not even its MCAP header record' in line, line
        assert line.endswith('; nothing written') and str(mcap_file if path.is_dir()
                                                          else magic) in line
        assert (sorted(os.listdir(tmp_path)), listing(tmp_path / 'bag')) == before


def test_out_of_another_format_or_unwritable_is_named(tmp_path: Path) -> None:
    """--out rec.db3 is refused (it made a directory named rec.db3); OSErrors name the path."""
    bag = tmp_path / 'bag'
    mcap_file = small_bag(bag)
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(mcap_file.read_bytes()[:-40])
    for path, out, message in [
            (cut, tmp_path / 'rec.db3', 'recover writes MCAP (a .mcap file, or a rosbag2 '
                                        'directory for any other name), not .db3'),
            (bag, tmp_path / 'rec.mcap', 'a rosbag2 directory is recovered into a new '
                                         'directory; give a name without the .mcap suffix'),
            (cut, tmp_path / 'no' / 'x.mcap', f'{tmp_path}/no/x.mcap.recovering: No such file')]:
        done = cli('recover', str(path), '--out', str(out))
        assert done.returncode == 2
        [line] = done.stderr.splitlines()
        assert line.startswith('gear-phm recover: error: ') and message in line, line
        assert not out.exists()
