"""The same recording stored differently gives the same estimate.

bags/wearing rewritten with mcap's Writer with /joint_states on two channels (merged
recordings, a second publisher with other QoS), and without chunk index or statistics, read
through BagReader.raw_batches and fed to the estimator pipeline, give the original's u to 1e-9
from all 30 000 messages.
"""
from __future__ import annotations

from pathlib import Path
import shutil

from mcap.reader import make_reader
from mcap.writer import IndexType, Writer
import pytest

from gear_phm import codec, interfaces
from gear_phm.bagio import BagReader
from gear_phm.estimation import EstimatorConfig, EstimatorPipeline
from helpers.shared import build_once

WEARING = Path(__file__).resolve().parents[2] / 'bags' / 'wearing'
#: The variants: name -> the options of :func:`rewrite`.
VARIANTS = {
    'two-channels': {'split_channels': True, 'chunk_size': 64 * 1024},
    'no-chunk-index-no-statistics': {'split_channels': False, 'index_types': IndexType.NONE,
                                     'use_statistics': False},
}


def qos_yaml(reliability: int) -> str:
    never = '{sec: 9223372036, nsec: 854775807}'
    return (f'- history: 1\n  depth: 10\n  reliability: {reliability}\n  durability: 2\n'
            f'  deadline: {never}\n  lifespan: {never}\n  liveliness: 1\n'
            f'  liveliness_lease_duration: {never}\n  avoid_ros_namespace_conventions: false\n')


def rewrite(directory: Path, split_channels: bool, **writer_args) -> Path:
    """Rewrite bags/wearing with mcap's Writer (``writer_args``) as a rosbag2 directory.

    The directory has its metadata.yaml and the same file name; with ``split_channels``,
    /joint_states messages alternate between two channels that differ in their QoS.
    """
    directory.mkdir()
    source = next(WEARING.glob('*.mcap'))
    shutil.copy(WEARING / 'metadata.yaml', directory / 'metadata.yaml')
    with open(source, 'rb') as stream, open(directory / source.name, 'wb') as out:
        reader = make_reader(stream)
        writer = Writer(out, **writer_args)
        writer.start(profile='ros2', library='test')
        schemas: dict[int, int] = {}
        channels: dict[int, list[int]] = {}
        count = 0
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            if channel.id not in channels:
                if schema.id not in schemas:
                    schemas[schema.id] = writer.register_schema(schema.name, schema.encoding,
                                                                schema.data)
                copies = 2 if split_channels and channel.topic == '/joint_states' else 1
                channels[channel.id] = [writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id],
                    {**channel.metadata, 'offered_qos_profiles': qos_yaml(1 + k)})
                    for k in range(copies)]
            targets = channels[channel.id]
            writer.add_message(targets[count % len(targets)], message.log_time, message.data,
                               message.publish_time, message.sequence)
            count += 1
        writer.finish()
    return directory


def estimate(bag: Path) -> tuple[dict, str]:
    """Run the estimator pipeline over the bag's /joint_states messages.

    Returns the pipeline's summary after every /joint_states message, and how the bag was read.
    """
    pipeline = EstimatorPipeline(EstimatorConfig(ratio=3.0))
    with BagReader(bag) as reader:
        topic = reader.require_topic('joint_states', interfaces.JOINT_STATE_TYPE)
        for raw in reader.raw_batches([topic]):
            batch = codec.decode_joint_state_buffer(raw.buffer, raw.offsets, raw.lengths,
                                                    'motor', 'load')
            pipeline.on_batch(batch.stamp_ns, batch.motor_velocity, batch.motor_effort,
                              batch.load_velocity, batch.load_effort)
        return pipeline.summary(), reader.reader_kind


@pytest.fixture(scope='module')
def variants(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Each variant's bag (name -> directory), written once per test run for both tests."""
    def write(root: Path) -> None:
        for name, options in VARIANTS.items():
            rewrite(root / name, **options)
    root = build_once(tmp_path_factory, 'bag_variants', write)
    return {name: root / name for name in VARIANTS}


@pytest.fixture(scope='module')
def original() -> dict:
    summary, kind = estimate(WEARING)
    assert kind == 'mcap-chunks'
    assert summary['samples_seen'] == 30000 and summary['counts'].get('stamp_reset', 0) == 0
    return summary


@pytest.mark.parametrize('variant, kind', [('two-channels', 'mcap-chunks'),
                                           ('no-chunk-index-no-statistics', 'mcap-scan')])
def test_variant_gives_the_original_u(variants: dict[str, Path], original: dict, variant: str,
                                      kind: str) -> None:
    summary, used = estimate(variants[variant])
    assert used == kind
    assert summary['samples_seen'] == 30000
    assert summary['counts'].get('stamp_reset', 0) == 0
    assert summary['u'] == pytest.approx(original['u'], abs=1e-9)
    assert summary['sigma_u'] == pytest.approx(original['sigma_u'], abs=1e-9)
    assert summary['filter_updates'] == original['filter_updates']


def test_variants_through_gear_phm_analyze(variants: dict[str, Path], tmp_path: Path) -> None:
    """The same through the CLI users run: ``gear-phm analyze`` of each variant.

    It gives the original bag's u and sigma to 1e-9 (summary.json).
    """
    import json

    from gear_phm.cli.main import main

    def analysed(bag: Path, name: str) -> dict:
        out = tmp_path / f'out-{name}'
        assert main(['analyze', str(bag), '--ratio', '3.0', '--out', str(out), '--no-plot',
                     '--no-progress']) == 0
        return json.loads((out / 'summary.json').read_text())

    expected = analysed(WEARING, 'original')
    for name, bag in variants.items():
        got = analysed(bag, name)
        assert got['messages'] == expected['messages'] == 30000
        assert got['u'] == pytest.approx(expected['u'], abs=1e-9)
        assert got['sigma_u'] == pytest.approx(expected['sigma_u'], abs=1e-9)
