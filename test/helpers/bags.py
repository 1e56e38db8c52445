"""Compare bags by content: the sample bags against a run of ``bags/regenerate.sh``.

Structure (metadata.yaml, profile, schemas, channels, statistics, chunks), topics, counts,
log/publish times, sequences, stamps and strings must be identical; float fields of decoded
messages may differ within RTOL/ATOL (bags/README.md).
"""
from __future__ import annotations

import math
from pathlib import Path

from mcap.reader import make_reader
import numpy as np
import yaml

from gear_phm.bagio import Rosbag2McapWriter, TYPESTORE
from gear_phm.interfaces import DiagnosticsOut, StatusOut, Vector3Out

#: The three single-bag samples of bags/.
SAMPLES = ('healthy', 'wearing', 'fault')
#: Size limits [bytes]: one sample bag, and all sample data in the repository.
SAMPLE_MAX_BYTES = 5 * 1024 * 1024
ALL_SAMPLES_MAX_BYTES = 10 * 1024 * 1024


#: Float fields of the regenerated bags may differ from the committed ones in the last bits:
#: numpy's ``exp`` rounds differently on another CPU's SIMD path (seen: 7e-15 on 1 772 of
#: 90 000 messages). Everything else must be identical.
RTOL = ATOL = 1e-12


def bag_content(directory: Path) -> tuple[dict, dict[str, list[tuple[int, int, int, bytes]]]]:
    """Return (structure, messages) of a rosbag2 MCAP bag, read with mcap's reader.

    Structure is metadata.yaml, the header profile, schemas, channels and statistics; messages
    are (log time, publish time, sequence, payload) per topic, in file order.
    """
    meta = yaml.safe_load((directory / 'metadata.yaml').read_text())
    [mcap_file] = directory.glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        stats = summary.statistics
        topics = {cid: c.topic for cid, c in summary.channels.items()}
        structure = {
            'files': sorted(p.name for p in directory.iterdir()), 'metadata': meta,
            'profile': reader.get_header().profile,
            'schemas': sorted((s.name, s.encoding, s.data) for s in summary.schemas.values()),
            'channels': sorted((c.topic, c.message_encoding, summary.schemas[c.schema_id].name,
                                sorted(c.metadata.items()))
                               for c in summary.channels.values()),
            'statistics': (stats.message_count, stats.message_start_time,
                           stats.message_end_time, stats.chunk_count,
                           {topics[c]: n for c, n in stats.channel_message_counts.items()}),
            'chunks': [(i.message_start_time, i.message_end_time, i.uncompressed_size,
                        i.compression) for i in summary.chunk_indexes],
        }
        messages: dict[str, list[tuple[int, int, int, bytes]]] = {}
        for _, channel, message in reader.iter_messages(log_time_order=False):
            messages.setdefault(channel.topic, []).append(
                (message.log_time, message.publish_time, message.sequence, message.data))
    return structure, messages


def differences(value: object, reference: object, where: str) -> list[str]:
    """Where two decoded messages differ: floats beyond RTOL/ATOL, anything else at all."""
    if isinstance(reference, np.ndarray):
        value = np.asarray(value)
        if value.shape != reference.shape or value.dtype != reference.dtype:
            return [f'{where}: {value.dtype}{value.shape} != {reference.dtype}'
                    f'{reference.shape}']
        if reference.dtype.kind == 'f':
            close = np.isclose(value, reference, rtol=RTOL, atol=ATOL, equal_nan=True)
            return [] if close.all() else [f'{where}: {value} != {reference}']
        return [] if np.array_equal(value, reference) else [f'{where}: {value} != {reference}']
    if isinstance(reference, float):
        ok = isinstance(value, float) and bool(np.isclose(value, reference, rtol=RTOL,
                                                          atol=ATOL, equal_nan=True))
        return [] if ok else [f'{where}: {value!r} != {reference!r}']
    if hasattr(reference, '__dataclass_fields__'):
        if type(value) is not type(reference):
            return [f'{where}: {type(value).__name__} != {type(reference).__name__}']
        return [d for name in reference.__dataclass_fields__
                for d in differences(getattr(value, name), getattr(reference, name),
                                     f'{where}.{name}')]
    if isinstance(reference, list):
        if not isinstance(value, list) or len(value) != len(reference):
            return [f'{where}: {value!r} != {reference!r}']
        return [d for i, (a, b) in enumerate(zip(value, reference))
                for d in differences(a, b, f'{where}[{i}]')]
    return [] if value == reference else [f'{where}: {value!r} != {reference!r}']


def bag_differences(directory: Path, reference: Path) -> list[str]:
    """Return every difference of ``directory`` from ``reference`` beyond float rounding.

    Structure, topics, counts, log/publish times, sequences, types and metadata exactly;
    payloads equal byte for byte, or else decoded and equal within RTOL/ATOL.
    """
    structure, messages = bag_content(directory)
    expected_structure, expected = bag_content(reference)
    if structure != expected_structure:
        return [f'structure: {structure} != {expected_structure}']
    if {t: len(m) for t, m in messages.items()} != {t: len(m) for t, m in expected.items()}:
        return ['message counts differ']
    types = {t['topic_metadata']['name']: t['topic_metadata']['type'] for t in
             structure['metadata']['rosbag2_bagfile_information']['topics_with_message_count']}
    found = []
    for topic, items in expected.items():
        for number, (got, want) in enumerate(zip(messages[topic], items)):
            if got[:3] != want[:3]:
                found.append(f'{topic}[{number}]: times/sequence {got[:3]} != {want[:3]}')
            elif got[3] != want[3]:
                found += differences(TYPESTORE.deserialize_cdr(got[3], types[topic]),
                                     TYPESTORE.deserialize_cdr(want[3], types[topic]),
                                     f'{topic}[{number}]')
    return found


def regenerated_differences(root: Path, reference: Path) -> list[str]:
    """Every difference of the sample bags under ``root`` from those under ``reference``.

    The three samples and every recording of every fleet unit by :func:`bag_differences`;
    each unit's truth.yaml exactly but for its wear parameters (floats within RTOL/ATOL).
    """
    found = [f'{name}: {d}' for name in SAMPLES
             for d in bag_differences(root / name, reference / name)]
    units = sorted(p.name for p in (reference / 'fleet').iterdir())
    if units != sorted(p.name for p in (root / 'fleet').iterdir()):
        return [*found, f'fleet units {sorted(p.name for p in (root / "fleet").iterdir())} '
                f'!= {units}']
    for unit in units:
        recordings = sorted(p.name for p in (reference / 'fleet' / unit).glob('rec_*'))
        if recordings != sorted(p.name for p in (root / 'fleet' / unit).glob('rec_*')):
            found.append(f'{unit}: recordings differ from {recordings}')
            continue
        found += [f'{unit}/{recording}: {d}' for recording in recordings
                  for d in bag_differences(root / 'fleet' / unit / recording,
                                           reference / 'fleet' / unit / recording)]
        truth = yaml.safe_load((root / 'fleet' / unit / 'truth.yaml').read_text())
        expected = yaml.safe_load((reference / 'fleet' / unit / 'truth.yaml').read_text())
        wear, expected_wear = truth.pop('wear'), expected.pop('wear')
        if truth != expected:
            found.append(f'{unit}/truth.yaml: {truth} != {expected}')
        if wear.keys() != expected_wear.keys() or wear['kind'] != expected_wear['kind'] or \
                not np.allclose([wear[k] for k in wear if k != 'kind'],
                                [expected_wear[k] for k in wear if k != 'kind'],
                                rtol=RTOL, atol=ATOL):
            found.append(f'{unit}/truth.yaml wear: {wear} != {expected_wear}')
    return found


JOINT_STATE = 'sensor_msgs/msg/JointState'


def joint_state(i: int, names: tuple[str, ...] = ('motor', 'load')) -> object:
    """Return JointState ``i`` of a test stream: stamp 10 s + i ms, speeds 0.5 i."""
    types = TYPESTORE.types
    header = types['std_msgs/msg/Header'](
        stamp=types['builtin_interfaces/msg/Time'](sec=10 + i // 1000, nanosec=(i % 1000) * 10**6),
        frame_id='')
    n = len(names)
    return types[JOINT_STATE](header=header, name=list(names),
                              position=np.arange(n, dtype=float) + i,
                              velocity=np.full(n, 0.5 * i), effort=np.linspace(-1.0, 1.0, n))


def write_bag(directory: Path, count: int, **kwargs: object) -> None:
    """Write ``count`` joint states, a friction vector and a /diagnostics array.

    ``kwargs``: the writer's options.
    """
    with Rosbag2McapWriter(directory, **kwargs) as writer:
        writer.add_topic('joint_states', JOINT_STATE)
        for i in range(count):
            writer.write('joint_states', 10**10 + i * 10**6, joint_state(i))
        writer.write_output(Vector3Out('gear_phm/friction', 10**10, 0.125, -1.5, math.inf))
        writer.write_output(DiagnosticsOut(10**10, (StatusOut(
            1, 'gear_phm: flap', 'warn', 'bench-1', (('u', '0.125'), ('rul_s', 'inf'))),)))
