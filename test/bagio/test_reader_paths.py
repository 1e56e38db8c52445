"""What BagReader accepts as a bag path, and what it says when it cannot read one.

Bare .db3 and .mcap files are read; a cut-off MCAP file is called truncated with the recover
advice, which no complete file gets.
"""
from __future__ import annotations

from pathlib import Path
import shutil
import subprocess
import sys

from mcap.reader import make_reader
from mcap.writer import Writer
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer as Ros2Writer

from gear_phm.bagio import TYPESTORE
from gear_phm.bagio.reader import BagError, BagReader

REPO = Path(__file__).resolve().parents[2]
HEALTHY = REPO / 'bags' / 'healthy'
STRING = 'std_msgs/msg/String'


def string_bag(directory: Path, storage: StoragePlugin, count: int = 25) -> Path:
    with Ros2Writer(directory, version=9, storage_plugin=storage) as writer:
        connection = writer.add_connection('/words', STRING, typestore=TYPESTORE)
        for i in range(count):
            msg = TYPESTORE.types[STRING](data=f'word {i}')
            writer.write(connection, 10**9 + i * 10**6, TYPESTORE.serialize_cdr(msg, STRING))
    return directory


def words(path: Path) -> list[str]:
    with BagReader(path) as reader:
        return [msg.data for _, _, msg in reader.messages(['words'])]


def cli_analyze(bag: Path, out: Path) -> subprocess.CompletedProcess:
    exe = Path(sys.executable).with_name('gear-phm')
    return subprocess.run([str(exe), 'analyze', str(bag), '--ratio', '3.0', '--out', str(out),
                           '--no-plot', '--no-progress'], capture_output=True, text=True,
                          timeout=300)


def test_bare_db3_is_read(tmp_path: Path) -> None:
    """A .db3 file on its own (no metadata.yaml), and one inside its bag directory."""
    bag = string_bag(tmp_path / 'bag', StoragePlugin.SQLITE3)
    db3 = next(bag.glob('*.db3'))
    alone = tmp_path / 'alone.db3'
    shutil.copy(db3, alone)
    expected = [f'word {i}' for i in range(25)]
    assert words(alone) == expected
    assert words(db3) == expected


def test_bare_mcap_is_read_without_recover_advice(tmp_path: Path) -> None:
    """A complete .mcap without its metadata.yaml is a readable bag, also through analyze."""
    bag = string_bag(tmp_path / 'bag', StoragePlugin.MCAP)
    alone = tmp_path / 'alone.mcap'
    shutil.copy(next(bag.glob('*.mcap')), alone)
    assert words(alone) == [f'word {i}' for i in range(25)]
    sample = tmp_path / 'healthy.mcap'
    shutil.copy(next(HEALTHY.glob('*.mcap')), sample)
    result = cli_analyze(sample, tmp_path / 'out')
    assert result.returncode == 0, result.stderr
    assert 'recover' not in result.stderr
    assert (tmp_path / 'out' / 'summary.json').exists()


@pytest.mark.parametrize('layout', ['directory', 'bare file', 'directory without metadata'])
def test_truncated_mcap_says_truncated_and_suggests_recover(tmp_path: Path,
                                                            layout: str) -> None:
    """A recording killed before it closed: its .mcap has no footer.

    The error says so in one line and names gear-phm recover.
    """
    bag = tmp_path / 'bag'
    shutil.copytree(HEALTHY, bag)
    mcap_file = next(bag.glob('*.mcap'))
    data = mcap_file.read_bytes()
    mcap_file.write_bytes(data[:len(data) * 2 // 3])
    if layout == 'directory without metadata':
        (bag / 'metadata.yaml').unlink()
    path = mcap_file if layout == 'bare file' else bag
    if layout == 'bare file':
        (bag / 'metadata.yaml').unlink()
    with pytest.raises(BagError) as info:
        with BagReader(path):
            pass
    text = str(info.value)
    assert 'looks truncated' in text and f'gear-phm recover {bag}' in text
    assert mcap_file.name in text and '\n' not in text
    result = cli_analyze(path, tmp_path / 'out')
    assert result.returncode == 2
    assert 'looks truncated' in result.stderr and 'gear-phm recover' in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_complete_but_corrupt_mcap_gets_no_recover_advice(tmp_path: Path) -> None:
    """A flipped byte inside a chunk of a complete file: an error naming the checksum.

    No advice to run recover is given (the file is not truncated).
    """
    path = tmp_path / 'bad.mcap'
    with open(path, 'wb') as stream:
        writer = Writer(stream, chunk_size=4096)
        writer.start(profile='ros2', library='test')
        msgdef, _ = TYPESTORE.generate_msgdef(STRING, ros_version=2)
        schema = writer.register_schema(STRING, 'ros2msg', msgdef.encode())
        channel = writer.register_channel('/words', 'cdr', schema,
                                          {'topic_type_hash': TYPESTORE.hash_rihs01(STRING)})
        for i in range(2000):
            msg = TYPESTORE.types[STRING](data=f'word {i:05d}')
            writer.add_message(channel, i, bytes(TYPESTORE.serialize_cdr(msg, STRING)), i, i)
        writer.finish()
    with open(path, 'rb') as stream:
        chunk = make_reader(stream).get_summary().chunk_indexes[2]
    data = bytearray(path.read_bytes())
    data[chunk.chunk_start_offset + chunk.chunk_length // 2] ^= 0xFF     # compressed records
    path.write_bytes(bytes(data))
    with pytest.raises(BagError) as info:
        with BagReader(path) as reader:
            for _ in reader.raw_batches(['words']):
                pass
    text = str(info.value)
    assert text.startswith(f'bag {path} is corrupt: ') and '\n' not in text
    assert 'gear-phm recover' not in text and 'truncated' not in text
    assert 'checksum' in text or 'decompress' in text


def test_directory_of_complete_mcap_files_without_metadata_is_read(tmp_path: Path) -> None:
    bag = string_bag(tmp_path / 'bag', StoragePlugin.MCAP)
    (bag / 'metadata.yaml').unlink()
    assert words(bag) == [f'word {i}' for i in range(25)]
